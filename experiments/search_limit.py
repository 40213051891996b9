"""How far is each planner from the best possible search? Its cost against the exact limit.

The limit is the optimal expected cost of finding every object when looks can miss, bracketed
from both sides (fg_tea/planning/limit.py, docs/design.md §6.9). Each planner runs a search-only
task (``find_mug``, ``find_three``) on worlds drawn from the model's own prior (``independent``),
in the fake house with a detector that misses as often as the model says, so its cost against
the limit measures planning alone. A ratio to the optimum is an interval, [cost / upper, cost /
lower], never below 1 (a policy that finds every object costs at least the optimum; a give-up is
charged the sweep that would finish the search). CPU per decision is reported as mean, median and
95th percentile, every solve included, and per episode. Writes ``summary.md`` and ``episodes.csv``
to ``--out``, and one JSON file per episode under ``--out``/episodes (a re-run resumes).

    python experiments/search_limit.py --worlds 50                  # a quick look, about a minute
    # the committed table (experiments/results/search_limit/):
    python experiments/search_limit.py --worlds 200 --planners efe lookahead lookahead:relook=1 \\
        lookahead:relook=1,nodes=60 exact exact:cap=2 optimal pouct:100 pouct:1000 pouct:3000 \\
        pomcp:100 pomcp:1000 pomcp:3000 --gaps lookahead lookahead:relook=1 \\
        --out experiments/results/search_limit   # its summary.md names the command exactly
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from fg_tea.common.errors import InputError, run_script
from fg_tea.common.files import out_folder
from fg_tea.study import yardstick


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.options import MODEL_HELP, WORLD_HELP, experiment_parser

    p = experiment_parser(__doc__, __file__, "§6.9")
    p.add_argument("--worlds", type=int, default=200, help="worlds per task and planner (seeds from --first-seed)")
    p.add_argument("--first-seed", type=int, default=0, help="first world seed (and episode seed)")
    p.add_argument("--world", default="independent", help=WORLD_HELP)
    p.add_argument("--model", default="factorised_close", help=MODEL_HELP)
    p.add_argument("--tasks", nargs="+", default=list(yardstick.TASKS), choices=yardstick.TASKS,
                   help="search-only tasks")
    p.add_argument("--planners", nargs="+", default=list(yardstick.PLANNERS),
                   help="planner names, with options as in lookahead:nodes=60")
    p.add_argument("--tolerance", type=float, default=1e-3,
                   help="width of the limit's bracket to stop at, metres (if memory allows)")
    p.add_argument("--max-gb", type=float, default=2.0,
                   help="memory each solve of the limit may use, GiB: the full tables where they fit, else two "
                        "layers of them at a time (docs/design.md §6.9) (default: %(default)s)")
    p.add_argument("--gaps", nargs="*", default=["lookahead"],
                   help="planners whose decisions are compared with the exact policy's (gaps.md)")
    p.add_argument("--gaps-max-gb", type=float, default=2.0,
                   help="memory the gap analysis's tables may use, GiB: it uses the largest cap up to 3 "
                        "that fits (default: %(default)s)")
    p.add_argument("--out", type=out_folder, default="runs/experiments/search_limit",
                   help="output folder")
    return p


def main(argv: list[str] | None = None) -> int:
    from fg_tea.study.frontier import check_inputs

    args = build_parser().parse_args(argv)
    check_inputs(args.world, args.worlds, [args.model], args.planners)
    if not (args.tolerance > 0):
        raise InputError("<command line>", "--tolerance", f"{args.tolerance}: must be above 0")
    if not (args.max_gb > 0):
        raise InputError("<command line>", "--max-gb", f"{args.max_gb}: must be above 0")
    if not (args.gaps_max_gb > 0):
        raise InputError("<command line>", "--gaps-max-gb", f"{args.gaps_max_gb}: must be above 0")
    command = "python experiments/search_limit.py " + shlex.join(argv if argv is not None else sys.argv[1:])
    text = yardstick.study(args.world, range(args.first_seed, args.first_seed + args.worlds), args.model,
                           args.tasks, args.planners, Path(args.out), command, args.tolerance, args.gaps,
                           int(args.gaps_max_gb * 1024 ** 3), max_bytes=int(args.max_gb * 1024 ** 3))
    print(text)
    return 0


if __name__ == "__main__":
    run_script(main, "search_limit.py")
