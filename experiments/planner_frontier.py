"""Quality against cost: how close does each planner come to the best possible search, and how fast?

Two yardsticks (``--yardstick``):

- ``limit`` (the default): the search limit under imperfect detection (docs/design.md §6.9), the
  least expected cost of finding every object when looks can miss, bracketed from both sides.
  Search-only tasks (``find_mug``, ``find_three``) on worlds drawn from the model's own prior, one
  factorised model with close looks; each planner's exact policy cost and its sampled episodes
  against the optimum as intervals, [cost / upper, cost / lower] (never below 1), and
  ``frontier.png`` draws them against mean CPU ms per decision (every solve included).
  It is the study of ``experiments/search_limit.py`` (``summary.md``, ``episodes.csv``,
  ``gaps.md``; see there), run here with the frontier's planners.
- ``optimal``: search travel in the make-tea episode against the perfect-detection DP
  (``optimal``), which is not the best policy when looks can miss; kept for the correlated worlds
  and joint beliefs the limit does not cover. It writes

  - ``frontier.md``: per model and planner, mean search travel, the ratio of means to the
    ``optimal`` planner (not the optimum when looks can miss) with a paired bootstrap 95 % interval
    over worlds, mean, median and 95th-percentile decision time (ms), CPU ms per decision (mean,
    median) and per episode, inspections and success;
  - ``frontier.png``: ratio to ``optimal`` against mean ms per decision (log scale), one point per
    planner and model.

One JSON file per episode under ``<out>/episodes/``; a re-run skips episodes already there, so an
interrupted run resumes. Times are measured serially; the episode logs stay deterministic.

    python experiments/planner_frontier.py --worlds 50               # against the limit, a few minutes
    # the peers' budgets against the limit, with where the lookahead loses (gaps.md):
    python experiments/planner_frontier.py --worlds 200 --planners efe lookahead exact \\
        pouct:100 pouct:1000 pouct:3000 pomcp:100 pomcp:1000 pomcp:3000 --gaps lookahead
    # the committed tables (experiments/results/search_limit*/) are search_limit.py's, whose
    # summary.md names its command
    # against the perfect-detection DP (experiments/results/planner_frontier/), about 6 minutes:
    python experiments/planner_frontier.py --yardstick optimal --worlds 100 \\
        --models factorised_close joint_close \\
        --planners optimal efe lookahead lookahead:nodes=60 pouct:1000 \\
        --out experiments/results/planner_frontier
    # beyond the optimal planner's reach (SPL against the clairvoyant route), about 20 minutes:
    python experiments/planner_frontier.py --yardstick optimal --world generated_medium --worlds 30 \\
        --models factorised_close joint_close --planners efe lookahead pouct:100 pouct:1000 \\
        --out experiments/results/planner_frontier/generated_medium

The environment is the fake house (straight-line travel, oracle pixel counts) with an injected
detector miss rate equal to the model's mu (0.05), so the detector misses as often as the agent
assumes; with ``--yardstick optimal``, ``--env pybullet`` runs the PyBullet house instead.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from fg_tea.common.files import check_out_dir, out_folder
from fg_tea.common.errors import InputError, run_script
from fg_tea.study import yardstick
from fg_tea.study.frontier import (
    DEFAULT_PLANNERS,
    check_inputs,
    run_frontier,
    summarise,
)

YARDSTICKS = ("limit", "optimal")
#: Default output folders: OUT_ROOT/limit and OUT_ROOT/optimal (each yardstick writes its own
#: frontier.png and episodes/, so they never share a folder).
OUT_ROOT = Path("runs") / "experiments" / "planner_frontier"


def output_path(args: argparse.Namespace) -> Path:
    """The output folder: --out, else OUT_ROOT/<yardstick>."""
    return Path(args.out) if args.out else OUT_ROOT / args.yardstick


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.options import (
        ENV_HELP,
        MODELS_HELP,
        WORLD_HELP,
        experiment_parser,
    )

    p = experiment_parser(__doc__, __file__, "§6.5, §6.6, §6.7 and §6.9")
    p.add_argument("--yardstick", choices=YARDSTICKS, default="limit",
                   help="limit: against the search limit under imperfect detection (search-only "
                   "tasks, one factorised close-look model); optimal: make-tea search travel against "
                   "the perfect-detection DP (default: %(default)s)")
    p.add_argument("--worlds", type=int, default=None,
                   help="number of paired worlds (default: 200 against the limit, 100 against optimal)")
    p.add_argument("--first-seed", type=int, default=0, help="first world seed (and episode seed)")
    p.add_argument("--world", default=None,
                   help=WORLD_HELP + " (default: independent against the limit, correlated against optimal)")
    p.add_argument("--models", nargs="+", default=None,
                   help=MODELS_HELP + " (default: factorised_close against the limit, which takes one; "
                   "factorised_close joint_close against optimal)")
    p.add_argument("--planners", nargs="+", default=None,
                   help=f"planner names, with options as in lookahead:depth=3 or pouct:1000 "
                   f"(default: {' '.join(yardstick.PLANNERS)} against the limit, "
                   f"{' '.join(DEFAULT_PLANNERS)} against optimal)")
    p.add_argument("--tasks", nargs="+", default=None, choices=yardstick.TASKS,
                   help="search-only tasks, against the limit only (default: find_mug find_three)")
    p.add_argument("--gaps", nargs="*", default=None,
                   help="against the limit only: planners whose decisions are compared with the "
                   "exact policy's (gaps.md; default: none)")
    p.add_argument("--env", choices=("fake", "pybullet"), default=None,
                   help=ENV_HELP + " (against optimal only; the limit's episodes are in the fake house)")
    p.add_argument("--miss-rate", type=float, default=None,
                   help="injected detector miss rate, against optimal only (default: the model's mu)")
    p.add_argument("--out", type=out_folder, default=None,
                   help="output folder (default: runs/experiments/planner_frontier/limit or "
                   "runs/experiments/planner_frontier/optimal, by yardstick)")
    p.add_argument("--summary-only", action="store_true",
                   help="against optimal: run nothing, summarise the episodes already in "
                        "OUT/episodes (missing ones are left out, so a planner may cover fewer worlds)")
    return p


def main(argv: list[str] | None = None) -> int:
    p = build_parser()
    args = p.parse_args(argv)
    if args.yardstick == "limit":
        return _against_limit(args, argv)
    for flag, value in (("--tasks", args.tasks), ("--gaps", args.gaps)):
        if value is not None:
            raise InputError("<command line>", flag, "has no effect with --yardstick optimal: "
                             "its episodes run the make-tea task, against the perfect-detection DP")
    planners = _installed(args.planners or list(DEFAULT_PLANNERS))
    world, models = args.world or "correlated", args.models or ["factorised_close", "joint_close"]
    worlds = 100 if args.worlds is None else args.worlds
    check_inputs(world, worlds, models, planners, args.miss_rate)
    out = check_out_dir(output_path(args))
    rows = run_frontier(world, worlds, args.first_seed, models, planners, args.env or "fake",
                        args.miss_rate, out, args.summary_only)
    print(summarise(rows, out))
    return 0


def _against_limit(args: argparse.Namespace, argv: list[str] | None) -> int:
    """The search-limit study (fg_tea.study.yardstick.study) with the frontier's planners."""
    for flag, value, why in (("--env", args.env not in (None, "fake"), "the limit's episodes run in the fake house"),
                             ("--miss-rate", args.miss_rate is not None, "the limit's detector misses "
                              "as often as the model says, so that the ratio measures planning alone"),
                             ("--summary-only", args.summary_only, "the limit's study resumes from "
                              "OUT/episodes by itself")):
        if value:
            raise InputError("<command line>", flag, f"has no effect with --yardstick limit: {why}")
    if args.models is not None and len(args.models) != 1:
        raise InputError("<command line>", "--models", f"{' '.join(args.models)}: the limit takes one "
                         "factorised model with close looks (e.g. factorised_close)")
    planners = _installed(args.planners or list(yardstick.PLANNERS))
    world, model = args.world or "independent", (args.models or ["factorised_close"])[0]
    worlds = 200 if args.worlds is None else args.worlds
    check_inputs(world, worlds, [model], planners)
    command = "python experiments/planner_frontier.py " + shlex.join(argv if argv is not None else sys.argv[1:])
    out = check_out_dir(output_path(args))
    print(yardstick.study(world, range(args.first_seed, args.first_seed + worlds), model,
                          args.tasks or list(yardstick.TASKS), planners, out, command,
                          gaps=args.gaps or (), model_flag="--models"))
    return 0


def _installed(planners: list[str]) -> list[str]:
    """The planners whose libraries are installed; the peers' are skipped with a note."""
    try:
        import pomdp_py  # noqa: F401
    except ImportError:
        skipped = [x for x in planners if x.startswith(("pouct", "pomcp"))]
        if skipped:
            print(f"pomdp-py not installed; skipping {', '.join(skipped)} (pip install -e \".[peers]\")")
        return [x for x in planners if x not in skipped]
    return planners


if __name__ == "__main__":
    run_script(main, "planner_frontier.py")
