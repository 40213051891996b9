"""Which node budget should the lookahead planner use by default, judged on several houses at once?

The rule (docs/design.md §6.6): run the lookahead with a ladder of node budgets on paired worlds
of every house and close-look model; the default is the smallest budget whose paired mean search
travel is not detectably worse than the largest budget's on *every* house and model, i.e. the
95 % paired bootstrap interval of mean(travel_N - travel_largest) over worlds reaches 0 or lies
below it. Its decision time is then checked against the 5 ms target (median, wall and CPU).

For each house the episodes are run as by ``experiments/planner_frontier.py``
(:func:`fg_tea.study.frontier.run_frontier`) into
``<out>/<world>/episodes/`` (so runs resume and can be shared with frontier runs), and this
script writes ``<out>/budget.md``: per house, model and budget, the paired difference and ratio
to the largest budget with their intervals, the median and 95th-percentile decision time (wall
and CPU, ms) and inspections, then the budget the rule picks.

    python experiments/lookahead_budget.py                       # the committed ladder (long)
    python experiments/lookahead_budget.py --summary-only --out runs/experiments/lookahead_budget
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from fg_tea.common.errors import InputError, run_script
from fg_tea.common.files import out_folder, atomic_write_text
from fg_tea.common.stats import bootstrap_interval, bootstrap_ratio
from fg_tea.common.tables import table_lines
from fg_tea.study.frontier import run_frontier, summarise

LADDER = (10, 20, 40, 60, 120, 240)
HOUSES = ("correlated:100", "generated_small:30", "generated_medium:30")


def load_rows(folder: Path) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted((folder / "episodes").glob("*.json"))]


#: Columns of each model's table of its ladder of node budgets.
LADDER_HEADER = ("nodes", "worlds", "travel (m)", "minus largest (m) [95 %]", "ratio to largest [95 %]", "not worse",
                 "ms median wall", "CPU", "p95 wall", "CPU", "inspections")


def budget_table(rows: list[dict], ladder: tuple[int, ...]) -> tuple[list[str], dict]:
    """Markdown lines and ``{(model, N): passes}`` for one house's ladder episodes."""
    lines, verdict = [], {}
    top = max(ladder)
    for model in sorted({r["model"] for r in rows}):
        by: dict[int, dict[int, dict]] = {}
        for r in rows:
            if r["model"] == model and r["planner"].startswith("lookahead:nodes="):
                by.setdefault(int(r["planner"].split("=")[1]), {})[r["seed"]] = r
        if top not in by:
            continue
        lines += [f"### model `{model}`", ""]
        body = []
        for n in ladder:
            if n not in by:
                continue
            seeds = sorted(set(by[n]) & set(by[top]))
            x = np.array([by[n][s]["search_distance"] for s in seeds])
            y = np.array([by[top][s]["search_distance"] for s in seeds])
            d = x - y
            lo, hi = bootstrap_interval(d)
            rlo, rhi = bootstrap_ratio(x, y)
            ok = lo <= 0.0
            verdict[(model, n)] = ok
            wall = np.concatenate([by[n][s]["decision_seconds"] for s in seeds]) * 1000
            cpu = np.concatenate([by[n][s]["decision_cpu_seconds"] for s in seeds]) * 1000
            ins = np.mean([by[n][s]["inspections"] for s in seeds])
            body.append([n, len(seeds), f"{x.mean():.2f}", f"{d.mean():+.2f} [{lo:+.2f}, {hi:+.2f}]",
                         f"{x.mean() / y.mean():.3f} [{rlo:.3f}, {rhi:.3f}]", "yes" if ok else "no",
                         f"{np.median(wall):.2f}", f"{np.median(cpu):.2f}", f"{np.percentile(wall, 95):.1f}",
                         f"{np.percentile(cpu, 95):.1f}", f"{ins:.2f}"])
        lines += table_lines(LADDER_HEADER, body, align="left") + [""]
    return lines, verdict


def check(args: argparse.Namespace) -> None:
    """Every house, budget and model, checked before any episode runs.

    Raises:
        InputError: the first bad value, named by its flag.
    """
    from fg_tea.study.sweep import job_model, job_world

    for house in args.houses:
        world, _, count = house.partition(":")
        if count and not (count.isdigit() and int(count) >= 1):
            raise InputError("<command line>", "--houses", f"{house!r}: WORLDS must be a positive integer")
        job_world(world, ())
    if len(set(args.ladder)) < 2 or min(args.ladder) < 1:
        raise InputError("<command line>", "--ladder", "give at least two different budgets, each >= 1")
    for m in args.models:
        job_model(m, ())


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.options import MODELS_HELP, experiment_parser

    p = experiment_parser(__doc__, __file__, "§6.6")
    p.add_argument("--houses", nargs="+", default=list(HOUSES),
                   help="houses as WORLD:WORLDS pairs (world distribution : number of worlds)")
    p.add_argument("--ladder", nargs="+", type=int, default=list(LADDER),
                   help="node budgets (tree nodes per decision); the largest is the reference")
    p.add_argument("--models", nargs="+", default=["factorised_close", "joint_close"], help=MODELS_HELP)
    p.add_argument("--out", type=out_folder, default="runs/experiments/lookahead_budget",
                   help="output folder: OUT/budget.md and OUT/<world>/ (default: %(default)s)")
    p.add_argument("--summary-only", action="store_true",
                   help="run nothing; summarise the episodes already under OUT/<world>/episodes")
    return p


def main(argv: list[str] | None = None) -> int:
    p = build_parser()
    args = p.parse_args(argv)
    check(args)
    ladder = tuple(sorted(args.ladder))
    out = Path(args.out)
    planners = [f"lookahead:nodes={n}" for n in ladder]
    lines = ["# Lookahead node budget across houses", "",
             "Rule: the smallest budget whose paired mean search travel is not detectably worse "
             f"than the largest budget's ({max(ladder)} nodes), i.e. the 95 % paired bootstrap "
             "interval of the mean difference reaches 0 or lies below it, on every house and "
             "model. Fake house, detector miss rate = the model's mu (0.05). Times: ms per "
             "decision on a shared 2-core machine (wall, and the process's CPU time).", ""]
    passes: dict[int, list[bool]] = {n: [] for n in ladder}
    for house in args.houses:
        world, _, count = house.partition(":")
        folder = out / world
        if not args.summary_only:
            rows = run_frontier(world, int(count or "30"), 0, args.models, planners, "fake", None, folder)
            print(summarise(rows, folder))
        rows = load_rows(folder)
        if not rows:
            continue
        table, verdict = budget_table(rows, ladder)
        lines += [f"## house `{world}`", ""] + table
        for (_, n), ok in verdict.items():
            passes[n].append(ok)
    chosen = next((n for n in ladder if passes[n] and all(passes[n])), None)
    lines.append(f"Smallest budget passing on every house and model: "
                 f"{chosen if chosen is not None else 'none'}.")
    text = "\n".join(lines) + "\n"
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "budget.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    run_script(main, "lookahead_budget.py")
