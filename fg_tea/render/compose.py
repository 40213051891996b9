"""How one output frame of a video is made (docs/design.md §9): the options and the frame plan's
data classes, the house a logged episode took place in, and the composition of the camera views
and the overlays into a frame. :mod:`fg_tea.render.video` plans the frames of a log;
:mod:`fg_tea.render.frames` renders them in worker processes; both compose frames here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from fg_tea.render.overlay import OverlayState, draw_overlays

VIEWS = ("multi", "first", "third")


@dataclass(frozen=True)
class VideoOptions:
    """Rendering options (defaults: docs/design.md §8.6; the views: §9).

    Attributes:
        width, height: output size in pixels (even).
        fps: output frame rate.
        view: ``multi`` (chase view with first-person inset), ``first`` or ``third``.
        inset_scale: inset width as a fraction of the frame width (multi view).
        chase_distance, chase_height, chase_pitch_deg, chase_hfov_deg: chase camera (m, m, deg, deg).
        hold_seconds: how long selected frames are held for reading.
        frame_stride: render every n-th frame of motion and hold each pause 1/n as long: a
            draft about n times shorter and cheaper (1 = every frame).
        workers: rendering processes (0 = one per core).
        overlays: draw the explanatory panels.
        scene_scale: the 3D views are rendered at this fraction of the output size and scaled
            up, so overlays stay sharp at a fraction of the rendering cost (1.0 = native).
        wall_cutaway: chase view only: draw walls up to this height (m), a dollhouse view
            (None = full walls; the first-person view always shows full walls).
    """

    width: int = 960
    height: int = 540
    fps: int = 30
    view: str = "multi"
    inset_scale: float = 0.3
    chase_distance: float = 3.2
    chase_height: float = 2.2
    chase_pitch_deg: float = -22.0
    chase_hfov_deg: float = 78.0
    hold_seconds: float = 0.8
    frame_stride: int = 1
    workers: int = 0
    overlays: bool = True
    scene_scale: float = 1.0
    wall_cutaway: float | None = 1.0

    def __post_init__(self) -> None:
        if self.view not in VIEWS:
            raise ValueError(f"view must be one of {', '.join(VIEWS)}, got {self.view!r}")
        if self.width % 2 or self.height % 2 or self.width < 64 or self.height < 64:
            raise ValueError(f"video size must be even and at least 64x64, got {self.width}x{self.height}")
        if self.frame_stride < 1:
            raise ValueError("frame_stride must be at least 1")
        if not 0.1 <= self.scene_scale <= 1.0:
            raise ValueError(f"scene_scale must be in [0.1, 1], got {self.scene_scale}")


@dataclass
class FrameSpec:
    """One output frame: where everything is, and what the overlays say."""

    pose: tuple[float, float, float]
    placements: int  # index into the placements table
    held: str | None
    overlay: int  # index into the overlay table
    repeat: int = 1  # output frames this rendered frame is shown for


@dataclass
class FramePlan:
    """Everything needed to render a log's video."""

    scenario_file: str
    scenario_name: str
    seed: int
    env: dict
    frames: list[FrameSpec] = field(default_factory=list)
    placements: list[dict[str, tuple[float, float, float]]] = field(default_factory=list)
    overlays: list[OverlayState] = field(default_factory=list)
    site_positions: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    viewpoints: dict[str, dict] = field(default_factory=dict)
    #: ``episode_start.inputs.scenario`` (bundle path and sha256) in logs that record it.
    scenario_input: dict | None = None
    #: Event ``seq`` -> the output frame at which that event's frames begin (the explorer seeks
    #: the video there).
    event_frames: dict[int, int] = field(default_factory=dict)

    @property
    def output_frames(self) -> int:
        return sum(f.repeat for f in self.frames)


def load_plan_scenario(plan: FramePlan):
    """The house of a logged episode.

    Tried in order: the file the log names (a user's path, relative to the current folder, or
    an absolute path in older logs); the bundled file at the bundle path the log records; a
    bundled scenario of the logged name. When the log records a sha256 and the file found has
    other bytes, a warning says so (the video then shows today's house).
    """
    import warnings

    from fg_tea.episode.provenance import bundled_file, sha256_file
    from fg_tea.world.scenario import load_scenario

    recorded = plan.scenario_input or {}
    path = Path(plan.scenario_file) if plan.scenario_file else None
    if path is None or not path.is_file():
        inside = bundled_file(recorded["bundled"]) if recorded.get("bundled") else None
        path = inside
    if path is None:
        return load_scenario(plan.scenario_name.split("#")[0])
    expected = recorded.get("sha256")
    if expected and sha256_file(path) != expected:
        warnings.warn(f"{path}: not the scenario file the log was written with (sha256 differs); "
                      "rendering the house as it is now", stacklevel=2)
    return load_scenario(path)


