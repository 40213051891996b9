"""Smoke test: ``experiments/bench_inference.py --quick`` runs end to end and reports agreement."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_bench_inference_quick_runs_and_methods_agree(tmp_path):
    out = tmp_path / "bench.md"
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, str(ROOT / "experiments" / "bench_inference.py"),
                           "--quick", "--out", str(out)],
                          capture_output=True, text=True, timeout=300, env=env, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    text = out.read_text()
    assert "| joint | 3×8 |" in text and "| factorised | 3×6 |" in text
    agreement = re.search(r"gtsam ([0-9.e+-]+), pgmpy ([0-9.e+-]+), dense ([0-9.e+-]+)", text)
    assert agreement, text
    assert all(float(x) < 1e-9 for x in agreement.groups())
    assert "joint 3×8 full planner query set" in text
