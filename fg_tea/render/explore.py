"""An episode in the browser: one self-contained HTML page from one log, or two side by side
(docs/design.md §9.2).

:func:`episode_data` turns a log into the page's data: one step per event with the beliefs, the
hidden-state probabilities, the entropies, the task statuses and the look in force after it; every
decision's candidate table with every term of its score; the agent's path. :func:`house_data`
draws the house from the scenario the log names (rooms, walls, furniture, sites, vantages), or,
when that file is gone, from the sites and viewpoints the log itself records, and says what is
missing. :func:`align` pairs two episodes of the same world decision by decision and finds the
first decision where their choices differ. :func:`write_page` inlines the data, the script and the
styles into one HTML file that opens from disk with no server and no network.

The page reads only what docs/design.md §9 documents; what an older log lacks is listed on the
page (``lacks``), never guessed.
"""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path
from typing import Any, Mapping, Sequence

from fg_tea.common.errors import InputError
from fg_tea.common.files import atomic_write_text
from fg_tea.episode.log import read_events
from fg_tea.render.captions import caption
from fg_tea.render.page import content_security_policy, fill, html_text, json_script
from fg_tea.world.interface import logged_viewpoint

#: Key :func:`read_episode` sets on the start event (in memory only) when the log's last line
#: was not whole JSON and was left out.
PARTIAL = "_explorer_partial_last_line"
#: The largest log the explorer reads (bytes): its page would be about twice as large, more than
#: a browser opens comfortably. Checked before the log is read.
EXPLORE_LOG_MAX_BYTES = 64 * 1024 ** 2
#: The largest page the explorer writes (bytes of its embedded data).
PAGE_MAX_BYTES = 96 * 1024 ** 2
#: Version of the page's data layout (the ``format`` of the embedded JSON).
PAGE_FORMAT = 1
#: How far (m) above its centre vantage a room's name is written on the plan.
ROOM_LABEL_RISE = 0.35
#: Every n-th pose of the agent's motion is kept for the drawn path (the last of each move always).
PATH_STRIDE = 6
#: The terms of a candidate's score, in the order the table shows them (others follow).
TERM_ORDER = ("object", "viewpoint", "total", "viewpoint_kind", "distance", "probability",
              "information_gain", "repeat", "relevance", "base")


def _major(version: str) -> int | None:
    try:
        return int(str(version).split(".")[0])
    except ValueError:
        return None


def read_episode(path: str | Path) -> list[dict]:
    """The events of the log at `path`, checked as the explorer needs them.

    Raises:
        InputError: not a log (no ``episode_start`` first), a line that is not an event, a log
            written by a newer major version of fg_tea than this one.
    """
    from fg_tea._version import __version__

    events, partial = read_events(path, strict=False)  # the log's meaning: fg_tea.episode.log_check
    if not events or events[0].get("event") != "episode_start":
        raise InputError(path, "line 1", "not an fg_tea episode log (it must start with episode_start)")
    start = events[0]
    for key in ("scenario", "sites", "belief"):
        if key not in start:
            raise InputError(path, "line 1", f"episode_start has no {key!r}: not a log this explorer can read")
    _check_start(path, start)
    if partial:  # the reader left out a partial last line (a crash mid-write)
        start[PARTIAL] = True
    written = str((start.get("versions") or {}).get("fg_tea", ""))
    ours, theirs = _major(__version__), _major(written)
    if theirs is not None and ours is not None and theirs > ours:
        raise InputError(path, "line 1", f"written by fg_tea {written}, newer than this fg_tea "
                                         f"{__version__}: open it with that version")
    return events


def _numbers(value: Any, least: int) -> bool:
    return (isinstance(value, list) and len(value) >= least
            and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in value))


