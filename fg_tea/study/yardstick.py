"""Each planner's cost against the search limit under imperfect detection (docs/design.md §6.9).

A search-only task (``find_mug``, ``find_three``) in worlds drawn from the model's own prior (the
``independent`` world distribution), the fake house with a detector that misses as often as the
model says: what is left between a planner and the limit is then planning alone. Every episode's
cost is priced as the limit prices it (:mod:`fg_tea.planning.limit`): the planner's own travel
distances between the viewpoints it looked from, plus the look cost per image; the limit is the
bracketed optimal expected cost of the same problem from the start, which every world of the
distribution shares (the worlds change where the objects are, not the house or the prior).

Used by ``experiments/search_limit.py``; one JSON file per episode under ``<out>/episodes/``, so
an interrupted run resumes. Times are CPU seconds per decision, measured serially.
"""

from __future__ import annotations

import csv
import itertools
from functools import partial
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fg_tea.common.errors import InputError, PlannerRefused
from fg_tea.common.files import atomic_path, atomic_write_text
from fg_tea.episode.distances import EnvDistances
from fg_tea.study.episode_files import file_part, kept_or_run
from fg_tea.episode.runner import EpisodeRunner, RunConfig
from fg_tea.common.stats import bootstrap_interval
from fg_tea.common.tables import table_lines
from fg_tea.planning.bracket import search_limit
from fg_tea.planning.limit import MAX_BYTES, Limit, human_bytes, table_bytes
from fg_tea.planning.problem import LOOK_COST
from fg_tea.study.frontier import DecisionClock, episode_setup

#: Planners that draw random numbers: their policy is no function of the belief, so it is only
#: sampled, never enumerated.
RANDOMISED = ("random", "pouct", "pomcp")
#: The search-only tasks the limit prices.
TASKS = ("find_mug", "find_three")
#: The planners a study runs by default: one-step EFE, the lookahead, the limit's own policy and
#: the perfect-detection DP, all deterministic, so each has an exact policy cost.
PLANNERS = ("efe", "lookahead", "exact", "optimal")


def start_problem(world: str, model_name: str, task: str):
    """The search problem the task starts with, from the start pose (world seed 0's house), and
    the objects it searches."""
    model, scenario, env, _ = episode_setup(world, 0, model_name, "fake", None)
    try:
        runner = EpisodeRunner(scenario, model, env, RunConfig(seed=0, task=task))
        runner.start()  # resets the house and hands the agent its view geometry; no look yet
        agent = runner.agent
        objects = agent.searching()
        problem = agent.search_problem(EnvDistances(env), LOOK_COST)
    finally:
        env.close()
    return problem, objects


def cuts_text(limit: Limit) -> str:
    """Where the limit's cuts were made: ``upper cut at cap 4, lower at cap 3``, or the caps of
    each viewpoint where a cap per viewpoint narrowed it (docs/design.md §6.9)."""
    uniform = f"upper cut at cap {limit.cap}, lower at cap {limit.lower_cap}"
    if limit.caps:
        return (f"{uniform}, and at caps {', '.join(map(str, limit.caps))} per viewpoint (lower one less), "
                "each end the tighter")
    return uniform


def check_fits(world: str, model_name: str, planner: str, task: str) -> None:
    """Refuse, before any episode, a planner that cannot plan the task in world seed 0's house.

    Raises:
        InputError: on ``--planners``, with the planner's own one-line reason.
    """
    model, scenario, env, _ = episode_setup(world, 0, model_name, "fake", None)
    try:
        EpisodeRunner(scenario, model, env, RunConfig(seed=0, planner=planner, task=task))
    except PlannerRefused as exc:
        raise InputError("<command line>", "--planners", str(exc)) from None
    finally:
        env.close()


def start_limit(world: str, model_name: str, task: str, tolerance: float = 1e-3,
                max_bytes: int = MAX_BYTES) -> tuple[Limit, list[str]]:
    """The limit of the search the task starts with, from the start pose (world seed 0's house),
    each solve within `max_bytes`."""
    problem, objects = start_problem(world, model_name, task)
    def say(line: str) -> None:
        print(f"{task}: limit, {line}", flush=True)

    return search_limit(problem, tolerance=tolerance, max_bytes=max_bytes, progress=say), objects


