"""Re-render an episode's video from its log, without re-running the agent (docs/design.md §9).

The log holds everything a frame needs: the agent pose at every frame of motion, where objects
stand after each action, which object is held, and the beliefs, decision, task statuses and
hidden-state probabilities to overlay. :func:`plan_frames` turns the events into a list of frame
specifications; :func:`render_video` renders them with a render-only copy of the PyBullet house
(chase view with a first-person inset, or either alone; :mod:`fg_tea.render.scene`), in worker
processes over fixed pieces of the frames, and joins the pieces in order into one H.264 MP4 by
remuxing (:mod:`fg_tea.render.frames`): the same bytes with any number of workers.

Selected frames (decisions, observations, actions, skips) are held for a moment so a viewer can
read the overlays; a held frame is rendered and encoded once and shown for the whole hold. The
overlays add a mini-map of the house with the current look's field of view and covered sites,
and the names of the sites in the chase view (:mod:`fg_tea.render.overlay`).
Logs written before viewpoints existed still render: a look without ``viewpoint`` is a close look
at its ``site``, and one without ``sites_in_view`` covers just that site.
"""

from __future__ import annotations

import copy
import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from fg_tea.episode.log import read_log
from fg_tea.render.overlay import OverlayState, draw_overlays
from fg_tea.world.interface import logged_viewpoint

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


def _top_candidates(decision: dict, n: int = 4) -> list[dict]:
    return sorted(decision.get("candidates", []), key=lambda c: c["total"])[:n]


