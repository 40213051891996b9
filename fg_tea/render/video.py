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
import os
import tempfile
from pathlib import Path
from typing import Callable, Sequence

from fg_tea.episode.log import read_log
# The options and the frame plan's classes live with the frame's composition; named here too.
from fg_tea.render.compose import VIEWS, FramePlan, FrameSpec, VideoOptions  # noqa: F401
from fg_tea.render.overlay import OverlayState
from fg_tea.world.interface import logged_viewpoint

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
        elif kind == "substitute":  # a search given up or an object used up: another serves its role (§7.6)
            clear_look()
            ov.phase, ov.focus_object, ov.candidates = "SUBSTITUTE", e["substitute"], []
            why = "used up" if e.get("cause") == "used_up" else "given up"
            ov.caption = f"{e['object']} {why}: the {e['substitute']} stands in for it"
            emit([], repeat_last=hold)
        elif kind == "alternative_method":  # retries spent: the action is done another way (§7.6)
            ov.phase = "ALTERNATIVE"
            ov.caption = f"{e['action']} another way: {e.get('description') or e['after'].get('verb')}"
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
