"""``fg-tea preview --search``: the looks a planner would make if none of them found anything.

The agent plans in the house as in an episode — its own beliefs, its planner, the house's travel
distances, the agent walking to each viewpoint — but every look is taken as a miss of every
searched object, so the sequence is the planner's order of search under its prior and negative
evidence alone (docs/design.md §6), until it gives a search up or ``--looks`` looks are made.
Truth is never read: the house only moves the agent and measures the walk.
"""

from __future__ import annotations

from typing import Any


def search_sequence(scenario: Any, model: Any, house: Any, planner: str, task: str, seed: int,
                    looks: int) -> tuple[list[dict], str]:
    """(the looks, why the sequence ended): each look's viewpoint, kind, metres walked to it, the
    objects searched and their probability of being in view before it."""
    from fg_tea.agent.agent import Agent
    from fg_tea.episode.distances import EnvDistances

    agent = Agent(scenario, model, planner, task, seed=seed)
    pose = house.reset(seed)
    agent.view_geometry_from(house)
    between: dict = {}
    out: list[dict] = []
    while len(out) < looks:
        position = (pose.x, pose.y)
        action = agent.next_action(position, EnvDistances(house, between))
        list(agent.records())
        if action is None or action.verb != "SEARCH":
            why = agent.end_reason() if action is None else f"the next action is {action.id}, not a search"
            return out, why or "the task has no search left"
        decision = agent.decide(action, position, EnvDistances(house, between))
        objects = agent.searching()
        view = agent.view(decision.viewpoint)
        walked = house.inspect_viewpoint(decision.viewpoint, objects)  # moves the agent; detections unused
        if not walked.reachable:
            return out, f"{decision.viewpoint} cannot be reached"
        mass = {o: float(agent.belief.marginal(o)[list(view.sites)].sum()) for o in objects}
        agent.observe_look(decision.viewpoint, {o: None for o in objects})
        list(agent.records())
        out.append({"viewpoint": decision.viewpoint, "kind": view.kind, "walked": float(walked.distance),
                    "objects": objects, "in_view": mass})
        pose = house.agent_pose()
    return out, f"{looks} looks (--looks)"


def describe(sequence: list[dict], why: str, planner: str) -> str:
    """The sequence as lines of text."""
    lines = [f"search sequence of {planner} if no look finds anything:"]
    for i, look in enumerate(sequence, 1):
        chances = ", ".join(f"{o} {p:.2f}" for o, p in look["in_view"].items())
        lines.append(f"  {i:2d}. {look['viewpoint']} ({look['kind']}, {look['walked']:.1f} m): "
                     f"in view before the look: {chances}")
    lines.append(f"  ended: {why}")
    return "\n".join(lines)


__all__ = ["search_sequence", "describe"]