def run_episode(world: str, seed: int, model_name: str, planner: str, task: str,
                miss_rate: float | None = None) -> dict:
    """One search-only episode: its cost as the limit prices it, success, looks and CPU times."""
    model, scenario, env, rate = episode_setup(world, seed, model_name, "fake", miss_rate)
    distances = EnvDistances(env)
    runner = EpisodeRunner(scenario, model, env, RunConfig(seed=seed, planner=planner, task=task))
    clock = DecisionClock(runner.agent.planner)
    steps = 0
    cost, here, start = 0.0, None, {}
    try:
        runner.start()
        start = {v: distances.from_agent(v) for v in runner.agent.viewpoints()}
        steps = 0
        while not runner.done and steps < 2000:
            runner.step()
            steps += 1
        for e in runner.events:
            if e["event"] == "observation":
                v = e["viewpoint"]
                cost += start[v] if here is None else distances.between(here, v)
                cost += LOOK_COST * max(1, len(e.get("sites_in_view") or [v]))
                here = v
    finally:
        env.close()
    m = runner.metrics()
    return {"world": world, "seed": seed, "model": model_name, "planner": planner, "task": task,
            "miss_rate": rate, "cost": cost, "looks": sum(e["event"] == "observation" for e in runner.events),
            "success": bool(m["success"]) and runner.done, "reason": runner.reason,
            "decision_cpu_seconds": clock.cpu}


def run(world: str, seeds: range, model: str, planners: list[str], task: str, out: Path,
        progress=None) -> list[dict]:
    """Every (planner, seed) episode, resumed from ``out/episodes/`` where already there."""
    folder = out / "episodes"
    folder.mkdir(parents=True, exist_ok=True)
    rows = []
    jobs = [(p, s) for p in planners for s in seeds]
    for i, (planner, seed) in enumerate(jobs):
        path = folder / f"{file_part(f'{task}-{model}-{planner}-{seed:05d}')}.json"

        def other_world(row: dict) -> str | None:  # file names carry no world: one world per folder
            return None if row.get("world") == world else (f"world: an episode of world {row.get('world')!r}, "
                                                           f"not {world!r}: one world per --out folder")

        row = kept_or_run(path, partial(run_episode, world, seed, model, planner, task), other_world)
        assert row is not None
        rows.append(row)
        if progress:
            progress(i + 1, len(jobs))
    return rows


#: Relative slack allowed below the limit's lower bound (rounding in the sums and the sweep's tail
#: bound, 1e-12 of the mass): a cost below ``lower * (1 - RATIO_TOLERANCE)`` is an error, not a ratio.
RATIO_TOLERANCE = 1e-9


def ratio_interval(cost: float, limit: Limit) -> tuple[float, float] | None:
    """``[cost / upper, cost / lower]``, the ratio of `cost` to the optimum V* (which the limit
    brackets), its low end raised to 1 where it falls below: a policy that finds every object
    costs at least V*. None if `cost` lies below the lower bound beyond :data:`RATIO_TOLERANCE`
    (then it is not the cost of such a policy, and no ratio is printed)."""
    if cost < limit.lower * (1.0 - RATIO_TOLERANCE):
        return None
    return max(1.0, cost / limit.upper), max(1.0, cost / limit.lower)


def ratio_text(cost: float, limit: Limit, digits: int = 4) -> str:
    """:func:`ratio_interval` as ``[1.0000, 1.0005]``, or why there is none."""
    got = ratio_interval(cost, limit)
    if got is None:
        return f"below the limit by {limit.lower - cost:.2g} m: not a policy's cost"
    return f"[{got[0]:.{digits}f}, {got[1]:.{digits}f}]"


def cpu_summary(rows: list[dict]) -> dict[str, float]:
    """CPU ms per decision (mean, median, 95th percentile, every decision, solves included)
    and per episode (mean of each episode's sum)."""
    per = np.array([t for r in rows for t in r["decision_cpu_seconds"]]) * 1e3
    episodes = np.array([sum(r["decision_cpu_seconds"]) for r in rows]) * 1e3
    if not per.size:
        return {"mean": float("nan"), "median": float("nan"), "p95": float("nan"),
                "episode": float("nan")}
    return {"mean": float(per.mean()), "median": float(np.median(per)),
            "p95": float(np.percentile(per, 95)), "episode": float(episodes.mean())}


