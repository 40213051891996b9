"""Factorised versus joint beliefs, with every planner, over many sampled worlds (docs/design.md §11).

Runs N worlds (default 200) of a world distribution (default ``correlated``: the teabag is kept
with the kettle half of the time) x models (default factorised, joint) x planners (default efe,
factorised_efe, nearest, greedy, random, optimal), headless in the PyBullet house, on a process
pool over every core; every configuration solves the same worlds with the same seeds. Writes to
``--out`` (default ``runs/experiments/compare_beliefs``):

- ``episodes.csv``: one row per episode (all log metrics, seeds, model, planner, world
  parameters, true sites, kettle water truth, per-inspection entropy trace);
- ``summary.md`` / ``summary.csv``: means with 95 % confidence intervals per model and planner;
  ``paired.csv`` and the paired differences joint − factorised; each planner relative to the
  Bayes-optimal planner; an ablation table when ablation models are passed with ``--models``;
- ``travel_inspections.png``, ``entropy.png``, ``ratio_to_optimal.png``.

Resuming is on by default: episodes whose key is already in ``episodes.csv`` are not run again
(keys name the full configuration, so a different sweep never reuses a row it did not plan);
``--no-resume`` discards the CSV and starts afresh.

This script is the same code path as ``fg-tea compare`` (it only changes the default output
folder). The committed results in ``experiments/results/compare`` change only when ``--out`` names
that folder (their ``summary.md`` starts with the exact command that made them):

    python experiments/compare_beliefs.py --episode-seeds world --out experiments/results/compare   # 200 worlds: 4 min 37 s

and these write under ``runs/experiments/compare_beliefs``:

    python experiments/compare_beliefs.py --quick          # 10 worlds, 4 planners (CI)
    python experiments/compare_beliefs.py --executor ray --address auto
"""

from __future__ import annotations

import argparse
from pathlib import Path

from fg_tea.cli.compare import add_compare_arguments  # noqa: E402
from fg_tea.cli.main import main as fg_tea_main  # noqa: E402
from fg_tea.common.options import experiment_parser

#: Default output folder, relative to the working directory like every fg-tea output under runs/.
DEFAULT_OUT = Path("runs") / "experiments" / "compare_beliefs"


def build_parser() -> argparse.ArgumentParser:
    """The options of ``fg-tea compare``, under this script's name, with ``--out`` defaulting to
    runs/experiments/compare_beliefs."""
    p = experiment_parser(__doc__, __file__, "§11")
    add_compare_arguments(p, out=str(DEFAULT_OUT))
    return p


def main(argv: list[str] | None = None) -> int:
    """Run ``fg-tea compare`` with ``--out`` defaulting to runs/experiments/compare_beliefs."""
    return fg_tea_main(argv, parser_factory=build_parser)


if __name__ == "__main__":
    raise SystemExit(main())
