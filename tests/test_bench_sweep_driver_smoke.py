"""Smoke test: ``experiments/bench_sweep_driver.py --quick`` drives stub jobs through the process
pool's real loop (and the former one, with ``--before``) and writes its table; no timing is asserted
(timings belong in the committed results, experiments/results/bench_sweep_driver.md)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_sweep_driver_quick(tmp_path):
    out = tmp_path / "driver.md"
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, str(ROOT / "experiments" / "bench_sweep_driver.py"), "--quick",
                           "--before", "--job-seconds", "0.001", "--out", str(out)],
                          capture_output=True, text=True, timeout=300, env=env, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    text = out.read_text()
    assert "stub jobs sleeping 0.001 s, 2 workers" in text and "at most 4 jobs in flight" in text
    rows = re.findall(r"^\| process \| (window|before) \| ([\d,]+) \| ([\d.]+) \| ([\d.]+) \|", text, re.M)
    assert [(loop, n) for loop, n, *_ in rows] == [("window", "50"), ("before", "50"), ("window", "200"),
                                                   ("before", "200")]
    assert all(float(per_job) >= 0 for *_, per_job in rows)
