"""The log records the agent's verbs return (docs/log-format.md): what the episode runner writes.

The agent keeps one cursor into its task executor's events, so every record the agent makes is
handed out once, in order, by :meth:`fg_tea.agent.agent.Agent.records`; the records built here
are the agent's halves of the runner's ``decision``, ``observation``, ``episode_start`` and
``episode_end`` events, which the runner (or a loop of one's own) merges with what the
environment reported. None of them reads the world's truth. ``agent`` is the
:class:`~fg_tea.agent.agent.Agent` whose records they are (not imported here: the agent imports
this module).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from fg_tea.beliefs.engine import entropy
from fg_tea.world.interface import InspectionResult

if TYPE_CHECKING:
    from fg_tea.beliefs.engine import LookUpdate
    from fg_tea.planning import Decision
    from fg_tea.tasks.actions import TaskAction


def decision_record(agent: Any, action: TaskAction, decision: Decision) -> dict:
    """The ``decision`` event of a SEARCH step: what was served, searched and why this look."""
    executor = agent.executor
    return {"event": "decision", "serving": action.id, "objects": executor.pending_search_objects(),
            "relevance": executor.search_relevance(), "inspected": dict(agent.inspected),
            "excluded": sorted(frozenset(executor.excluded_sites)), **decision.to_json()}


def observation_record(agent: Any, viewpoint: str, objects: list[str], result: InspectionResult,
                       update: LookUpdate) -> dict:
    """The ``observation`` event of a look from `viewpoint` at `objects` (before its motion)."""
    assert agent.views is not None, "a look needs the view geometry"
    view = agent.views.view(viewpoint)
    in_view = [agent.belief.sites[j] for j in view.sites]
    probability = agent.views.probabilities(viewpoint)
    return {
        "event": "observation", "viewpoint": viewpoint,
        "viewpoint_kind": view.kind, "sites_in_view": in_view, "objects": objects,
        "detections": dict(result.detections), "found_at": dict(result.found_at),
        "pixel_counts": dict(result.pixel_counts),
        "detection_probability": {o: probability[o] for o in objects},
        "site_pixel_counts": {o: dict(result.view_pixels.get(o, {s: result.pixel_counts.get(o, 0)
                                                               for s in in_view}))
                              for o in objects},
        "resolved": list(update.detected),
        "before": {o: update.before[o] for o in objects},
        "after": {o: update.after[o] for o in objects},
        "entropy_before": {o: entropy(update.before[o]) for o in objects},
        "entropy_after": {o: entropy(update.after[o]) for o in objects}}


def start_record(agent: Any) -> dict[str, Any]:
    """The agent's fields of ``episode_start``: its task, searches, recovery budget and prior."""
    executor, graph = agent.executor, agent.graph
    return {"task": graph.name, "tries": executor.transient_tries(),
            "action_runs": executor.practical_runs(),
            "searched": executor.pending_search_objects(), "graph": graph.to_json(),
            "tasks": [[n, graph.status(n)] for n in graph], "belief": agent.belief.snapshot()}


def goal_conditions(agent: Any) -> dict:
    """What the agent believes holds at the end: every finished action's goals and preconditions
    against their thresholds, and the symbolic object state."""
    executor, graph = agent.executor, agent.graph
    objects = executor.object_state()
    states = agent.belief.states()
    thresholds: dict[str, float] = {}
    for node in graph:
        if graph.status(node) in ("complete", "skipped"):
            action = graph.action(node)
            for c in (*action.goals, *action.preconditions):
                thresholds[c.state] = max(thresholds.get(c.state, 0.0), c.at_least)
    goals = {s: {"belief": states.get(s), "threshold": t, "met": states.get(s, 0.0) >= t}
             for s, t in sorted(thresholds.items())}
    return {"all_actions_finished": executor.done, "goals": goals,
            # What the agent claims holds at the end: goals and preconditions it still believes.
            "final_states": [s for s, g in goals.items() if g["met"]],
            "objects": objects}


def gtsam_agreement(agent: Any) -> float | None:
    """The belief's disagreement with gtsam, or None where gtsam cannot hold it: a capacity factor
    is one dense table over all objects, and above the dense limit only the subset dynamic
    program (with its own numerical guard, docs/design.md §4.4) answers."""
    from fg_tea.beliefs.graph import DENSE_LIMIT

    graph = agent.belief.graph
    if graph.capacity_active and graph.joint_size > DENSE_LIMIT:
        return None
    return agent.belief.check_against_gtsam()
