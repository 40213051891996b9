"""Planners beside a lower bound on the search limit where the limit's tables do not fit (27, 45 sites).

The exact limit (experiments/search_limit.py) needs a table per count vector and answers up to
about 8 viewpoints. Beyond, the optimal expected search travel V* is bounded from below by
fg_tea/planning/limit_bound.py (docs/design.md §6.9: perfect looks, one object at a time, each
look at its cheapest arrival), and from above by any planner's mean cost. This script runs
search-only tasks (``find_mug``, ``find_three``) in the fake house, on worlds whose objects are
drawn from the model's own prior over a fresh generated house per world seed
(``independent_medium``: 6 rooms, about 27 sites; ``independent_large``: 10 rooms, about 45), and
writes the comparison report per task (``<out>/<task>/summary.md``, ``summary.csv``): each
planner's mean search travel beside the mean bound over the same worlds, and travel ÷ bound, an
upper end on the planner's ratio to the optimum. Search travel has no look cost here, and the
bound none either.

    python experiments/search_bound.py --world independent_medium --worlds 30 \\
        --out experiments/results/search_bound/medium
    python experiments/search_bound.py --world independent_large --worlds 30 \\
        --out experiments/results/search_bound/large
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from fg_tea.common.errors import InputError, run_script
from fg_tea.common.files import out_folder

TASKS = ("find_mug", "find_three")


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.options import MODEL_HELP, WORLD_HELP, experiment_parser

    p = experiment_parser(__doc__, __file__, "§6.9")
    p.add_argument("--worlds", type=int, default=30, help="worlds per task and planner (seeds from --first-seed)")
    p.add_argument("--first-seed", type=int, default=0, help="first world seed")
    p.add_argument("--world", default="independent_medium", help=WORLD_HELP)
    p.add_argument("--model", default="factorised_close", help=MODEL_HELP)
    p.add_argument("--tasks", nargs="+", default=list(TASKS), choices=TASKS, help="search-only tasks")
    p.add_argument("--planners", nargs="+", default=["efe", "lookahead"],
                   help="planner names, with options as in lookahead:nodes=60")
    p.add_argument("--workers", type=int, default=1, help="processes (1: serial)")
    p.add_argument("--out", type=out_folder, default="runs/experiments/search_bound", help="output folder")
    return p


def main(argv: list[str] | None = None) -> int:
    from fg_tea.study.report import comparison_report
    from fg_tea.study.sweep import check_jobs, plan_sweep, run_sweep

    args = build_parser().parse_args(argv)
    if args.worlds < 1:
        raise InputError("<command line>", "--worlds", f"{args.worlds}: must be at least 1")
    command = "python experiments/search_bound.py " + shlex.join(argv if argv is not None else sys.argv[1:])
    for task in args.tasks:
        jobs = plan_sweep([args.world], args.worlds, [args.model], args.planners, first_seed=args.first_seed,
                          env="fake", task=task)
        check_jobs(jobs)
        out = Path(args.out) / task
        out.mkdir(parents=True, exist_ok=True)
        rows = run_sweep(jobs, out / "episodes.csv", "serial" if args.workers == 1 else "process",
                         workers=args.workers, progress=True, label=task)
        comparison_report(rows, out, title=f"Planners beside the search bound: `{task}` on `{args.world}`",
                          command=command)
        print((out / "summary.md").read_text(encoding="utf-8").split("## Search travel beside")[1].split("##")[0])
    return 0


if __name__ == "__main__":
    run_script(main, "search_bound.py")
