"""Time the test suite: the quick loop (``-m "not slow"``) and the full suite, as CI runs them.

The targets (docs/guide/tests.md): the quick loop under 2 minutes and the full suite under 10
minutes on two idle cores. This script runs ``python -m pytest -q -m "not slow"`` and
``python -m pytest -q`` one after the other in this checkout, then writes one row per run to
``test_times.csv`` in ``--out`` (default ``runs/experiments/time_tests``), replacing that run's
older row (git keeps the history): the date, the command, wall
seconds, the outcome line, the core count and the 1-minute load average before the run (a busy
machine is visible in the row). The committed copy, test_times.csv in experiments/results,
changes only when ``--out`` names that folder:

    python experiments/time_tests.py --out experiments/results
    python experiments/time_tests.py --which quick         # the quick loop only, under runs/
"""

from __future__ import annotations

import argparse
import csv
import datetime
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

from fg_tea.common.errors import run_script
from fg_tea.common.files import atomic_path, out_folder
from fg_tea.common.options import experiment_parser

DEFAULT_OUT = Path("runs") / "experiments" / "time_tests"
RUNS = {"quick": ["-m", "pytest", "-q", "-m", "not slow"], "full": ["-m", "pytest", "-q"]}
FIELDS = ("date", "which", "command", "wall_s", "outcome", "cores", "load_before")


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§1 (the tests; docs/guide/tests.md)")
    p.add_argument("--which", nargs="+", choices=tuple(RUNS), default=list(RUNS),
                   help="which runs to time")
    p.add_argument("--out", type=out_folder, default=str(DEFAULT_OUT),
                   help="folder of test_times.csv (committed: experiments/results)")
    return p


def time_run(which: str) -> dict:
    """Run one pytest command in the checkout; its row."""
    load = os.getloadavg()[0]
    start = time.perf_counter()
    done = subprocess.run([sys.executable, *RUNS[which]], cwd=ROOT, capture_output=True, text=True,
                          stdin=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    lines = [line for line in done.stdout.splitlines() if " in " in line and ("passed" in line
                                                                            or "failed" in line)]
    return {"date": datetime.date.today().isoformat(), "which": which,
            "command": "python " + " ".join(a if " " not in a else f'"{a}"' for a in RUNS[which]),
            "wall_s": round(wall, 1), "outcome": (lines[-1] if lines else f"exit {done.returncode}").strip("= "),
            "cores": os.cpu_count(), "load_before": round(load, 2)}


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    out = Path(args.out) / "test_times.csv"
    rows = []
    if out.exists():
        with out.open(newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
    # Every run first, then one write: the suite being timed reads this file (the docs quote it),
    # so it must not change under it. One row per run kind, the newest (git keeps the history).
    new = []
    for which in args.which:
        row = time_run(which)
        print(f"{which}: {row['wall_s']} s, {row['outcome']} (load before {row['load_before']})")
        new.append(row)
    rows = [r for r in rows if r["which"] not in {n["which"] for n in new}] + new
    with atomic_path(out) as tmp, tmp.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, FIELDS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    print(f"times: {out}; now run python docs/tools/render_numbers.py")
    return 0


if __name__ == "__main__":
    run_script(main, "time_tests.py")