#: Columns of each task's table in summary.md.
SUMMARY_HEADER = ("planner", "policy cost (m)", "policy / optimum", "given up", "unexpanded", "sweep (m)",
                  "worlds", "episodes: mean cost (m) [95 %]", "episodes / optimum [95 %]", "looks",
                  "success", "CPU ms mean", "CPU ms median", "CPU ms p95", "CPU ms per episode")


def summarise(rows: list[dict], limits: dict[str, tuple[Limit, list[str]]], world: str, model: str,
              command: str, policies: dict[tuple[str, str], "PolicyCost"] | None = None) -> str:
    """The markdown tables: per task and planner, the exact expected cost of its policy (where it
    is deterministic) and the mean over sampled episodes, each against the limit as an interval
    (:func:`ratio_interval`), and CPU times."""
    policies = policies or {}
    lines = [f"# Planners against the search limit: model `{model}`, world `{world}`", "",
             f"Regenerate: `{command}`", "",
             "Cost: travel between the viewpoints looked from (the planner's own distances) plus "
             f"{LOOK_COST:.3f} m-equivalent per image, until every object is found. Limit: the "
             "optimal expected cost V* of the same search (docs/design.md §6.9), bracketed "
             "[lower, upper]. A ratio to the optimum is an interval, [cost / upper, cost / lower] "
             "(V* lies in the bracket), its low end raised to 1 where below: no policy that finds "
             f"every object costs less than V* (a cost below the lower bound by more than "
             f"{RATIO_TOLERANCE:g} relative is flagged, never printed as a ratio). *Policy*: the "
             "exact expected cost of the planner's own policy, every outcome of every look "
             "enumerated under the model; where it gives a search up (*given up*, its probability) "
             "or a branch is less probable than 1e-9 (*unexpanded*), the search is finished by a "
             "cyclic sweep of the viewpoints, whose expected cost (*sweep*, m) is part of the "
             "policy cost. *Episodes*: the mean cost over sampled worlds with a 95 % bootstrap "
             "interval, and that interval against the limit (same rule). CPU: ms per decision "
             "(mean, median and 95th percentile over every decision, the exact planner's solves "
             "included) and per episode (mean), serial.", ""]
    for task in sorted({r["task"] for r in rows}):
        limit, objects = limits[task]
        lines += [f"## task `{task}` ({', '.join(objects)})", "",
                  f"Limit: [{limit.lower:.6f}, {limit.upper:.6f}] m ({cuts_text(limit)}; "
                  f"{limit.viewpoints} viewpoints).", ""]
        body = []
        for planner in dict.fromkeys(r["planner"] for r in rows if r["task"] == task):
            mine = sorted((r for r in rows if r["task"] == task and r["planner"] == planner),
                          key=lambda r: r["seed"])
            cost = np.array([r["cost"] for r in mine])
            lo, hi = bootstrap_interval(cost)
            sampled = (f"[{max(1.0, lo / limit.upper):.3f}, {hi / limit.lower:.3f}]"
                       if hi >= limit.lower else "– (the sample lies below the limit)")
            cpu = cpu_summary(mine)
            pol = policies.get((task, planner))
            exact = ([f"{pol.cost:.4f}", ratio_text(pol.cost, limit), f"{pol.given_up:.2g}",
                      f"{pol.unexpanded:.2g}", f"{pol.completion:.4f}"] if pol is not None else ["–"] * 5)
            body.append([planner, *exact, len(mine), f"{cost.mean():.3f} [{lo:.3f}, {hi:.3f}]", sampled,
                         f"{np.mean([r['looks'] for r in mine]):.2f}",
                         f"{np.mean([r['success'] for r in mine]):.3f}", f"{cpu['mean']:.2f}",
                         f"{cpu['median']:.2f}", f"{cpu['p95']:.2f}", f"{cpu['episode']:.1f}"])
        lines += table_lines(SUMMARY_HEADER, body, align="left") + [""]
    return "\n".join(lines)


def planner_styles(planners: list[str]) -> dict[str, tuple[str, str]]:
    """(colour, marker) per planner: one colour per family (``pouct:100`` and ``pouct:3000``
    alike), a marker per variant within it, so that no two planners look the same."""
    from fg_tea.study.frontier import MARKERS

    families = list(dict.fromkeys(p.split(":")[0] for p in planners))
    out = {}
    for planner in planners:
        family = planner.split(":")[0]
        variant = [p for p in planners if p.split(":")[0] == family].index(planner)
        out[planner] = (f"C{families.index(family) % 10}", MARKERS[variant % len(MARKERS)])
    return out


