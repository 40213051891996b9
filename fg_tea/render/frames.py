"""Render a frame plan into MP4 pieces in worker processes, and join them in order.

The rendered frames of a plan are cut into fixed pieces of :data:`PIECE_FRAMES` (the cuts do not
depend on the number of workers). Each piece is rendered and encoded into its own H.264 file by
one worker; the parent joins the pieces in order by remuxing. So the same plan and options give
the same bytes with any number of workers (tests/test_video_speed.py).

A frame held for reading (a decision, an observation: ``FrameSpec.repeat`` > 1) is rendered
once and encoded once, shown for its whole hold by its timestamps (no repeated pictures). A frame
whose scene (pose, placements, held object) is the previous frame's, or one shortly before it,
reuses that frame's camera views (:class:`RepeatedViews`; the hold after a motion ends where it
ended, a turn back retraces the turn): only its overlays are drawn anew.

Workers are started with the ``spawn`` method (no inherited simulator or encoder state), build
the render-only house once (:class:`~fg_tea.render.scene.SceneViews`), and die with the command
that started them (:func:`fg_tea.common.process.die_with_parent`).
"""

from __future__ import annotations

import os
from collections import OrderedDict
from dataclasses import replace
from pathlib import Path
from typing import Callable, Iterator, Sequence

import numpy as np

from fg_tea.common.files import atomic_path

#: Rendered frames per MP4 piece (each a separate encoding that starts with a key frame).
PIECE_FRAMES = 120
#: Bytes of camera images a worker keeps for scenes that come again (:class:`RepeatedViews`):
#: the default video's images are about 0.8 MB a scene, so about the last 80 scenes.
KEPT_BYTES = 64 * 2 ** 20


def pieces(count: int, size: int | None = None) -> list[tuple[int, int]]:
    """[lo, hi) ranges of `count` rendered frames, `size` (default :data:`PIECE_FRAMES`) each
    (the last may be shorter)."""
    size = size or PIECE_FRAMES
    return [(lo, min(lo + size, count)) for lo in range(0, count, size)]


def default_workers() -> int:
    """One worker per core this process may run on (at most 8)."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    return max(1, min(cores, 8))


class RepeatedViews:
    """Camera views that render only when the scene or the camera is new.

    Wraps a :class:`~fg_tea.render.scene.SceneViews`: a view asked for with the same arguments
    at a scene seen before (the previous frame's, or an earlier one still kept: a drone that turns
    and turns back, a walk retraced) is a copy of the image it gave then (the same pixels:
    rendering is a function of the scene and the camera). The images of the most recent scenes
    are kept, up to :data:`KEPT_BYTES` in all. ``rendered`` and ``reused`` count.
    """

    def __init__(self, views, kept_bytes: int | None = None) -> None:
        self.views, self.config = views, views.config
        self.kept_bytes = KEPT_BYTES if kept_bytes is None else kept_bytes
        self._scene: tuple | None = None
        self._kept: OrderedDict[tuple, dict[tuple, np.ndarray]] = OrderedDict()  # oldest first
        self._bytes = 0
        self.rendered = self.reused = 0

    def set_scene_state(self, pose, placements, held: str | None) -> None:
        scene = (tuple(pose), tuple(sorted((k, tuple(v)) for k, v in placements.items())), held)
        if scene != self._scene:
            self._scene = scene
            self.views.set_scene_state(pose, placements, held)
        self._kept.setdefault(scene, {})
        self._kept.move_to_end(scene)

    def chase_camera(self, *args):
        return self.views.chase_camera(*args)

    def chase(self, *args) -> np.ndarray:
        return self._view("chase", args)

    def ego(self, *args) -> np.ndarray:
        return self._view("ego", args)

    def _view(self, name: str, args: tuple) -> np.ndarray:
        key = (name, *args)
        assert self._scene is not None, "set_scene_state first"
        images = self._kept[self._scene]
        if key in images:
            self.reused += 1
        else:
            self.rendered += 1
            images[key] = getattr(self.views, name)(*args)
            self._bytes += images[key].nbytes
            self._forget()
        return images[key].copy()  # the frame is drawn on: the kept image stays clean

    def _forget(self) -> None:
        """Drop the oldest scenes' images (never the current scene's) while over the budget."""
        while self._bytes > self.kept_bytes and len(self._kept) > 1:
            scene = next(iter(self._kept))
            if scene == self._scene:
                self._kept.move_to_end(scene)
                continue
            self._bytes -= sum(image.nbytes for image in self._kept.pop(scene).values())

    def close(self) -> None:
        self.views.close()


class FrameRenderer:
    """Composes the output frames of a plan: one render-only house, mini-map and site table."""

    def __init__(self, plan, options) -> None:
        from fg_tea.env.base import EnvConfig
        from fg_tea.render.floorplan import MiniMap
        from fg_tea.render.scene import SceneViews
        from fg_tea.render.compose import load_plan_scenario

        self.plan, self.options = plan, options
        scenario = load_plan_scenario(plan)
        env_fields = {k: v for k, v in plan.env.items() if k in EnvConfig.__dataclass_fields__}
        config = replace(EnvConfig(), **env_fields)
        self.views = RepeatedViews(SceneViews(scenario, config, plan.seed, options.wall_cutaway))
        self.minimap = MiniMap(scenario, config.ego_hfov_deg)
        self.sites: dict[str, Sequence[float]] = dict(plan.site_positions or
                                                      {s.name: s.position for s in scenario.sites})

    def frame(self, index: int) -> np.ndarray:
        """The picture of rendered frame `index` of the plan."""
        from fg_tea.render.compose import compose_frame

        spec = self.plan.frames[index]
        return compose_frame(self.views, self.options, (spec.pose, self.plan.placements[spec.placements], spec.held),
                        self.plan.overlays[spec.overlay], self.minimap, self.sites)

    def encode(self, lo: int, hi: int, path: str | Path) -> int:
        """Render frames [lo, hi) into the MP4 `path`; return the output frames it shows."""
        from fg_tea.render.encoder import Mp4Writer

        o = self.options
        writer = Mp4Writer(path, o.width, o.height, o.fps, bframes=0, threads=1)
        try:
            for index in range(lo, hi):
                writer.write(self.frame(index), self.plan.frames[index].repeat)
            writer.close()
        except BaseException:
            writer.abort()
            raise
        return writer.frames

    def close(self) -> None:
        self.views.close()


_WORKER: FrameRenderer | None = None


def _start_worker(plan, options, parent_pid: int) -> None:
    """Pool initializer: die with the parent, build this process's renderer once."""
    global _WORKER
    from fg_tea.common.process import die_with_parent

    die_with_parent(parent_pid)
    _WORKER = FrameRenderer(plan, options)


