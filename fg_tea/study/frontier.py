"""The planner quality-cost frontier: paired episodes per (model, planner) with the wall and CPU
time of every decision, and the table and plot that summarise them.

Used by ``experiments/planner_frontier.py`` (one house) and ``experiments/lookahead_budget.py``
(a ladder of node budgets on several houses). One JSON file per episode under
``<out>/episodes/``; a re-run skips episodes already there, so an interrupted run resumes. Times
are wall-clock on whatever else the machine is running, so they stay out of the episode logs
(which remain deterministic) and are measured serially. Intervals are the paired percentile
bootstrap of :mod:`fg_tea.common.stats` over worlds.
"""

from __future__ import annotations

from functools import partial
import time
from pathlib import Path

import numpy as np

from fg_tea.common.errors import InputError
from fg_tea.common.stats import bootstrap_interval, bootstrap_ratio
from fg_tea.common.tables import table_lines
from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
from fg_tea.model.spec import load_model
from fg_tea.planning import check_planner
from fg_tea.study.episode_files import file_part, kept_or_run
from fg_tea.study.sweep import job_env, model_path, world_path
from fg_tea.world.distributions import load_world

DEFAULT_PLANNERS = ["optimal", "efe", "factorised_efe", "nearest", "lookahead",
                    "lookahead:depth=1", "lookahead:depth=3,width=3,nodes=150", "pouct:100",
                    "pouct:1000", "pomcp:1000"]


def episode_setup(world: str, seed: int, model_name: str, env_kind: str, miss_rate: float | None):
    """(model, the world of `seed`, its environment, the detector miss rate): a threshold camera
    misses at `miss_rate` (default the model's mu); a visibility camera draws from its curve."""
    model = load_model(model_path(model_name))
    scenario = load_world(world_path(world)).sample(seed)
    rate = model.miss_likelihood if miss_rate is None else miss_rate
    if not model.detector_kind.miss_rate:  # the camera's curve draws the misses (docs/design.md §3.4)
        rate = 0.0
    return model, scenario, job_env(env_kind, scenario, env_config_for(model, detection_miss_rate=rate)), rate


class DecisionClock:
    """The wall and CPU seconds of every decision a planner makes: its ``choose`` is wrapped in
    place, so whoever calls it (the agent, in an episode) is timed without knowing. Times stay
    out of the episode log, which remains deterministic."""

    def __init__(self, planner) -> None:
        self.wall: list[float] = []
        self.cpu: list[float] = []
        choose = planner.choose

        def timed(*args, **kwargs):
            start, start_cpu = time.perf_counter(), time.process_time()
            try:
                return choose(*args, **kwargs)
            finally:
                self.wall.append(time.perf_counter() - start)
                self.cpu.append(time.process_time() - start_cpu)

        planner.choose = timed


def played_episode(world: str, seed: int, model_name: str, planner: str, env_kind: str,
                   miss_rate: float | None) -> tuple[EpisodeRunner, DecisionClock, float]:
    """One episode of world `seed` played to its end (at most 2,000 steps): the runner (its
    events and metrics), the clock of its decisions and the detector's miss rate."""
    model, scenario, env, rate = episode_setup(world, seed, model_name, env_kind, miss_rate)
    try:
        runner = EpisodeRunner(scenario, model, env, RunConfig(seed=seed, planner=planner))
        clock = DecisionClock(runner.agent.planner)
        steps = 0
        while not runner.done and steps < 2000:
            runner.step()
            steps += 1
    finally:
        env.close()
    return runner, clock, rate


def run_episode(world: str, seed: int, model_name: str, planner: str, env_kind: str,
                miss_rate: float | None) -> dict:
    """One episode; returns its metrics and the wall and CPU time of every decision (seconds)."""
    runner, clock, rate = played_episode(world, seed, model_name, planner, env_kind, miss_rate)
    m = runner.metrics()
    return {"world": world, "seed": seed, "model": model_name, "planner": planner,
            "env": env_kind, "miss_rate": rate, "search_distance": m["search_distance"],
            "inspections": m["inspections"], "success": bool(m["success"]) and runner.done,
            "spl": m.get("spl"),
            "reason": runner.reason, "decision_seconds": clock.wall, "decision_cpu_seconds": clock.cpu}