def draw_frontier(rows: list[dict], limits: dict[str, tuple[Limit, list[str]]],
                  policies: dict[tuple[str, str], "PolicyCost"], path: Path) -> Path:
    """The quality-cost frontier against the limit: per task, each planner's cost against the
    optimum as an interval (its exact policy cost where it has one, [cost / upper, cost / lower];
    else the episodes' 95 % interval, the same way), against its mean CPU ms per decision (log,
    every solve included), with the limit (1) and 3 % above it marked."""
    from fg_tea.study.analysis import figure_row, save_figure
    from fg_tea.study.frontier import log_ticks

    tasks = sorted({r["task"] for r in rows})
    planners = list(dict.fromkeys(r["planner"] for r in rows))
    fig, axes = figure_row(width=4.2 * len(tasks) + 2.2, height=4.0, ncols=len(tasks))
    for ax, task in zip(axes, tasks):
        limit, objects = limits[task]
        styles = planner_styles(planners)
        for planner in planners:
            mine = [r for r in rows if r["task"] == task and r["planner"] == planner]
            cpu = cpu_summary(mine)["mean"] if mine else float("nan")
            if not mine or not np.isfinite(cpu) or cpu <= 0:
                continue
            colour, marker = styles[planner]
            style = {"marker": marker, "label": planner, "color": colour}
            pol = policies.get((task, planner))
            if pol is not None:
                got = ratio_interval(pol.cost, limit)
                if got is None:
                    continue
                mid = (got[0] + got[1]) / 2
                ax.errorbar(cpu, mid, yerr=[[mid - got[0]], [got[1] - mid]], ls="none", capsize=3,
                            markersize=6, **style)
            else:  # randomised: only its sampled episodes say how it does
                lo, hi = bootstrap_interval(np.array([r["cost"] for r in mine]))
                if hi < limit.lower:
                    continue
                low, high = max(1.0, lo / limit.upper), hi / limit.lower
                mid = (low + high) / 2
                ax.errorbar(cpu, mid, yerr=[[mid - low], [high - mid]], ls="none", capsize=3,
                            markersize=6, markerfacecolor="none", **style)
        ax.axhline(1.0, color="grey", lw=0.8)
        ax.axhline(1.03, color="grey", lw=0.8, ls=":")
        log_ticks(ax)
        ax.set_xlabel("mean CPU ms per decision (log, solves included)")
        ax.set_ylabel("expected cost / optimum (interval)")
        ax.set_title(f"{task} ({len(objects)} object{'s' if len(objects) != 1 else ''})", fontsize=10)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="outside right center", frameon=False)
    fig.suptitle("Quality against cost, against the search limit (dotted: 3 % above it; filled: the "
                 "exact policy cost, open: episodes' 95 %)", fontsize=9)
    return save_figure(fig, path)


