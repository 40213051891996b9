"""Quality against cost: how close does each planner come to the Bayes-optimal search, and how fast?

For every (model, planner) the script runs the same paired worlds (world seed s, episode seed s)
headlessly and records, per episode, the search travel, inspections, success and the wall time of
every planner decision. It then writes

- ``frontier.md``: per model and planner, mean search travel, the ratio of means to the
  Bayes-optimal planner (``optimal``, the perfect-detection limit) with a paired bootstrap 95 %
  interval over worlds, median and 95th-percentile decision time (ms), inspections and success;
- ``frontier.png``: ratio to optimal against median ms per decision (log scale), one point per
  planner and model.

One JSON file per episode under ``<out>/episodes/``; a re-run skips episodes already there, so an
interrupted run resumes. Times are wall-clock on whatever else the machine is running, so they
stay out of the episode logs (which remain deterministic) and are measured serially.

    python experiments/planner_frontier.py                      # every default planner (long)
    python experiments/planner_frontier.py --worlds 20 --planners optimal efe lookahead pouct:1000
    # the committed headline (experiments/results/planner_frontier/), about 6 minutes on 2 cores:
    python experiments/planner_frontier.py --worlds 100 --models factorised_close joint_close \
        --planners optimal efe lookahead lookahead:nodes=60 pouct:1000 \
        --out experiments/results/planner_frontier
    # beyond the optimal planner's reach (SPL against the clairvoyant route), about 20 minutes:
    python experiments/planner_frontier.py --world generated_medium --worlds 30 \
        --models factorised_close joint_close --planners efe lookahead pouct:100 pouct:1000 \
        --out experiments/results/planner_frontier/generated_medium

The default environment is the fake house (straight-line travel, oracle pixel counts) with an
injected detector miss rate equal to the model's mu (0.05), so the detector misses as often as
the agent assumes; search travel there is metres walked on straight lines, the same metric every
planner is scored and plans with.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from fg_tea.common.files import out_folder  # noqa: E402
from fg_tea.common.errors import run_script  # noqa: E402
from fg_tea.study.frontier import (  # noqa: E402
    DEFAULT_PLANNERS,
    check_inputs,
    run_frontier,
    summarise,
)


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.options import (
        ENV_HELP,
        MODELS_HELP,
        WORLD_HELP,
        experiment_parser,
    )

    p = experiment_parser(__doc__, __file__, "§6.5, §6.6 and §6.7")
    p.add_argument("--worlds", type=int, default=100, help="number of paired worlds")
    p.add_argument("--first-seed", type=int, default=0, help="first world seed (and episode seed)")
    p.add_argument("--world", default="correlated", help=WORLD_HELP)
    p.add_argument("--models", nargs="+", default=["factorised_close", "joint_close"], help=MODELS_HELP)
    p.add_argument("--planners", nargs="+", default=None,
                   help=f"planner names, with options as in lookahead:depth=3 or pouct:1000 "
                   f"(default: {' '.join(DEFAULT_PLANNERS)})")
    p.add_argument("--env", choices=("fake", "pybullet"), default="fake", help=ENV_HELP)
    p.add_argument("--miss-rate", type=float, default=None,
                   help="injected detector miss rate (default: the model's mu)")
    p.add_argument("--out", type=out_folder, default="runs/experiments/planner_frontier",
                   help="output folder (default: %(default)s)")
    p.add_argument("--summary-only", action="store_true",
                   help="run nothing: summarise the episodes already in OUT/episodes (missing "
                        "ones are left out, so a planner may cover fewer worlds)")
    return p


def main(argv: list[str] | None = None) -> int:
    p = build_parser()
    args = p.parse_args(argv)
    planners = args.planners or list(DEFAULT_PLANNERS)
    try:
        import pomdp_py  # noqa: F401
    except ImportError:
        skipped = [x for x in planners if x.startswith(("pouct", "pomcp"))]
        if skipped:
            print(f"pomdp-py not installed; skipping {', '.join(skipped)} (pip install -e \".[peers]\")")
        planners = [x for x in planners if x not in skipped]
    check_inputs(args.world, args.worlds, args.models, planners, args.miss_rate)
    out = Path(args.out)
    rows = run_frontier(args.world, args.worlds, args.first_seed, args.models, planners, args.env,
                        args.miss_rate, out, args.summary_only)
    print(summarise(rows, out))
    return 0


if __name__ == "__main__":
    run_script(main, "planner_frontier.py")