#: Marker per planner (cycled) and colour per model: a legend names them, so no label sits on a point.
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "<", ">")


def log_ticks(ax) -> None:
    """A log axis with few, plainly written ticks (1, 10, 100 ms; no crowded minor labels)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ax.set_xscale("log")
    ax.xaxis.set_major_locator(LogLocator(base=10, numticks=6))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())


#: Columns of frontier.md's table of each model (SPL [95 %] added where the episodes logged it).
FRONTIER_HEADER = ("planner", "worlds", "search travel (m)", "ratio to optimal [95 %]", "ms/decision mean",
                   "ms/decision median", "p95", "CPU ms mean", "CPU ms median", "CPU ms per episode", "inspections",
                   "success")


def summarise(rows: list[dict], out: Path, reference: str = "optimal") -> str:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from fg_tea.common.files import atomic_write_text
    from fg_tea.study.analysis import save_figure

    lines = ["# Planner frontier", "",
             "Search travel relative to the `optimal` planner (the perfect-detection DP: optimal "
             "only for a detector that never misses, so not the optimum here, and a ratio below 1 "
             "is no ratio to an optimum) on paired worlds; 95 % paired bootstrap intervals; "
             "decision times are wall clock, serial, on a shared machine, mean (every decision "
             "included), median and 95th percentile (CPU: the process's CPU time for the same "
             "decisions, less sensitive to what else the machine runs, mean per decision and per "
             "episode).", ""]
    fig = Figure(figsize=(7.5, 4.8), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    planners_seen: list[str] = []
    models_seen = sorted({r["model"] for r in rows})
    with_spl = any(r.get("spl") is not None for r in rows)
    with_ref = any(r["planner"] == reference for r in rows)
    plotted = False
    if with_spl:
        lines[-1:-1] = ["SPL: success weighted by the clairvoyant route's search travel over the "
                        "agent's (docs/design.md eq. 48), mean over worlds with a 95 % bootstrap "
                        "interval (episodes recorded before SPL was logged have none).", ""]
    for model in sorted({r["model"] for r in rows}):
        by: dict[str, dict[int, dict]] = {}
        for r in rows:
            if r["model"] == model:
                by.setdefault(r["planner"], {})[r["seed"]] = r
        ref = by.get(reference, {})
        lines += [f"## model `{model}`, world `{rows[0]['world']}`, env `{rows[0]['env']}`, "
                  f"detector miss rate {rows[0]['miss_rate']}", ""]
        body = []
        points = []
        for planner, eps in by.items():
            seeds = sorted(set(eps) & set(ref)) if ref else sorted(eps)
            travel = np.array([eps[s]["search_distance"] for s in seeds])
            times = np.concatenate([eps[s]["decision_seconds"] for s in seeds]) * 1000
            cpu = [t for s in seeds for t in eps[s].get("decision_cpu_seconds", [])]
            cpu_cells = ([f"{np.mean(cpu) * 1000:.2f}", f"{np.median(cpu) * 1000:.2f}",
                          f"{np.mean([sum(eps[s]['decision_cpu_seconds']) for s in seeds]) * 1000:.1f}"]
                         if cpu else ["n/a"] * 3)
            ins = np.mean([eps[s]["inspections"] for s in seeds])
            succ = np.mean([eps[s]["success"] for s in seeds])
            if ref:
                base = np.array([ref[s]["search_distance"] for s in seeds])
                ratio = travel.mean() / base.mean()
                lo, hi = bootstrap_ratio(travel, base)
                ratio_txt = f"{ratio:.3f} [{lo:.3f}, {hi:.3f}]"
            else:
                ratio, ratio_txt = float("nan"), "n/a"
            mean, med, p95 = float(times.mean()), float(np.median(times)), float(np.percentile(times, 95))
            spl = np.array([eps[s]["spl"] for s in seeds if eps[s].get("spl") is not None])
            spl_mean = float(spl.mean()) if len(spl) else float("nan")
            spl_cells = []
            if with_spl:
                spl_cells = ["n/a"]
                if len(spl):
                    lo, hi = bootstrap_interval(spl)
                    part = f" (of {len(spl)} worlds)" if len(spl) < len(seeds) else ""
                    spl_cells = [f"{spl_mean:.3f} [{lo:.3f}, {hi:.3f}]{part}"]
            body.append([planner, len(seeds), f"{travel.mean():.2f}", ratio_txt, f"{mean:.2f}", f"{med:.2f}",
                         f"{p95:.2f}", *cpu_cells, f"{ins:.2f}", f"{succ:.2f}", *spl_cells])
            points.append((planner, mean, ratio if with_ref else spl_mean))
        lines += table_lines(FRONTIER_HEADER + (("SPL [95 %]",) if with_spl else ()), body, align="left") + [""]
        for planner, mean_ms, ratio in points:
            if not (np.isfinite(ratio) and mean_ms > 0):  # no reference (and no SPL): nothing to plot
                continue
            plotted = True
            if planner not in planners_seen:
                planners_seen.append(planner)
            ax.scatter(mean_ms, ratio, marker=MARKERS[planners_seen.index(planner) % len(MARKERS)],
                       color=f"C{models_seen.index(model)}", s=36,
                       label=f"{planner} ({model})")
    if plotted:
        log_ticks(ax)
        ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5), frameon=False)
    ax.axhline(1.0, color="grey", lw=0.8)
    ax.set_xlabel("mean ms per decision (log)")
    ax.set_ylabel("search travel / `optimal` (perfect-detection DP)" if with_ref else "SPL (clairvoyant route)")
    worlds = len({r["seed"] for r in rows})
    ax.set_title("Planner quality-cost frontier" + (f"\nn = {worlds} world{'s' if worlds != 1 else ''}: "
                                                     "intervals are wide or not shown"
                                                     if worlds < 5 else ""))
    save_figure(fig, out / "frontier.png")
    text = "\n".join(lines) + "\n"
    atomic_write_text(out / "frontier.md", text)
    return text


def check_inputs(world: str, worlds: int, models: list[str], planners: list[str],
                 miss_rate: float | None = None) -> None:
    """Every input checked before any episode runs.

    Raises:
        InputError: the first bad value, named by its flag.
    """
    if worlds < 1:
        raise InputError("<command line>", "--worlds", f"{worlds}: must be at least 1")
    if not world_path(world, "--world").exists():
        raise InputError("<command line>", "--world", f"unknown world {world!r}")
    for model in models:
        loaded = load_model(model_path(model, "--models"))  # InputError naming the file and fault
        if miss_rate is not None and not loaded.detector_kind.miss_rate:
            raise InputError("<command line>", "--miss-rate", f"has no effect with model {model!r}: "
                             f"its {loaded.detector} detector draws each detection from the camera's curve")
    for name in planners:
        check_planner(name)


def run_frontier(world: str, worlds: int, first_seed: int, models: list[str], planners: list[str],
                 env_kind: str, miss_rate: float | None, out: Path, summary_only: bool = False) -> list[dict]:
    """Every (model, planner, seed) episode, run or read back from ``out/episodes``; the rows."""
    episodes = out / "episodes"
    episodes.mkdir(parents=True, exist_ok=True)
    rows = []
    for model in models:
        for planner in planners:
            for seed in range(first_seed, first_seed + worlds):
                path = episodes / f"{world}__{model}__{file_part(planner)}__{seed:05d}.json"
                row = kept_or_run(path, None if summary_only else
                                  partial(run_episode, world, seed, model, planner, env_kind, miss_rate))
                if row is not None:
                    rows.append(row)
            print(f"{model} {planner}: done", flush=True)
    return rows


__all__ = ["DEFAULT_PLANNERS", "DecisionClock", "MARKERS", "log_ticks", "run_episode", "summarise",
           "check_inputs", "run_frontier"]