def plan_frames(events: list[dict], options: VideoOptions) -> FramePlan:
    """Turn a log's events into frame specifications (pure; no rendering)."""
    start = next((e for e in events if e.get("event") == "episode_start"), None)
    if start is None:
        raise ValueError("the log has no episode_start event")
    plan = FramePlan(start["scenario_file"], start["scenario"], int(start["seed"]),
                     start["parameters"]["env"])
    plan.scenario_input = (start.get("inputs") or {}).get("scenario")
    plan.site_positions = {s["name"]: tuple(s["position"]) for s in start["sites"] if "position" in s}
    vantages = {s["name"]: s.get("vantage") for s in start["sites"]}
    plan.viewpoints = {v["name"]: v for v in start.get("viewpoints", [])}
    # A draft (frame_stride n > 1) is about n times shorter and cheaper than the full video: every
    # n-th frame of motion is rendered and shown once, and every pause is n times shorter.
    hold = max(1, int(round(options.hold_seconds * options.fps)) // options.frame_stride)
    placements = {k: tuple(v) for k, v in start["world"]["placements"].items()}
    plan.placements.append(dict(placements))
    held: str | None = None
    pose = tuple(start["pose"])
    tasks = [tuple(t) for t in start["tasks"]]
    status = dict(tasks)
    ov = OverlayState(phase="start", caption=f"{start['scenario']} · {start['model']} model · "
                      f"seed {start['seed']}", sites=[s["name"] for s in start["sites"]],
                      locations=start["belief"]["locations"], tasks=tasks,
                      states=start["belief"]["states"])

    def set_look(e: dict, sites_in_view: list[str] | None) -> None:
        """The viewpoint of a decision or observation; older logs name only the site."""
        name = logged_viewpoint(e)
        kind = e.get("viewpoint_kind", "site")
        info = plan.viewpoints.get(name, {})
        if sites_in_view is None:
            sites_in_view = list(info.get("sites", [name]))
        ov.viewpoint, ov.viewpoint_kind, ov.sites_in_view = name, kind, list(sites_in_view)
        position = info.get("position") or (vantages.get(name) if kind == "site" else None)
        ov.viewpoint_position = list(position[:2]) if position else None
        ov.viewpoint_room = info.get("room")
        if kind == "room" and ov.viewpoint_room is None:
            rooms = {s["room"] for s in start["sites"] if s["name"] in sites_in_view and "room" in s}
            ov.viewpoint_room = rooms.pop() if len(rooms) == 1 else name

    def where() -> str:
        if ov.viewpoint_kind == "room":
            return f"room glance: {ov.viewpoint_room} ({len(ov.sites_in_view)} sites)"
        return ov.viewpoint or ""

    def clear_look() -> None:
        ov.viewpoint, ov.viewpoint_kind, ov.viewpoint_room = None, "site", None
        ov.viewpoint_position, ov.sites_in_view, ov.found_at = None, [], {}

    def push_overlay() -> int:
        plan.overlays.append(copy.deepcopy(ov))
        return len(plan.overlays) - 1

    output = 0  # output frames planned so far

    def emit(motion: Sequence[Sequence[float]], repeat_last: int = 0) -> None:
        nonlocal pose, output
        index = push_overlay()
        for i, p in enumerate(motion):
            if i % options.frame_stride and i != len(motion) - 1:
                continue
            pose = tuple(p)
            plan.frames.append(FrameSpec(pose, len(plan.placements) - 1, held, index))
            output += 1
        if repeat_last:
            plan.frames.append(FrameSpec(pose, len(plan.placements) - 1, held, push_overlay(), repeat_last))
            output += repeat_last

    emit([], repeat_last=hold)
    for n, e in enumerate(events):
        kind = e.get("event")
        plan.event_frames[int(e.get("seq", n))] = output if n else 0  # the start shows first
        if kind == "decision":
            ov.phase, ov.focus_object, ov.selected_site = "SEARCH", e["object"], logged_viewpoint(e)
            set_look(e, None)
            ov.found_at = {}
            several = e.get("objects") or []  # one look serves every search on the frontier (§6.1)
            ov.caption = ((f"serves {', '.join(several)}; " if len(several) > 1 else "")  # first: never cut
                          + f"plan: look for the {e['object']} at {where()} ({e['planner']})")
            ov.candidates = _top_candidates(e)
            emit([], repeat_last=hold)
        elif kind == "observation":
            set_look(e, e.get("sites_in_view"))
            ov.found_at = {}
            ov.caption = f"going to {where()} for {', '.join(e['objects'])}"
            emit(e.get("motion", []))
            ov.locations = {**ov.locations, **e["after"]}
            seen = [o for o, v in e["detections"].items() if v]
            found_at = e.get("found_at") or {}
            ov.found_at = {o: found_at.get(o, logged_viewpoint(e)) for o in seen}
            if seen:
                found = ", ".join(f"{o} on {ov.found_at[o]}" if ov.viewpoint_kind == "room" else o
                                  for o in seen)
                ov.caption = f"{where()}: found {found}"
            else:
                ov.caption = f"{where()}: nothing found — belief moves away"
            emit([], repeat_last=hold)
        elif kind in ("action", "state_reading", "action_failed"):
            name = e.get("action") or e.get("state", "")
            verb = e.get("verb") or ("INSPECT" if kind == "state_reading" else "")
            ov.phase, ov.selected_site, ov.candidates = verb, None, []
            ov.focus_object = None
            clear_look()
            if kind == "state_reading":
                ov.caption = f"reading {e.get('state')} ({e.get('purpose')})"
            elif kind == "action_failed":
                ov.caption = f"{name} failed: {e.get('reason')}"
            else:
                ov.caption = f"{name}"
            emit(e.get("motion", []))
            if kind == "action":
                if e.get("placements"):
                    placements = {**placements, **{k: tuple(v) for k, v in e["placements"].items()}}
                    plan.placements.append(dict(placements))
                objects = e.get("objects_after", {})
                held = next((o for o, s in objects.items() if s.get("held")), None)
                ov.states = e.get("belief_after", ov.states)
            if kind == "state_reading":
                ov.caption = f"{e.get('state')} read {'true' if e.get('value') else 'false'}: " \
                             f"q {e.get('before', 0):.2f} -> {e.get('after', 0):.2f}"
            emit([], repeat_last=hold)
        elif kind == "skip":
            clear_look()
            ov.phase, ov.caption = "SKIP", f"{e['action']} skipped: its goal already holds"
            emit([], repeat_last=hold)
        elif kind == "belief":
            ov.locations, ov.states = e["locations"], e["states"]
        elif kind == "activate":  # the action now being carried out is drawn as active
            status[e["action"]] = "active"
            ov.tasks = [(n, status[n]) for n, _ in tasks]
        if "graph" in e or "graph_after" in e:
            graph = e.get("graph_after") or e.get("graph")
            if isinstance(graph, dict):
                status.update(graph)
                ov.tasks = [(n, status[n]) for n, _ in tasks]
        if kind == "episode_end":
            ov.phase = "END"
            ov.caption = f"episode ended: {e['reason']}"
            emit([], repeat_last=2 * hold)
    return plan


# ---------------------------------------------------------------------------------- rendering
def _load_scenario(plan: FramePlan):
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


def _compose(views, options: VideoOptions, scene_state: tuple, overlay: OverlayState | None,
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


def render_still(events: list[dict], out: str | Path, frame: int,
                 options: VideoOptions = VideoOptions()) -> dict:
    """Write output frame `frame` (0-based, as in the video) of a log's video as a PNG.

    The same frame the video shows at that index, rendered alone: for the documentation's
    pictures (``fg-tea render LOG --still N``), without rendering the whole video.

    Raises:
        ValueError: `frame` is not a frame of the video.
    """
    from fg_tea.common.files import write_png

    plan = plan_frames(events, options)
    if not 0 <= frame < plan.output_frames:
        raise ValueError(f"frame {frame} is not in the video (frames 0 to {plan.output_frames - 1})")
    seen, index = 0, 0
    for index, spec in enumerate(plan.frames):
        if seen + spec.repeat > frame:
            break
        seen += spec.repeat
    from fg_tea.render.frames import FrameRenderer

    renderer = FrameRenderer(plan, options)
    try:
        image = renderer.frame(index)
    finally:
        renderer.close()
    write_png(out, image)
    return {"path": str(out), "frame": frame, "frames": plan.output_frames,
            "caption": plan.overlays[plan.frames[index].overlay].caption}


def remove_stale_render_dirs(folder: str | Path) -> None:
    """Remove ``.render-PID-*`` folders in `folder` whose rendering process no longer runs.

    A render killed with SIGKILL cannot clean up after itself; the next render into the same
    folder does it (folders of renders still running are left alone).
    """
    import shutil

    for tmp in Path(folder).glob(".render-*"):
        pid = tmp.name.split("-")[1] if tmp.name.count("-") >= 2 else ""
        if pid.isdigit() and _alive(int(pid)):
            continue
        shutil.rmtree(tmp, ignore_errors=True)


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def render_video(events: list[dict], out: str | Path, options: VideoOptions = VideoOptions(),
                 progress: Callable[[int, int], None] | None = None) -> dict:
    """Render the video of a logged episode to `out` (an MP4, written atomically).

    Args:
        events: the episode's log events.
        out: the MP4 to write.
        options: rendering options.
        progress: called after each piece of rendered frames (:mod:`fg_tea.render.frames`) with
            (output frames done, total output frames).

    Returns:
        {"path", "frames" (output frames), "rendered" (distinct rendered frames), "workers"}.
    """
    from fg_tea.render.frames import concat, default_workers, encode_pieces

    plan = plan_frames(events, options)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    workers = options.workers or default_workers()
    remove_stale_render_dirs(out.parent)
    with tempfile.TemporaryDirectory(dir=out.parent, prefix=f".render-{os.getpid()}-") as tmp:
        results = list(encode_pieces(plan, options, Path(tmp), workers, progress))
        concat([path for _, path in results], out)
    return {"path": str(out), "frames": sum(count for count, _ in results), "rendered": len(plan.frames),
            "workers": max(1, min(workers, len(results)))}


def render_log(log_path: str | Path, out: str | Path | None = None,
               options: VideoOptions = VideoOptions()) -> dict:
    """Re-render the video of the log at `log_path` (default output: the log's name, .mp4)."""
    log_path = Path(log_path)
    out = Path(out) if out is not None else log_path.with_suffix(".mp4")
    return render_video(read_log(log_path), out, options)