def _encode_piece(task: tuple[int, int, str]) -> tuple[int, str]:
    lo, hi, path = task
    assert _WORKER is not None, "worker not started"
    return _WORKER.encode(lo, hi, path), path


def encode_pieces(plan, options, folder: Path, workers: int,
                  progress: Callable[[int, int], None] | None = None) -> Iterator[tuple[int, str]]:
    """Render and encode every piece of `plan` into `folder`; yield (output frames, path) in order."""
    spans = pieces(len(plan.frames))
    tasks = [(lo, hi, str(folder / f"piece{i:04d}.mp4")) for i, (lo, hi) in enumerate(spans)]
    total, done = plan.output_frames, 0
    workers = max(1, min(workers, len(tasks)))
    if workers == 1:
        renderer = FrameRenderer(plan, options)
        try:
            for lo, hi, path in tasks:
                count = renderer.encode(lo, hi, path)
                done += count
                if progress is not None:
                    progress(done, total)
                yield count, path
        finally:
            renderer.close()
        return
    import multiprocessing

    context = multiprocessing.get_context("spawn")
    with context.Pool(workers, initializer=_start_worker, initargs=(plan, options, os.getpid())) as pool:
        for count, path in pool.imap(_encode_piece, tasks):
            done += count
            if progress is not None:
                progress(done, total)
            yield count, path


def concat(segments: Sequence[str], out: Path) -> None:
    """Join H.264 MP4 pieces into one MP4 by remuxing packets with shifted timestamps."""
    import av

    with atomic_path(out, ".mp4") as tmp, av.open(str(tmp), "w", options={"movflags": "faststart"}) as dst:
        stream = None
        offset = 0
        for seg in segments:
            with av.open(seg) as src:
                s_in = src.streams.video[0]
                if stream is None:
                    stream = dst.add_stream_from_template(s_in)
                last = 0
                for packet in src.demux(s_in):
                    if packet.dts is None:
                        continue
                    packet.pts = (packet.pts or 0) + offset
                    packet.dts = packet.dts + offset
                    last = max(last, packet.pts + (packet.duration or 0))
                    packet.stream = stream
                    dst.mux(packet)
                offset = last
