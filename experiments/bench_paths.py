"""The bundled models through the compiled path against the engine's path, side by side.

For each bundled model on the default apartment, on the same factors (the model's program,
``fg.program_from_model``, is what both start from):

- **engine**: :class:`fg_tea.beliefs.engine.BeliefEngine` (numpy backend), the path episodes take;
- **compiled**: ``fg.compile_program`` of the model's program (docs/design.md §4.8).

Two CPU times (``time.process_time``, best of the repeats), each ratio compiled / engine:

- **update**: a belief update — every object missed at one site (eqs. 5-6, the engine's miss
  factors as the compiled path's likelihoods), then every location marginal;
- **decision**: one planner's worth of hypothetical queries — for every object, its miss and its
  detection at every site as one candidate each (``hypothetical_all`` on the engine;
  ``hypothetical_many`` on the compiled model, reporting the location variables, a detection as
  the likelihood 1 - miss there and the false-positive rate elsewhere), all posterior location
  marginals; the misses' posteriors of the two paths are compared.

The miss posteriors of both paths (the update's and the decision's) are compared (max |difference|,
must be ~1e-12). Run it alone or through ``python experiments/bench_inference.py --paths``; it writes under
``runs/experiments/bench_paths/`` unless ``--out`` names the committed table:

    python experiments/bench_paths.py --out experiments/results/bench_paths.md
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

import fg_tea as fg
from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.beliefs.factors import miss_factor
from fg_tea.common.tables import table_lines

MODELS = ("factorised", "factorised_close", "joint", "joint_close")
TARGET = 1.2


def _best(call: Callable[[], Any], repeats: int) -> tuple[float, Any]:
    best, out = float("inf"), None
    for _ in range(repeats):
        start = time.process_time()
        out = call()
        best = min(best, time.process_time() - start)
    return best, out


def measure(name: str, scenario: Any, repeats: int = 20) -> dict[str, Any]:
    """One bundled model's row: CPU seconds per update and per decision on each path."""
    model = fg.load_model(name)
    engine = BeliefEngine(scenario, model)
    compiled = fg.compile_program(fg.program_from_model(scenario, model))
    objects, k = list(engine.objects), len(engine.sites)
    site = 0
    misses = {o: miss_factor(o, site, k, model.miss_likelihood).table for o in objects}

    def engine_update() -> dict[str, np.ndarray]:
        c = engine.copy()
        c.observe_site(engine.sites[site], {o: False for o in objects})
        return {o: c.location(o) for o in objects}

    def compiled_update() -> dict[str, np.ndarray]:
        return compiled.observe_many(misses).marginals(objects)

    def engine_decision() -> np.ndarray:
        return engine.copy().hypothetical_all()[0]

    def compiled_decision() -> np.ndarray:
        rows = np.ones((2 * k, k))
        rows[k:] = model.false_positive_rate
        np.fill_diagonal(rows[:k], model.miss_likelihood)        # row j: the miss at site j (eq. 5)
        np.fill_diagonal(rows[k:], 1.0 - model.miss_likelihood)  # row k + j: a detection there
        hyp = compiled.hypothetical_many({o: rows for o in objects}, report=objects)
        return np.array([[hyp[o].marginals[other][:k] for other in objects] for o in objects]).transpose(0, 2, 1, 3)

    row: dict[str, Any] = {"model": name, "structure": model.structure, "objects": len(objects), "sites": k}
    (row["update_engine"], a), (row["update_compiled"], b) = _best(engine_update, repeats), _best(
        compiled_update, repeats)
    diff = max(float(np.max(np.abs(a[o] - b[o]))) for o in objects)
    (row["decision_engine"], a), (row["decision_compiled"], b) = _best(engine_decision, repeats), _best(
        compiled_decision, repeats)
    row["max_diff"] = max(diff, float(np.max(np.abs(a - b))))
    return row


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table of the rows, with each ratio against the target."""
    body = []
    for r in rows:
        u, d = r["update_compiled"] / r["update_engine"], r["decision_compiled"] / r["decision_engine"]
        body.append([r["house"], r["model"], r["structure"], f"{r['objects']} x {r['sites']}",
                     f"{1e3 * r['update_engine']:.3f}", f"{1e3 * r['update_compiled']:.3f}", f"{u:.2f}",
                     f"{1e3 * r['decision_engine']:.3f}", f"{1e3 * r['decision_compiled']:.3f}", f"{d:.2f}",
                     f"{r['max_diff']:.1e}"])
    return "\n".join(table_lines(["house", "model", "structure", "N x K", "update engine ms", "update compiled ms",
                                  "ratio", "decision engine ms", "decision compiled ms", "ratio", "max diff"], body,
                                 align="left"))


def houses() -> list[tuple[str, Any]]:
    """The benchmark houses: the bundled apartment, and the first drawn house (seed 0) of the
    27- and 45-site generated world distributions."""
    from fg_tea.study.sweep import world_path
    from fg_tea.world.distributions import load_world

    drawn = [(f"{w} seed 0", load_world(world_path(w)).sample(0)) for w in ("generated_medium", "generated_large")]
    return [("default_apartment", fg.load_scenario("default_apartment"))] + drawn


EPISODE_WORLDS = ("independent", "generated_medium", "generated_large")


def episode_cpu(world: str, model: str, solver: str) -> tuple[float, list[float], list]:
    """CPU seconds of one fake-house episode (world seed 0, episode seed 0) with `solver`, the
    CPU of each decision, and the looks it chose."""
    from fg_tea.episode.runner import EpisodeRunner, RunConfig
    from fg_tea.study.frontier import DecisionClock, episode_setup

    model_spec, scenario, env, _ = episode_setup(world, 0, model, "fake", None)
    try:
        start = time.process_time()
        runner = EpisodeRunner(scenario, model_spec, env, RunConfig(seed=0, solver=solver))
        clock = DecisionClock(runner.agent.planner)
        while not runner.done:
            runner.step()
        total = time.process_time() - start
    finally:
        env.close()
    looks = [(e.get("object"), e.get("viewpoint")) for e in runner.events if e["event"] == "decision"]
    return total, clock.cpu, looks


def episodes(repeats: int = 5) -> str:
    """Whole episodes through each path: the engine's (``--solver numpy``) and the compiled
    location block (``--solver compiled``), CPU per episode (best of `repeats` runs of the same
    episode) and per decision (each decision's best of the runs, then their mean), the two paths'
    runs interleaved so that a slower spell of the machine falls on both; and whether the two made
    the same decisions."""
    body, over = [], []
    for world in EPISODE_WORLDS:
        for model in MODELS:
            runs: dict[str, list] = {"numpy": [], "compiled": []}
            for _ in range(repeats):
                for solver in runs:
                    runs[solver].append(episode_cpu(world, model, solver))
            best: dict[str, tuple[float, float, list]] = {}
            for solver, done in runs.items():
                per_decision = np.min([r[1] for r in done], axis=0)  # deterministic: the same decisions
                best[solver] = (min(r[0] for r in done), float(np.mean(per_decision)) if len(per_decision)
                                else 0.0, done[0][2])
            ratios = [best["compiled"][i] / best["numpy"][i] if best["numpy"][i] > 0 else float("nan")
                      for i in (0, 1)]
            over += [f"{world} {model} {what} {r:.2f}x" for what, r in zip(("episode", "decision"), ratios)
                     if r > TARGET]
            body.append([world, model, len(best["numpy"][2]), f"{1e3 * best['numpy'][0]:.0f}",
                         f"{1e3 * best['compiled'][0]:.0f}", f"{ratios[0]:.2f}", f"{1e3 * best['numpy'][1]:.3f}",
                         f"{1e3 * best['compiled'][1]:.3f}", f"{ratios[1]:.2f}",
                         "yes" if best["numpy"][2] == best["compiled"][2] else "no"])
    verdict = (f"every ratio is within the target of {TARGET}x" if not over else
               f"above the target of {TARGET}x: " + ", ".join(over))
    return ("## Whole episodes through each path\n\n"
            f"A make-tea episode in the fake house (world seed 0 of each world distribution, episode seed 0), "
            f"run with `--solver numpy` (the engine) and `--solver compiled` (the location block a compiled "
            f"program, docs/design.md §4.8), CPU (time.process_time) per episode (best of {repeats} runs) and per "
            f"decision (the planner's `choose`: each decision's best of the {repeats} runs, then the mean over the "
            "episode's decisions), the two paths' runs interleaved; ratio = compiled / numpy.\n\n"
            + "\n".join(table_lines(["world", "model", "decisions", "episode numpy ms", "episode compiled ms",
                                      "episode ratio", "decision numpy ms", "decision compiled ms", "decision ratio",
                                      "same decisions"],
                                     body, align="left"))
            + "\n\n" + verdict + "\n")


def run(repeats: int = 20, episode_repeats: int = 5) -> str:
    """The side-by-side section: the table and, per ratio, whether it meets the target."""
    rows = [dict(measure(m, scenario, repeats), house=house) for house, scenario in houses() for m in MODELS]
    over = [f"{r['house']} {r['model']} {what} {r[what + '_compiled'] / r[what + '_engine']:.2f}x" for r in rows
            for what in ("update", "decision") if r[what + "_compiled"] / r[what + "_engine"] > TARGET]
    verdict = (f"every ratio is within the target of {TARGET}x" if not over else
               f"above the target of {TARGET}x: " + ", ".join(over))
    return ("## Compiled path vs engine path (bundled models, three houses)\n\n"
            "CPU time (time.process_time, best of " + str(repeats) + ") per belief update (every object missed "
            "at one site, then every marginal) and per decision (every object's miss and detection at every "
            "site as hypotheticals); ratio = compiled / engine. Made by `python experiments/bench_inference.py --paths "
            "--out experiments/results/bench_paths.md`.\n\n" + table(rows) + "\n\n" + verdict + "\n\n"
            + episodes(episode_repeats))


DEFAULT_OUT = Path("runs") / "experiments" / "bench_paths" / "bench_paths.md"


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.files import out_file
    from fg_tea.common.options import experiment_parser

    p = experiment_parser(__doc__, __file__, "§4.8")
    p.add_argument("--repeats", type=int, default=20, help="calls timed per measurement (the best is kept)")
    p.add_argument("--episode-repeats", type=int, default=5, help="runs of each episode (the best is kept)")
    p.add_argument("--out", type=out_file, default=DEFAULT_OUT, help="the Markdown table to write")
    return p


def main(argv: list[str] | None = None) -> int:
    from fg_tea.common.files import atomic_write_text

    args = build_parser().parse_args(argv)
    atomic_write_text(Path(args.out), run(args.repeats, args.episode_repeats))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    from fg_tea.common.errors import run_script

    run_script(main, "bench_paths.py")
