"""The cheaper video looks the same, is the same with any number of workers, and renders a held
frame once.

Reference frames (tests/data/video_frames) were rendered by the renderer as it was before the
video was made cheaper, from the default episode with ``fg-tea run``'s video options.
"""

from __future__ import annotations

import dataclasses
import hashlib

import numpy as np
import pytest

from fg_tea.render.encoder import Mp4Writer, probe
from fg_tea.render.frames import FrameRenderer, pieces
from fg_tea.render.video import VideoOptions, plan_frames, render_video
from video_reference import FRAMES, check_frames_against, default_episode, default_options, psnr

DATA = __import__("pathlib").Path(__file__).parent / "data" / "video_frames"


@pytest.fixture(scope="module")
def default_events(tmp_path_factory):
    return default_episode(tmp_path_factory.mktemp("default"))


#: Reference frames: the old renderer's, and those of commit be13560, the code before the video
#: was made cheaper (tests/data/video_frames/make_references.py).
REFERENCES = ("video_frames", "video_frames_be13560")


@pytest.mark.slow
@pytest.mark.parametrize("folder", REFERENCES)
def test_frames_match_the_reference_frames(folder, default_events):
    check_frames_against(DATA.parent / folder, default_events)


@pytest.mark.parametrize("folder", REFERENCES)
def test_a_wrong_frame_falls_below_the_threshold(folder):
    """The check can fail: two different reference frames are far below 40 dB."""
    from PIL import Image

    a, b = (np.asarray(Image.open(DATA.parent / folder / f"frame{n:04d}.png").convert("RGB")) for n in FRAMES[:2])
    assert psnr(a, b) < 25.0


def _short_options(**changes) -> VideoOptions:
    return dataclasses.replace(default_options(), width=192, height=108, hold_seconds=0.2, fps=10,
                               frame_stride=25, **changes)


@pytest.mark.slow
def test_the_same_bytes_with_any_number_of_workers(default_events, tmp_path, monkeypatch):
    import fg_tea.render.frames as frames

    monkeypatch.setattr(frames, "PIECE_FRAMES", 7)  # several pieces from a short video
    options = _short_options()
    plan = plan_frames(default_events, options)
    assert len(frames.pieces(len(plan.frames), frames.PIECE_FRAMES)) >= 3
    digests = {}
    for workers in (1, 2, 3):
        out = tmp_path / f"w{workers}.mp4"
        result = render_video(default_events, out, dataclasses.replace(options, workers=workers))
        assert result["frames"] == plan.output_frames
        digests[workers] = hashlib.sha256(out.read_bytes()).hexdigest()
    assert len(set(digests.values())) == 1, digests
    info = probe(tmp_path / "w2.mp4")
    assert info["frames"] == len(plan.frames)  # one picture per rendered frame
    assert info["seconds"] == pytest.approx(plan.output_frames / options.fps, abs=1.5 / options.fps)


def test_pieces_cover_every_frame_once():
    for count in (1, 7, 119, 120, 121, 1717):
        spans = pieces(count, 120)
        assert spans[0][0] == 0 and spans[-1][1] == count
        assert all(a[1] == b[0] for a, b in zip(spans, spans[1:]))
        assert all(0 < hi - lo <= 120 for lo, hi in spans)


def test_a_held_frame_is_encoded_once_and_shown_for_its_hold(tmp_path):
    writer = Mp4Writer(tmp_path / "held.mp4", 64, 64, fps=10, bframes=0, threads=1)
    rng = np.random.default_rng(0)
    for repeat in (1, 24, 1, 3):
        writer.write(rng.integers(0, 255, (64, 64, 3), dtype=np.uint8), repeat)
    writer.close()
    assert (writer.pictures, writer.frames) == (4, 29)
    info = probe(tmp_path / "held.mp4")
    assert info["frames"] == 4
    assert info["seconds"] == pytest.approx(2.9, abs=0.05)


@pytest.mark.slow
def test_held_frames_are_rendered_once(default_events, tmp_path):
    """Each rendered frame asks for one chase and one inset image, however long it is held (a
    frame whose scene is the previous frame's reuses its images)."""
    options = dataclasses.replace(default_options(), width=192, height=108, workers=1)
    plan = plan_frames(default_events, options)
    held = [i for i, f in enumerate(plan.frames) if f.repeat > 1]
    assert held and plan.frames[held[1]].repeat == 24
    renderer = FrameRenderer(plan, options)
    try:
        lo, hi = held[1] - 1, held[1] + 2  # motion, a decision held for 0.8 s, motion
        shown = renderer.encode(lo, hi, tmp_path / "piece.mp4")
        assert shown == sum(f.repeat for f in plan.frames[lo:hi]) > hi - lo
        assert renderer.views.rendered + renderer.views.reused == 2 * (hi - lo)
        assert renderer.views.views.calls == renderer.views.rendered
    finally:
        renderer.close()


@pytest.mark.slow
@pytest.mark.skipif(not __import__("sys").platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux only")
def test_killed_render_leaves_no_workers(default_events, tmp_path):
    """kill -9 of `fg-tea render --workers 2` once its workers run: they and the resource tracker go too."""
    import json
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    log = tmp_path / "episode.jsonl"
    log.write_text("".join(json.dumps(e) + "\n" for e in default_events))
    root = Path(__file__).resolve().parents[1]
    parent = subprocess.Popen([sys.executable, "-m", "fg_tea.cli", "render", str(log), "--workers", "2",
                               "--out", str(tmp_path / "v.mp4")], cwd=root,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    children: set[int] = set()
    deadline = time.monotonic() + 600  # a hang guard (a loaded machine is slow to start workers)
    try:
        while time.monotonic() < deadline:  # the tracker and two workers
            children = {int(p) for p in subprocess.run(["ps", "-o", "pid=", "--ppid", str(parent.pid)],
                                                       capture_output=True, text=True).stdout.split()}
            if len(children) >= 3:
                time.sleep(1.0)  # the workers are past their initializer
                break
            time.sleep(0.2)
        else:
            pytest.fail(f"render did not start its workers in time (children {children})")
    finally:
        parent.kill()
        parent.wait()
    left = set(children)
    for _ in range(1200):  # up to a minute (a dead worker leaves at once)
        for pid in list(left):
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                left.discard(pid)
        if not left:
            return
        time.sleep(0.05)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    pytest.fail(f"processes {sorted(left)} outlived the killed render")
