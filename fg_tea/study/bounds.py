"""The lower bound of the search beside each planner's search travel in a comparison (docs/design.md §6.9).

For each world of a comparison and each model, the search the task starts with (the house of that
world seed, the model's prior, its viewpoints) has an optimal expected search travel V*; the bound
of :mod:`fg_tea.planning.limit_bound` is at most V* at any size (27 and 45 sites included). It is
computed here with no look cost, as a comparison's search travel is metres walked, and from the
straight-line distances of the fake house, which no walked route undercuts. Two cases have none,
and the report says why: a correlated belief (the bound needs independent objects), and a task
that is not a search alone (``make_tea``): its search travel is counted from wherever the task's
other actions left the agent, so a look can cost less than the bound's cheapest arrival.

What it bounds: the optimum under the model's own prior. A planner's mean search travel over the
worlds is at least the mean bound when the worlds are drawn from that prior (the ``independent``
worlds); in worlds placed otherwise (co-located objects, violations) it is a reference point, not a
guarantee, and the report says which.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any, Mapping, Sequence

from fg_tea.common.errors import InputError
from fg_tea.common.tables import table_lines
from fg_tea.study.analysis import refused, step_limited
from fg_tea.study.keys import job_from_key

#: Tasks that are a search and nothing else: their search travel is the search problem's.
SEARCH_ONLY_TASKS = ("find_mug", "find_three")


@lru_cache(maxsize=4096)
def start_bound(world: str, world_seed: int, model: str, task: str, knobs: tuple = (),
                overrides: tuple = ()) -> float | str:
    """The lower bound on the optimal expected search travel from the start of `task` in world
    `world_seed`'s house under `model`'s prior (metres), or why there is none (one line)."""
    from fg_tea.episode.distances import EnvDistances
    from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
    from fg_tea.planning.limit_bound import bound_fault, lower_bound
    from fg_tea.study.sweep import job_env, job_model, job_world

    the_model = job_model(model, overrides)
    scenario = job_world(world, knobs).sample(world_seed)
    env = job_env("fake", scenario, env_config_for(the_model))
    try:
        runner = EpisodeRunner(scenario, the_model, env, RunConfig(seed=world_seed, task=task))
        runner.start()  # resets the house and hands the agent its views; no look yet
        agent = runner.agent
        if not agent.searching():
            return 0.0
        problem = agent.search_problem(EnvDistances(env), 0.0)
    finally:
        env.close()
    fault = bound_fault(problem)
    return fault if fault else lower_bound(problem)


def row_bound(row: Mapping[str, Any]) -> float | str:
    """:func:`start_bound` of a comparison row's episode (from its key), or why there is none."""
    try:
        job = job_from_key(str(row.get("key", "")))
    except InputError:
        return "the row's key names no episode"
    if job.task not in SEARCH_ONLY_TASKS:
        return (f"task {job.task}: its search travel starts wherever its other actions leave the "
                f"agent; the bound prices a search-only task ({', '.join(SEARCH_ONLY_TASKS)})")
    return start_bound(job.world, job.world_seed, job.model, job.task, job.knobs, job.model_overrides)


def bound_table(summary_rows: Sequence[Mapping[str, Any]], rows: Sequence[Mapping[str, Any]]) -> list[dict]:
    """Per (model, planner) of `summary_rows`: the mean search travel of its episodes (those the
    summary's means count: not refused, not step-limited), the mean
    bound over the same worlds, and their ratio (an upper end on the planner's ratio to the
    optimum, in worlds drawn from the model's prior); the bound's fault where there is none."""
    out = []
    for s in summary_rows:
        mine = [r for r in rows if r["model"] == s["model"] and r["planner"] == s["planner"]
                and r.get("search_distance") not in (None, "") and not refused(r) and not step_limited(r)]
        bounds = [row_bound(r) for r in mine]
        fault = next((b for b in bounds if isinstance(b, str)), None)
        travel = sum(float(r["search_distance"]) for r in mine) / len(mine) if mine else None
        if fault is not None or travel is None:
            out.append({"model": s["model"], "planner": s["planner"], "episodes": len(mine),
                        "search_travel": travel, "bound": None, "travel_over_bound": None,
                        "bound_fault": fault or "no episode with a search travel"})
            continue
        bound = sum(float(b) for b in bounds) / len(bounds)
        out.append({"model": s["model"], "planner": s["planner"], "episodes": len(mine),
                    "search_travel": travel, "bound": bound,
                    "travel_over_bound": travel / bound if bound > 0 else None, "bound_fault": ""})
    return out


def bound_markdown(table: Sequence[Mapping[str, Any]]) -> str:
    """:func:`bound_table` as a markdown table."""
    body = []
    for t in table:
        travel = "–" if t["search_travel"] is None else f"{t['search_travel']:.2f}"
        if t["bound"] is None:
            body.append([t["model"], t["planner"], t["episodes"], travel, f"– ({t['bound_fault']})", "–"])
        else:
            ratio = "–" if t["travel_over_bound"] is None else f"{t['travel_over_bound']:.3f}"
            body.append([t["model"], t["planner"], t["episodes"], travel, f"{t['bound']:.3f}", ratio])
    return "\n".join(table_lines(["model", "planner", "episodes", "search travel (m)", "≥ bound (m)",
                                  "travel ÷ bound"], body, align="llrrrr"))


__all__ = ["SEARCH_ONLY_TASKS", "bound_markdown", "bound_table", "row_bound", "start_bound"]
