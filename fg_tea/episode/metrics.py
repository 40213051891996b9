"""Episode metrics as pure functions of the event log (docs/design.md §9).

Because they read only logged events, an old log can be re-scored with new metrics:
``score(read_log(path))``.
"""

from __future__ import annotations

from typing import Iterable

from fg_tea.episode.log import iter_events
from fg_tea.world.interface import logged_viewpoint

MOVING_EVENTS = ("observation", "state_reading", "action", "action_failed")


def total_distance(events: list[dict]) -> float:
    """Metres travelled by the agent (geodesic paths actually followed)."""
    return float(sum(e.get("distance", 0.0) for e in events if e.get("event") in MOVING_EVENTS))


def search_distance(events: list[dict]) -> float:
    """Metres travelled to inspect sites while searching (the search phase's travel cost)."""
    return float(sum(e.get("distance", 0.0) for e in iter_events(events, "observation")))


def inspections(events: list[dict]) -> int:
    """Number of site inspections (search observations)."""
    return sum(1 for _ in iter_events(events, "observation"))


def inspections_until_resolved(events: list[dict]) -> dict[str, int | None]:
    """For each searched object, the number of inspections up to and including its detection."""
    start = next(iter_events(events, "episode_start"), {})
    out: dict[str, int | None] = {o: None for o in start.get("searched", start.get("objects", []))}
    for n, e in enumerate(iter_events(events, "observation"), start=1):
        for obj in e.get("resolved", []):
            if out.get(obj) is None:
                out[obj] = n
    return out


def entropy_reductions(events: list[dict]) -> list[float]:
    """Per inspection: total entropy (nats) removed from the considered objects' location beliefs."""
    out = []
    for e in iter_events(events, "observation"):
        before, after = e.get("entropy_before", {}), e.get("entropy_after", {})
        out.append(float(sum(before[o] - after[o] for o in before if o in after)))
    return out


def repeated_sites(events: list[dict]) -> int:
    """Inspections of a site that had been inspected before in the episode."""
    seen, repeats = set(), 0
    for e in iter_events(events, "observation"):
        repeats += logged_viewpoint(e) in seen
        seen.add(logged_viewpoint(e))
    return repeats


def skipped_actions(events: list[dict]) -> list[str]:
    return [e["action"] for e in iter_events(events, "skip")]


def frames(events: list[dict]) -> int:
    return max((int(e.get("frame", 0)) for e in events), default=0)


def believed_goals_true(events: list[dict]) -> bool | None:
    """Whether every belief goal the episode finished on is also true in the world's final truth.

    The agent's success is judged by its beliefs (eqs. 19-20); this checks them against the truth
    the environment reports at the end (``episode_end.world_truth``), restricted to the goals of
    the actions that completed or were skipped last for each state. None when the log has no truth.
    """
    end = next(iter_events(events, "episode_end"), None)
    truth = (end or {}).get("world_truth", {}).get("states")
    if not end or not truth:
        return None
    goals = end.get("goal_conditions", {}).get("final_states", [])
    return all(bool(truth.get(state, False)) for state in goals)


def clairvoyant_search_travel(events: list[dict]) -> float | None:
    """Metres of the clairvoyant route (``episode_end.yardstick``; docs/design.md §11), or None."""
    end = next(iter_events(events, "episode_end"), None)
    value = ((end or {}).get("yardstick") or {}).get("clairvoyant_search_travel")
    return None if value is None else float(value)


def search_spl(events: list[dict]) -> float | None:
    """SPL of the search: clairvoyant ÷ max(search travel, clairvoyant); 0 if an object was never found.

    The search succeeded when every searched object was found; the episode's own ``success``
    (the task finished) is reported separately. None when the log has no yardstick.
    """
    from fg_tea.episode.yardstick import spl

    found_all = all(n is not None for n in inspections_until_resolved(events).values())
    return spl(found_all, search_distance(events), clairvoyant_search_travel(events))


def _mean(values: Iterable[float]) -> float | None:
    values = list(values)
    return sum(values) / len(values) if values else None


def score(events: list[dict]) -> dict:
    """Every metric of one episode, from its events alone."""
    end = next(iter_events(events, "episode_end"), None)
    reductions = entropy_reductions(events)
    graph = end.get("graph", {}) if end else {}
    statuses = list(graph.values())
    return {
        "success": bool(end and end.get("reason") == "complete"),
        "reason": end.get("reason") if end else "incomplete_log",
        "actions_total": len(statuses),
        "actions_complete": statuses.count("complete"),
        "actions_skipped": statuses.count("skipped"),
        "goal_conditions": end.get("goal_conditions", {}) if end else {},
        "goals_true": believed_goals_true(events),
        "total_distance": round(total_distance(events), 6),
        "search_distance": round(search_distance(events), 6),
        "clairvoyant_search_travel": clairvoyant_search_travel(events),
        "spl": None if (value := search_spl(events)) is None else round(value, 9),
        "inspections": inspections(events),
        "inspections_until_resolved": inspections_until_resolved(events),
        "entropy_reduction_per_inspection": None if not reductions else round(sum(reductions) / len(reductions), 9),
        "repeated_sites": repeated_sites(events),
        "skipped_actions": skipped_actions(events),
        "state_readings": sum(1 for _ in iter_events(events, "state_reading")),
        "failures": sum(1 for _ in iter_events(events, "action_failed")),
        "frames": frames(events),
    }