def study(world: str, seeds: range, model: str, tasks: list[str], planners: list[str], out: Path,
          command: str, tolerance: float = 1e-3, gaps: tuple[str, ...] | list[str] = (),
          gaps_max_bytes: int = MAX_BYTES,
          model_flag: str = "--model", max_bytes: int = MAX_BYTES) -> str:
    """Every planner against the limit on every task: the limits, the episodes (resumed from
    ``out/episodes``), each deterministic planner's exact policy cost, and, for the planners in
    `gaps`, where they lose against the exact policy. Writes ``summary.md`` (returned),
    ``episodes.csv``, ``frontier.png`` and, with `gaps`, ``gaps.md`` to `out`.

    Raises:
        InputError: the limit does not fit, or the model's belief is correlated (named by
            `model_flag`); `out` holds episodes of another world.
    """
    from fg_tea.study.rows import sweep_progress

    for task in tasks:
        for planner in planners:
            check_fits(world, model, planner, task)
        if gaps:
            gap_cap(world, model, task, max_bytes=gaps_max_bytes)  # refused now, not after the episodes
    limits = {}
    for task in tasks:
        try:
            limits[task] = start_limit(world, model, task, tolerance, max_bytes)
        except ValueError as exc:  # the limit does not fit, or the belief is correlated
            raise InputError("<command line>", model_flag, str(exc)) from None
        lim = limits[task][0]
        print(f"{task}: limit [{lim.lower:.4f}, {lim.upper:.4f}] m ({cuts_text(lim)})", flush=True)
    rows = []
    for task in tasks:
        bar = sweep_progress(len(planners) * len(seeds), label=task)
        rows += run(world, seeds, model, planners, task, out, progress=lambda done, total: bar.update())
    policies = {}
    for task in tasks:
        for planner in planners:
            if planner.split(":")[0] not in RANDOMISED:
                policies[(task, planner)] = evaluate_policy(world, model, planner, task)
    text = summarise(rows, limits, world, model, command, policies)
    atomic_write_text(out / "summary.md", text)
    draw_frontier(rows, limits, policies, out / "frontier.png")
    with atomic_path(out / "episodes.csv") as tmp, tmp.open("w", newline="") as fh:
        columns = ["task", "planner", "seed", "cost", "looks", "success", "reason"]
        w = csv.DictWriter(fh, columns, extrasaction="ignore", lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    if not gaps:
        return text
    found = [(planner, task, gap_analysis(world, model, planner, task, max_bytes=gaps_max_bytes))
             for planner in gaps for task in tasks]
    atomic_write_text(out / "gaps.md", gaps_markdown(found))
    return text


#: Columns of gaps.md's summary table, and of its table of each planner's costliest decisions.
GAP_SUMMARY_HEADER = ("planner", "task", "policy cost (m)", "exact policy (m)", "summed regret (m)",
                      "at re-looks (m)", "at the first decision (m)")
GAP_DECISION_HEADER = ("weighted regret (m)", "probability", "stood at", "looks so far", "still searched",
                       "chose", "best", "regret (m)")


def _caps_text(found: list[tuple[str, str, dict]]) -> str:
    """``cap 3``, or ``cap 3 for find_mug, cap 2 for find_three`` where the tasks' caps differ."""
    caps = {task: g.get("cap", 3) for _, task, g in found}
    if len(set(caps.values())) <= 1:
        return f"cap {next(iter(caps.values()), 3)}"
    return ", ".join(f"cap {c} for {t}" for t, c in caps.items())


def gaps_markdown(found: list[tuple[str, str, dict]]) -> str:
    """gaps.md: for each (planner, task, :func:`gap_analysis` result), the summed regret in a
    summary table and its costliest decisions."""
    intro = ["# Where each planner loses against the exact policy", "",
            "At every decision the planner makes (every branch of its policy, reached with the "
            "probability shown), the regret is the exact Q-value of its look minus the best look's "
            f"(the tables of the upper cut at {_caps_text(found)}, docs/design.md §6.9); weighted by the "
            "chance of reaching the decision, the regrets sum to the planner's excess cost over the exact "
            "policy.", ""]
    summary_rows = []
    details: list[str] = []
    for planner, task, g in found:
        relook = sum(r["weighted"] for r in g["rows"] if r["best"] == r["here"])
        root = sum(r["weighted"] for r in g["rows"] if r["here"] is None)
        summary_rows.append([planner, task, f"{g['policy'].cost:.4f}", f"{g['cut_policy']:.4f}",
                             f"{g['excess']:.4f}", f"{relook:.4f}", f"{root:.4f}"])
        details += [f"## `{planner}`, task `{task}`", "",
                    f"Policy cost {g['policy'].cost:.4f} m; the exact (cut) policy's {g['cut_policy']:.4f} m; "
                    f"summed weighted regret {g['excess']:.4f} m, of which {relook:.4f} m where the best "
                    f"look was a re-look from where the agent stood and {root:.4f} m at the first "
                    f"decision. Decisions beyond the cut (not weighed): probability {g['beyond_cut']:.2g}.", ""]
        decisions = [[f"{r['weighted']:.4f}", f"{r['weight']:.3f}", r["here"] or "start", sum(r["looks"].values()),
                      ", ".join(r["pending"]), r["chosen"], r["best"], f"{r['regret']:.3f}"]
                     for r in g["rows"][:12]]
        details += table_lines(GAP_DECISION_HEADER, decisions, align="left") + [""]
    summary = ["## Summary", ""] + table_lines(GAP_SUMMARY_HEADER, summary_rows, align="left")
    return "\n".join(intro + summary + [""] + details)


@dataclass(frozen=True)
class PolicyCost:
    """A planner's exact expected search cost, by enumerating every outcome of its looks.

    The cost is that of a real policy that finds every object, so it is never below the limit:
    the planner's, followed until it gives a search up (the give-up rule, §7.8) or until a branch
    is less probable than the evaluation's floor, and from there a cyclic sweep of the viewpoints
    until every object is found (:func:`completion_cost`, the upper cut's own continuation).

    Attributes:
        cost: expected cost (metres-equivalent) to find every object, the sweeps included.
        unexpanded: probability of the branches below ``floor``, not followed further (finished
            by a sweep instead of the planner).
        given_up: probability that the agent gives a search up (finished by a sweep).
        completion: the part of ``cost`` the sweeps after a give-up or below the floor add.
        states: distinct decision states evaluated.
    """

    cost: float
    unexpanded: float
    given_up: float
    states: int
    completion: float = 0.0


def completion_cost(agent, distances) -> float:
    """The expected cost of finding every object the agent still searches for, from where it
    stands, by sweeping the viewpoints that can show one in a fixed cyclic order (a
    nearest-neighbour tour entered at its nearest viewpoint), as the limit's upper cut finishes
    (:func:`fg_tea.planning.limit._cycle_cost`); inf if some object can never be seen."""
    from fg_tea.planning.limit import _cycle_cost, _tour, _useful

    objects = agent.searching()
    if not objects:
        return 0.0
    problem = agent.search_problem(distances, LOOK_COST)
    useful, sites, q0 = _useful(problem)
    if useful.size == 0:
        return float("inf")
    prob = problem.prob[np.ix_(useful, np.arange(len(objects)), sites)]
    between = problem.between[np.ix_(useful, useful)]
    tour = _tour(between)
    start = problem.start[useful]
    first = int(np.argmin(start[tour]))
    return _cycle_cost(q0[:, sites], prob, np.roll(tour, -first), float(start[tour[first]]), between,
                       problem.look[useful])


def evaluate_policy(world: str, model_name: str, planner: str, task: str,
                    floor: float = 1e-9, trace: list | None = None) -> PolicyCost:
    """The exact expected cost of `planner`'s search policy from the start, under the model.

    The agent's belief is the model's, so the chance of each outcome of a look (which objects it
    shows, and where) follows from the belief and the detection probabilities; every outcome is
    absorbed into a copy of the agent and the policy followed from there. With a factorised
    belief the decision state is (where the agent stands, looks per viewpoint, objects found),
    so equal states are evaluated once. Branches less probable than `floor` are not expanded.
    With `trace`, every decision along every branch is appended to it as (probability of
    reaching it, viewpoint stood at or None, looks per viewpoint, objects still searched, the
    viewpoint chosen), each path separately (no state is shared), for :func:`gap_analysis`.
    """
    from fg_tea.agent.agent import Agent

    model, scenario, env, _ = episode_setup(world, 0, model_name, "fake", None)
    try:
        env.reset(0)
        agent = Agent(scenario, model, planner, task)
        agent.view_geometry_from(env)
        distances = EnvDistances(env)  # the start pose's: the house's agent never moves here

        memo: dict[tuple, tuple[float, float, float, float]] = {}
        totals = {"unexpanded": 0.0}

        def value(agent: Agent, here: str | None, weight: float) -> tuple[float, float, float]:
            """(expected cost to go, probability of giving up, expected completion cost) from
            this state."""
            where = distances.at(here)
            action = agent.next_action((0.0, 0.0), where)
            if action is None:
                if agent.done:
                    return 0.0, 0.0, 0.0
                rest = completion_cost(agent, where)  # given up: sweep
                return rest, 1.0, rest
            key = (here, tuple(sorted(agent.inspected.items())),
                   tuple(sorted(agent.searching())))
            # A state met again is reused only if it was expanded at least as deep: branches are
            # cut at an absolute probability, so a visit with less weight cut more of its subtree.
            if key in memo and trace is None and memo[key][3] >= weight:
                return memo[key][:3]
            if weight < floor:  # not followed further: finished by a sweep
                totals["unexpanded"] += weight
                rest = completion_cost(agent, where)
                return rest, 0.0, rest
            decision = agent.decide(action, (0.0, 0.0), where)
            v = decision.viewpoint
            if trace is not None:
                trace.append((weight, here, dict(agent.inspected), tuple(agent.searching()), v))
            view = agent.view(v)
            step = where.from_agent(v) + LOOK_COST * max(1, len(view.sites))
            objects = agent.searching()
            marg = {o: agent.belief.marginal(o) for o in objects}
            sites = list(agent.belief.sites)
            per_object = []
            for o in objects:
                p = view.probability_over_sites(len(sites))[agent.belief.objects.index(o)]
                seen = [(sites[k], float(marg[o][k] * p[k])) for k in range(len(sites))
                        if marg[o][k] * p[k] > 0]
                per_object.append([(None, 1.0 - sum(x for _, x in seen))] + seen)
            cost, gave, rest = step, 0.0, 0.0
            for combo in itertools.product(*per_object):
                prob = float(np.prod([x for _, x in combo]))
                if prob <= 0:
                    continue
                child = agent.branch()
                child.observe_look(v, {o: site for o, (site, _) in zip(objects, combo)})
                c, g, r = value(child, v, weight * prob)
                cost += prob * c
                gave += prob * g
                rest += prob * r
            memo[key] = (cost, gave, rest, weight)
            return cost, gave, rest

        cost, gave, rest = value(agent, None, 1.0)
    finally:
        env.close()
    return PolicyCost(cost, totals["unexpanded"], gave, len(memo), rest)


def gap_cap(world: str, model_name: str, task: str, cap: int = 3, max_bytes: int = MAX_BYTES) -> int:
    """The largest cap up to `cap` whose upper-cut tables fit `max_bytes` for the task's search.

    Raises:
        InputError: on ``--gaps``, when not even cap 1 fits (one line, with the sizes).
    """
    from fg_tea.planning.limit import _useful

    problem, objects = start_problem(world, model_name, task)
    useful, sites, _ = _useful(problem)
    fits = [c for c in range(cap, 0, -1) if table_bytes(useful.size, len(objects), sites.size, c + 1) <= max_bytes]
    if not fits:
        need = table_bytes(useful.size, len(objects), sites.size, 2)
        raise InputError("<command line>", "--gaps", f"the gap analysis of {task} needs the upper cut's tables: "
                         f"{useful.size} viewpoints and {len(objects)} objects need {human_bytes(need)} at cap 1, "
                         f"more than {human_bytes(max_bytes)} (--gaps-max-gb)")
    return fits[0]


def gap_analysis(world: str, model_name: str, planner: str, task: str, cap: int = 3,
                 floor: float = 1e-7, max_bytes: int = MAX_BYTES) -> dict:
    """Where a planner loses against the exact policy: at every decision it makes, the regret
    Q*(state, its look) - min_w Q*(state, w) under the upper cut's exact Q-values
    (:class:`fg_tea.planning.limit.Tables`) at the largest cap up to `cap` whose tables fit
    `max_bytes` (:func:`gap_cap`; returned as ``"cap"``), weighted by the chance of reaching the
    decision. Their sum is the planner's excess cost over the cut policy's (the performance
    difference identity), so the largest terms say which decisions make the gap."""
    from fg_tea.planning.limit import _useful, solve_tables

    cap = gap_cap(world, model_name, task, cap, max_bytes)
    problem, objects = start_problem(world, model_name, task)
    useful, sites, q0 = _useful(problem)
    tables = solve_tables(problem, useful, sites, q0, cap, upper=True)
    index = {problem.names[i]: j for j, i in enumerate(useful)}
    trace: list = []
    cost = evaluate_policy(world, model_name, planner, task, floor=floor, trace=trace)
    rows = []
    for weight, here, inspected, pending, chosen in trace:
        counts = np.zeros(len(useful), dtype=np.int64)
        for name, n in inspected.items():
            if name in index:
                counts[index[name]] = n
        found = sum(1 << u for u, o in enumerate(objects) if o not in pending)
        q = tables.q_values(None if here is None else index[here], counts, found)
        best = int(np.argmin(q))
        # beyond the cut (its look, or every look, forbidden there): not weighed
        regret = float(q[index[chosen]] - q[best]) if chosen in index and np.isfinite(q[best]) else float("inf")
        rows.append({"weight": weight, "here": here, "looks": dict(inspected), "pending": pending,
                     "chosen": chosen, "best": problem.names[useful[best]], "regret": regret,
                     "weighted": weight * regret})
    beyond = [r for r in rows if not np.isfinite(r["regret"])]
    rows = [r for r in rows if np.isfinite(r["regret"])]
    rows.sort(key=lambda r: -r["weighted"])
    return {"policy": cost, "cut_policy": tables.root, "cap": cap, "rows": rows,
            "excess": sum(r["weighted"] for r in rows),
            "beyond_cut": sum(r["weight"] for r in beyond)}