def _check_start(path: str | Path, start: Mapping[str, Any]) -> None:
    """One line naming the first field of `episode_start` the page cannot draw."""
    def fault(field: str, what: str) -> InputError:
        return InputError(path, f"line 1: episode_start.{field}", what)

    sites = start["sites"]
    if not isinstance(sites, list) or not sites:
        raise fault("sites", "expected a non-empty list of sites")
    for i, site in enumerate(sites):
        if not isinstance(site, dict) or not isinstance(site.get("name"), str) \
                or not _numbers(site.get("position"), 2):
            raise fault(f"sites[{i}]", "expected a name and a position [x, y, ...]")
    locations = start["belief"].get("locations") if isinstance(start["belief"], dict) else None
    if not isinstance(locations, dict) or not locations:
        raise fault("belief.locations", "expected each object's probabilities over the sites")
    for obj, p in locations.items():
        if not _numbers(p, len(sites)) or len(p) != len(sites):
            raise fault(f"belief.locations.{obj}", f"expected {len(sites)} probabilities, one per site")
    if "pose" in start and not _numbers(start["pose"], 3):
        raise fault("pose", "expected [x, y, yaw]")


# ------------------------------------------------------------------------------------ the house
def logged_house(start: Mapping[str, Any]):
    """The scenario of a logged episode and a note, or (None, why) when its file is gone.

    Tried in order: the generated house of the world the log records (``inputs.world``, the house
    of the world seed after ``#`` in the scenario name); the scenario file the log names; the
    bundled file at the recorded bundle path; a bundled scenario of the logged name, only when its
    bytes are the ones the log records. A file found with other bytes than the log records is
    drawn as it is now, and the note says so.
    """
    from fg_tea.episode.provenance import bundled_file, sha256_file
    from fg_tea.world.distributions import load_world
    from fg_tea.world.scenario import load_scenario

    inputs = start.get("inputs") or {}
    name = str(start.get("scenario", ""))
    world = inputs.get("world") or {}
    base, _, seed = name.partition("#")

    def found(ref: str | None) -> Path | None:
        if not ref:
            return None
        path = Path(ref)
        return path if path.is_file() else bundled_file(ref)

    if world and seed.isdigit():
        for path in (found(world.get("file")), found(world.get("bundled"))):
            if path is None:
                continue
            try:
                dist = load_world(path)
            except InputError:
                continue
            if dist.generate is not None:
                return dist.house(int(seed)), None
            if dist.base is not None:
                return dist.base, None
    recorded = inputs.get("scenario") or {}
    expected = recorded.get("sha256")
    failed = None
    for ref in (start.get("scenario_file"), recorded.get("bundled")):
        path = found(ref)
        if path is None:
            continue
        try:
            scenario = load_scenario(path)
        except InputError as exc:
            failed = f"the scenario file {ref} no longer loads ({exc.fault})"
            continue
        if expected and sha256_file(path) != expected:
            return scenario, (f"the scenario file {ref} has changed since the log was written: "
                              "the house is drawn as it is now")
        return scenario, None
    try:
        from fg_tea.common.resources import resolve_scenario

        path = resolve_scenario(base)
        if not expected or sha256_file(path) == expected:
            return load_scenario(path), None
    except InputError:
        pass
    where = start.get("scenario_file") or (world.get("file") if world else None) or base
    return None, (failed or f"the scenario {where} is not on this machine") + \
        ": walls and furniture are not drawn, sites and viewpoints are from the log"


