"""Video: H.264 MP4 that decodes, re-rendered from a log (short form in CI; full size is slow)."""

from __future__ import annotations

import numpy as np
import pytest

from fg_tea.cli import main
from fg_tea.episode.log import read_log
from fg_tea.render.encoder import probe
from fg_tea.render.video import VideoOptions, plan_frames


@pytest.fixture(scope="module")
def logged(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    assert main(["run", "--no-video", "--out", str(out), "--seed", "1"]) == 0
    return out / "episode.jsonl"


def test_frame_plan_replays_every_motion_frame(logged):
    events = read_log(logged)
    options = VideoOptions(hold_seconds=0.5)
    plan = plan_frames(events, options)
    motion = sum(len(e.get("motion", [])) for e in events)
    rendered_motion = sum(1 for f in plan.frames if f.repeat == 1)
    assert rendered_motion >= motion  # every pose of motion is a frame
    assert plan.output_frames > motion  # plus held frames for reading
    held = [f for f in plan.frames if f.repeat == 15]
    assert held, "decision frames are held for hold_seconds * fps output frames"
    # The held object rides with the agent between its PICK and its PLACE/INSERT.
    assert {f.held for f in plan.frames} >= {None, "mug", "teabag", "kettle"}


def test_render_from_log_gives_a_decodable_browser_mp4(logged, tmp_path):
    out = tmp_path / "small.mp4"
    code = main(["render", str(logged), "--out", str(out), "--width", "192", "--height", "108",
                 "--frame-stride", "12", "--hold", "0.1", "--workers", "2"])
    assert code == 0
    info = probe(out)
    assert info["codec"] == "h264" and info["pix_fmt"] == "yuv420p" and info["fps"] == 30.0
    assert (info["width"], info["height"]) == (192, 108)
    assert info["frames"] > 50
    assert not list(tmp_path.glob(".*partial*"))


def test_views_differ_and_overlays_draw(logged, tmp_path):
    import av

    frames = {}
    for view in ("first", "third"):
        out = tmp_path / f"{view}.mp4"
        assert main(["render", str(logged), "--out", str(out), "--view", view, "--width", "128",
                     "--height", "72", "--frame-stride", "40", "--hold", "0.05", "--workers", "1"]) == 0
        with av.open(str(out)) as c:
            frames[view] = next(iter(c.decode(video=0))).to_ndarray(format="rgb24")
    assert not np.array_equal(frames["first"], frames["third"])


def test_bad_log_is_one_line(tmp_path, capsys):
    bad = tmp_path / "x.jsonl"
    bad.write_text('{"event": "something"}\n')
    assert main(["render", str(bad)]) == 2
    assert "not an fg_tea episode log" in capsys.readouterr().err


@pytest.mark.slow
def test_full_size_default_video(logged, tmp_path):
    out = tmp_path / "full.mp4"
    assert main(["render", str(logged), "--out", str(out)]) == 0
    info = probe(out)
    assert (info["width"], info["height"]) == (960, 540) and info["frames"] > 1500


def test_wall_cutaway_is_for_people_only():
    """Lowered walls change the chase view; the agent's camera and evidence stay as they were."""
    from fg_tea.env.base import EnvConfig
    from fg_tea.env.house import PyBulletHouse
    from fg_tea.scenario import load_scenario

    house = PyBulletHouse(load_scenario("default_apartment"), EnvConfig(ego_width=160, ego_height=120))
    try:
        house.reset(0)
        ego_before = house.render_ego(160, 120)
        full = house.render_chase(192, 108)
        cut = house.render_chase(192, 108, wall_cutaway=1.0)
        ego_after = house.render_ego(160, 120)
        assert np.abs(full.astype(int) - cut.astype(int)).mean() > 5  # the view opens up
        for before, after in zip(ego_before, ego_after):
            assert np.array_equal(before, after)  # walls restored for the agent
        assert np.array_equal(full, house.render_chase(192, 108))
    finally:
        house.close()