def _scaled(render, w: int, h: int, scale: float) -> np.ndarray:
    """Render at scale * (w, h) and resize to (w, h)."""
    import cv2

    if scale >= 1.0:
        return np.ascontiguousarray(render(w, h))
    sw, sh = max(int(w * scale) // 2 * 2, 16), max(int(h * scale) // 2 * 2, 16)
    return cv2.resize(np.ascontiguousarray(render(sw, sh)), (w, h), interpolation=cv2.INTER_LINEAR)


#: Half size (m) of the region around the agent where no site name is written in the chase view:
#: the drone's radius (0.17 m) plus a held object in front of it, about 0.1 m more.
AGENT_CLEAR_M = 0.28


def pose_xy(pose) -> tuple[float, float]:
    return (pose.x, pose.y) if hasattr(pose, "x") else (float(pose[0]), float(pose[1]))


def project_points(view: Sequence[float], proj: Sequence[float], width: int, height: int,
                   points: dict[str, Sequence[float]]) -> dict[str, tuple[float, float, float]]:
    """Project world points (x, y, z m) through a camera (pybullet column-major matrices).

    Returns:
        name -> (column px, row px, depth m along the optical axis) for points in front of the
        camera (on or off the image).
    """
    if not points:
        return {}
    names = list(points)
    world = np.array([[*points[n][:3], 1.0] for n in names]).T
    clip = np.reshape(proj, (4, 4)).T @ np.reshape(view, (4, 4)).T @ world
    out = {}
    for i, name in enumerate(names):
        wc = clip[3, i]
        if wc <= 0.05:
            continue
        out[name] = ((clip[0, i] / wc + 1) / 2 * width, (1 - clip[1, i] / wc) / 2 * height, float(wc))
    return out


def compose_frame(views, options: VideoOptions, scene_state: tuple, overlay: OverlayState | None,
             minimap=None, sites: dict[str, Sequence[float]] | None = None) -> np.ndarray:
    """One output frame: the camera views and, if enabled, the overlays.

    Args:
        views: a :class:`~fg_tea.render.scene.SceneViews` (or a reset PyBulletHouse, drawn by the
            plain renderer) whose chase walls stand at ``options.wall_cutaway``.
        options: rendering options.
        scene_state: (pose, placements, held object).
        overlay: what the panels say (None: no panels).
        minimap: a :class:`~fg_tea.render.floorplan.MiniMap` for the right column.
        sites: site -> surface position (x, y, z m), named in the chase view.
    """
    from fg_tea.render.scene import HouseViews

    if not hasattr(views, "chase"):
        views = HouseViews(views, options.wall_cutaway)
    w, h = options.width, options.height
    pose, placements, held = scene_state
    views.set_scene_state(pose, placements, held)
    inset = None
    scale = options.scene_scale
    site_pixels, keep_clear = None, []
    if options.view == "first":
        frame = _scaled(views.ego, w, h, scale)
    else:
        chase = (options.chase_distance, options.chase_height, options.chase_pitch_deg, options.chase_hfov_deg)
        frame = _scaled(lambda a, b: views.chase(a, b, *chase), w, h, scale)
        if sites and overlay is not None and options.overlays:
            view, proj = views.chase_camera(w, h, *chase)
            site_pixels = project_points(view, proj, w, h, {k: (v[0], v[1], v[2] + 0.05) for k, v in sites.items()})
            # Names keep clear of the agent (and what it carries): a square of AGENT_CLEAR_M.
            agent = project_points(view, proj, w, h, {"agent": (pose_xy(pose)[0], pose_xy(pose)[1],
                                                                  views.config.sensor_height)})
            if "agent" in agent:
                u, v, depth = agent["agent"]
                r = AGENT_CLEAR_M * w / (2 * math.tan(math.radians(options.chase_hfov_deg) / 2)) / depth
                keep_clear.append((int(u - r), int(v - r), int(u + r), int(v + r)))
        if options.view == "multi":
            iw = int(w * options.inset_scale) // 2 * 2
            ih = int(iw * 3 / 4) // 2 * 2
            ego = _scaled(views.ego, iw, ih, max(scale, 0.75))
            x0 = w - iw - 4
            frame[2:ih + 6, x0 - 2:x0 + iw + 2] = 255
            frame[4:ih + 4, x0:x0 + iw] = ego
            inset = (x0 - 2, 0, w, ih + 6)
    if overlay is not None and options.overlays:
        pose_xyyaw = tuple(pose.as_list()) if hasattr(pose, "as_list") else tuple(pose)
        draw_overlays(frame, overlay, inset, minimap, pose_xyyaw, site_pixels, keep_clear)
    return frame