def house_data(start: Mapping[str, Any]) -> dict[str, Any]:
    """The floor plan's geometry in metres: floor, rooms, walls, furniture, sites, viewpoints."""
    from fg_tea.world.navigation import wall_boxes

    scenario, missing = logged_house(start)  # missing: a note when the house is gone or changed
    sites = [{"name": s["name"], "room": s.get("room"), "position": list(s["position"][:2]),
              "vantage": list(s["vantage"][:2]) if s.get("vantage") else None}
             for s in start["sites"] if "position" in s]
    viewpoints = [{"name": v["name"], "kind": v.get("kind", "site"), "position": list(v["position"][:2]),
                   "sites": list(v.get("sites", [])), "room": v.get("room")}
                  for v in start.get("viewpoints", [])]
    out: dict[str, Any] = {"sites": sites, "viewpoints": viewpoints, "walls": [], "furniture": [],
                           "missing": missing}
    if scenario is not None:
        house = scenario.house
        out["floor"] = [*map(float, house.floor_min[:2]), *map(float, house.floor_max[:2])]
        for box in wall_boxes(house):
            (cx, cy), (hu, hv), (ux, uy) = box.center, box.half, box.axis
            out["walls"].append([[round(cx + su * hu * ux - sv * hv * uy, 4),
                                  round(cy + su * hu * uy + sv * hv * ux, 4)]
                                 for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
        for f in house.furniture:
            (cx, cy), (sx, sy) = f.center[:2], f.size[:2]
            colour = "#%02x%02x%02x" % tuple(int(255 * min(max(c, 0.0), 1.0)) for c in f.color[:3])
            out["furniture"].append([round(cx - sx / 2, 4), round(cy - sy / 2, 4), round(sx, 4),
                                     round(sy, 4), colour])
    else:
        points = [s["position"] for s in sites] + [v["position"] for v in viewpoints]
        xs, ys = [p[0] for p in points], [p[1] for p in points]
        out["floor"] = [min(xs) - 1.0, min(ys) - 1.0, max(xs) + 1.0, max(ys) + 1.0]
    # A room's name goes just above its centre vantage (sites line the walls, so their centroid
    # falls among their labels), else at the mean of its room viewpoints, else of its sites.
    rooms: dict[str, list[list[float]]] = {}
    for s in sites:
        rooms.setdefault(str(s["room"]), []).append(s["position"])
    out["rooms"] = []
    for room, points in rooms.items():
        if room == "None":
            continue
        glances = [v for v in viewpoints if v["kind"] == "room" and v["room"] == room]
        centre = [v for v in glances if v["name"].endswith("_centre")]
        if centre:
            x, y = centre[0]["position"][0], centre[0]["position"][1] + ROOM_LABEL_RISE
        else:
            points = [v["position"] for v in glances] or points
            x, y = sum(p[0] for p in points) / len(points), sum(p[1] for p in points) / len(points)
        out["rooms"].append({"name": room, "centre": [round(x, 3), round(y, 3)]})
    return out


def task_edges(start: Mapping[str, Any]) -> list[list[str]] | None:
    """The task graph's dependency edges [before, after], from the task, model and scenario files
    the log names; None when one of them is gone (the page then lists the actions in order)."""
    from fg_tea.episode.provenance import bundled_file
    from fg_tea.model.spec import load_model
    from fg_tea.tasks.load import load_task

    inputs = start.get("inputs") or {}

    def path_of(record: Mapping[str, Any] | None) -> Path | None:
        if not record:
            return None
        for ref in (record.get("file"), record.get("bundled")):
            if ref:
                p = Path(ref) if Path(ref).is_file() else bundled_file(ref)
                if p is not None and p.is_file():
                    return p
        return None

    models = inputs.get("model") or []
    task, model = path_of(inputs.get("task")), path_of(models[0] if models else None)
    if not inputs:  # a log written before `inputs`: the model file and the task's bundled name
        from fg_tea.common.resources import resolve_model, resolve_task

        try:
            task = resolve_task(str(start.get("task")))
            model = path_of({"file": start.get("model_file")}) or resolve_model(str(start.get("model")))
        except InputError:
            return None
    scenario, _ = logged_house(start)
    if task is None or model is None or scenario is None:
        return None
    try:
        graph = load_task(task, load_model(model), scenario,
                          (start.get("parameters") or {}).get("run", {}).get("preparation_site"))
    except (InputError, ValueError):
        return None
    statuses = start.get("tasks") or []
    if [n for n, _ in statuses] and set(graph.ids) != {n for n, _ in statuses}:
        return None  # the task file changed since the log was written
    return [[a, b] for a, b in graph.nx_graph.edges]


# ---------------------------------------------------------------------------------- the episode
def _candidate_table(decision: Mapping[str, Any]) -> dict[str, Any]:
    rows = list(decision.get("candidates") or [])
    keys: list[str] = [k for k in TERM_ORDER if any(k in r for r in rows)]
    keys += sorted({k for r in rows for k in r} - set(keys))
    chosen = next((i for i, r in enumerate(rows)
                   if r.get("object") == decision.get("object")
                   and (r.get("viewpoint", r.get("site")) == logged_viewpoint(decision))), None)
    return {"columns": keys, "rows": [[r.get(k) for k in keys] for r in rows], "chosen": chosen}


def _entropy(p: Sequence[float]) -> float:
    return -sum(x * math.log(x) for x in p if x > 0)


def episode_data(events: list[dict], label: str | None = None, source: str | Path = "<log>") -> dict[str, Any]:
    """The page's data of one episode: the state after every event, and what the log lacks.

    Raises:
        InputError: an event whose fields are not what docs/design.md §9 says (`source` names
            the log).
    """
    try:
        return _episode_data(events, label)
    except _BadEvent as exc:
        raise InputError(source, f"line {exc.line}", f"{exc.kind} event: a field is not what the log "
                                                     f"format says ({exc.why})") from None


class _BadEvent(Exception):
    def __init__(self, line: int, kind: str, why: str) -> None:
        super().__init__(why)
        self.line, self.kind, self.why = line, kind, why


def _episode_data(events: list[dict], label: str | None) -> dict[str, Any]:
    start = events[0]
    sites = [s["name"] for s in start["sites"]]
    locations = {o: list(p) for o, p in start["belief"]["locations"].items()}
    states = dict(start["belief"].get("states", {}))
    entropy = {o: round(_entropy(p), 9) for o, p in locations.items()}
    tasks = [n for n, _ in start.get("tasks", [])]
    status = {n: s for n, s in start.get("tasks", [])}
    codes = {"pending": 0, "active": 1, "complete": 2, "skipped": 3, "failed": 4}
    pose = list(start.get("pose", [0.0, 0.0, 0.0]))
    path: list[list[float]] = [[round(pose[0], 3), round(pose[1], 3)]]
    look: dict[str, Any] = {"viewpoint": None, "kind": None, "sites": []}
    viewpoint_sites = {v["name"]: v.get("sites", []) for v in start.get("viewpoints", [])}
    lacks: list[str] = []
    if not start.get("viewpoints"):
        lacks.append("viewpoints (logs before room glances): every look is drawn as a close look at its site")
    beliefs = [e for e in events if e.get("event") == "belief"]
    if beliefs and "entropy" not in beliefs[0]:
        lacks.append("entropy in belief events: computed here from the logged marginals")
    if start.get(PARTIAL):
        lacks.append("its last line, which is not a whole JSON line (a crash mid-write): left out")
    if not tasks:
        lacks.append("task statuses in episode_start: the task graph is not shown")
    inference = start.get("inference") if isinstance(start.get("inference"), dict) else None
    if inference is None:
        lacks.append("inference in episode_start (logs before it was recorded): the exact method of "
                     "each query and which factors moved a belief are not shown")
    moved = [_moved(start, 0)]
    decisions: list[dict[str, Any]] = []
    steps: list[dict[str, Any]] = []
    for i, e in enumerate(events):
        kind = e.get("event", "")
        if kind == "belief" and i > 0:
            moved.append(_moved(e, i))
        try:
            look, pose = _apply(e, i, look, pose, locations, states, entropy, status, viewpoint_sites,
                                decisions, path)
        except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
            raise _BadEvent(i + 1, kind, f"{type(exc).__name__}: {exc}") from None
        steps.append({
            "seq": e.get("seq", i), "event": kind, "frame": e.get("frame"),
            "caption": caption(e), "pose": [round(float(x), 3) for x in pose[:3]], "path": len(path),
            "locations": {o: list(p) for o, p in locations.items()}, "states": dict(states),
            "entropy": dict(entropy), "tasks": [codes.get(status.get(n, "pending"), 0) for n in tasks],
            "look": dict(look), "decision": len(decisions) - 1 if kind == "decision" else None,
            "detections": ({"seen": e.get("detections", {}), "found_at": e.get("found_at", {}),
                            "pixels": e.get("pixel_counts", {})} if kind == "observation" else None),
            "moved": len(moved) - 1,
        })
    end = next((e for e in reversed(events) if e.get("event") == "episode_end"), None)
    if end is None:
        lacks.append(f"an episode_end: the log stops after event {events[-1].get('seq', len(events) - 1)} "
                     "(a run that was stopped or crashed)")
    return {"label": label or f"{start.get('model')} · {start.get('planner')}",
            "scenario": start.get("scenario"), "model": start.get("model"),
            "structure": start.get("structure"), "planner": start.get("planner"),
            "task": start.get("task"), "seed": start.get("seed"),
            "fg_tea": (start.get("versions") or {}).get("fg_tea"),
            "objects": list(locations), "sites": sites, "tasks": tasks,
            "task_codes": list(codes), "placements": (start.get("world") or {}).get("placements", {}),
            "outcome": (end or {}).get("reason"), "steps": steps, "decisions": decisions,
            "path": path, "lacks": lacks, "inference": inference, "moved": moved}


def _moved(e: Mapping[str, Any], i: int) -> dict[str, Any]:
    """The factors that moved each object's belief at a belief step (the prior's at the start),
    as the log records them (``moved_by``, ``moved_by_note``; docs/log-format.md)."""
    record = e.get("belief") if e.get("event") == "episode_start" else e
    record = record if isinstance(record, dict) else {}
    by = record.get("moved_by") or {}
    if not isinstance(by, dict) or not all(isinstance(v, dict) for v in by.values()):
        raise _BadEvent(i + 1, str(e.get("event")), "moved_by is not a map of objects to factors")
    try:
        shown = {o: {str(k): float(x) for k, x in v.items()} for o, v in by.items()}
    except (TypeError, ValueError) as exc:
        raise _BadEvent(i + 1, str(e.get("event")), f"moved_by: {exc}") from None
    return {"seq": e.get("seq", i), "by": shown, "note": record.get("moved_by_note")}


def _apply(e: Mapping[str, Any], i: int, look: dict, pose: list, locations: dict, states: dict,
           entropy: dict, status: dict, viewpoint_sites: Mapping[str, Any], decisions: list,
           path: list) -> tuple[dict, list]:
    """Fold one event into the running state (in place); returns the look and pose after it."""
    kind = e.get("event", "")
    if kind == "decision":
        name = logged_viewpoint(e)
        look = {"viewpoint": name, "kind": e.get("viewpoint_kind", "site"),
                "sites": list(viewpoint_sites.get(name) or [name])}
        decisions.append({"seq": e.get("seq", i), "step": i, "object": e.get("object"),
                          "viewpoint": name, "planner": e.get("planner"), "total": e.get("total"),
                          "serving": e.get("serving"), "objects": e.get("objects"), "info": e.get("info"),
                          **_candidate_table(e)})
    elif kind == "observation":
        name = logged_viewpoint(e)
        look = {"viewpoint": name, "kind": e.get("viewpoint_kind", "site"),
                "sites": list(e.get("sites_in_view") or viewpoint_sites.get(name) or [name])}
        after = e.get("after") or {}
        locations.update({o: [float(x) for x in p] for o, p in after.items()})
        entropy.update(e.get("entropy_after") or {o: round(_entropy(p), 9) for o, p in after.items()})
    elif kind == "belief":
        locations.update({o: [float(x) for x in p] for o, p in (e.get("locations") or {}).items()})
        states.update(e.get("states") or {})
        entropy.update(e.get("entropy") or {o: round(_entropy(p), 9)
                                            for o, p in (e.get("locations") or {}).items()})
    elif kind == "state_reading" and e.get("state") in states and "after" in e:
        states[e["state"]] = float(e["after"])
    elif kind == "action" and isinstance(e.get("belief_after"), dict):
        states.update(e["belief_after"])
    if kind in ("action", "state_reading", "action_failed", "skip"):
        look = {"viewpoint": None, "kind": None, "sites": []}
    if kind == "activate" and e.get("action") in status:
        status[e["action"]] = "active"
    graph = e.get("graph_after") or e.get("graph")
    if isinstance(graph, dict):
        status.update({k: v for k, v in graph.items() if k in status})
    motion = e.get("motion") or []
    for j, p in enumerate(motion):
        if j % PATH_STRIDE == 0 or j == len(motion) - 1:
            path.append([round(float(p[0]), 3), round(float(p[1]), 3)])
    return look, (list(motion[-1]) if motion else pose)


# ------------------------------------------------------------------------------ two episodes
def same_world(a: Sequence[dict], b: Sequence[dict]) -> str | None:
    """Why two logs are not episodes of the same world, or None when they are."""
    sa, sb = a[0], b[0]
    if sa.get("scenario") != sb.get("scenario"):
        return f"another house ({sb.get('scenario')} against {sa.get('scenario')})"
    if (sa.get("world") or {}).get("placements") != (sb.get("world") or {}).get("placements"):
        return "the same house with other object placements (another world seed)"
    return None


def align(a: dict, b: dict) -> dict[str, Any]:
    """Pair the steps of two episodes decision by decision, and find where their choices part.

    Returns:
        ``pairs``: [step of a, step of b] for the page's one slider: the steps between two
        decisions are zipped (the shorter side holds its last step); ``divergence``: the first
        decision (index k) whose object or viewpoint differs, with the steps and the choice and
        belief of each side there, or None when every decision agrees.
    """
    def cuts(ep: dict) -> list[int]:
        return [d["step"] for d in ep["decisions"]] + [len(ep["steps"])]

    ca, cb = [0] + cuts(a), [0] + cuts(b)
    pairs: list[list[int]] = []
    for k in range(max(len(ca), len(cb)) - 1):
        la, ha = (ca[k], ca[k + 1]) if k + 1 < len(ca) else (len(a["steps"]) - 1, len(a["steps"]))
        lb, hb = (cb[k], cb[k + 1]) if k + 1 < len(cb) else (len(b["steps"]) - 1, len(b["steps"]))
        for j in range(max(ha - la, hb - lb, 1)):
            pairs.append([min(la + j, max(ha - 1, la)), min(lb + j, max(hb - 1, lb))])
    divergence = None
    for k in range(max(len(a["decisions"]), len(b["decisions"]))):
        da = a["decisions"][k] if k < len(a["decisions"]) else None
        db = b["decisions"][k] if k < len(b["decisions"]) else None
        if da is None or db is None or (da["object"], da["viewpoint"]) != (db["object"], db["viewpoint"]):
            def side(ep: dict, d: dict | None) -> dict[str, Any] | None:
                if d is None:
                    return None
                before = ep["steps"][max(d["step"] - 1, 0)]["locations"].get(d["object"], [])
                return {"step": d["step"], "object": d["object"], "viewpoint": d["viewpoint"],
                        "belief": before}
            divergence = {"decision": k, "pair": next(
                (i for i, (x, y) in enumerate(pairs)
                 if (da is None or x == da["step"]) and (db is None or y == db["step"])), None),
                "a": side(a, da), "b": side(b, db)}
            break
    return {"pairs": pairs, "divergence": divergence}


# ------------------------------------------------------------------------------------- video
def video_times(events: list[dict]) -> list[float]:
    """Seconds into the episode's video of each event's last frame (what the page shows is the
    state after the event), for the video rendered with the options the log records
    (docs/design.md §8.6)."""
    from dataclasses import fields

    from fg_tea.render.video import VideoOptions, plan_frames

    recorded = ((events[0].get("parameters") or {}).get("render") or {})
    names = {f.name for f in fields(VideoOptions)}
    options = VideoOptions(**{k: v for k, v in recorded.items() if k in names})
    plan = plan_frames(events, options)
    starts = [plan.event_frames.get(e.get("seq", i), 0) for i, e in enumerate(events)] + [plan.output_frames]
    return [round(max(starts[i], starts[i + 1] - 1) / options.fps, 3) for i in range(len(events))]


# -------------------------------------------------------------------------------------- page
def _asset(name: str) -> str:
    return resources.files("fg_tea.render").joinpath("explorer", name).read_text(encoding="utf-8")


def page_data(logs: Sequence[tuple[str, list[dict]]], video: str | None = None,
              labels: Sequence[str | None] = ()) -> dict[str, Any]:
    """The data of a page of one episode, or two of the same world side by side."""
    from fg_tea._version import __version__

    episodes = [episode_data(events, labels[i] if i < len(labels) else None, name)
                for i, (name, events) in enumerate(logs)]
    for ep, (name, events) in zip(episodes, logs):
        ep["log"] = Path(name).name
        ep["task_edges"] = task_edges(events[0])
    start = logs[0][1][0]
    data: dict[str, Any] = {"format": PAGE_FORMAT, "fg_tea": __version__, "episodes": episodes,
                            "house": house_data(start), "task_edges": episodes[0]["task_edges"], "video": None}
    if len(episodes) == 2:
        data.update(align(episodes[0], episodes[1]))
    else:
        data["pairs"] = [[i] for i in range(len(episodes[0]["steps"]))]
        data["divergence"] = None
    if video is not None:
        data["video"] = {"src": video, "times": video_times(logs[0][1])}
    return data


def check_log_size(path: str | Path) -> None:
    """Refuse, in one line, a log too large for a page a browser can open (before reading it)."""
    size = Path(path).stat().st_size if Path(path).is_file() else 0
    if size > EXPLORE_LOG_MAX_BYTES:
        raise InputError(path, "size", f"{size / 2 ** 20:.0f} MB: the explorer reads logs of up to "
                                       f"{EXPLORE_LOG_MAX_BYTES // 2 ** 20} MB (a page about twice the log's "
                                       "size is more than a browser opens well); render its video instead")


def write_page(out: str | Path, data: Mapping[str, Any], title: str) -> Path:
    """Write the page (data, script and styles inlined) atomically; returns its path.

    Raises:
        InputError: the page's data would exceed ``PAGE_MAX_BYTES``.

    The template is filled once, each slot escaped for its context (:mod:`fg_tea.render.page`):
    whatever the names in `data` and `title` hold, they reach the page as text.
    """
    script = _asset("explorer.js")
    payload = json_script(_finite(data))
    if len(payload) > PAGE_MAX_BYTES:
        raise InputError(out, "page", f"its data would take {len(payload) / 2 ** 20:.0f} MB, above the "
                                      f"{PAGE_MAX_BYTES // 2 ** 20} MB a page may hold: explore a shorter episode")
    html = fill(_asset("page.html"), {
        "CSP": html_text(content_security_policy(script, media=bool(data.get("video")))),
        "TITLE": html_text(title),
        "STYLE": _asset("explorer.css"),
        "SCRIPT": script,
        "DATA": payload,
    })
    return atomic_write_text(out, html)


def _finite(value: Any) -> Any:
    """`value` with every non-finite float (an unreachable site's distance) as the string "inf",
    "-inf" or "nan" (JSON has no such numbers)."""
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else "inf" if value > 0 else "-inf"
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value
