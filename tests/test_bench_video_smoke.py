"""Smoke test: ``experiments/bench_video.py --quick`` runs end to end and reports a ratio."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_bench_video_quick_measures_both_runs(tmp_path):
    out = tmp_path / "bench.md"
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, str(ROOT / "experiments" / "bench_video.py"), "--quick",
                           "--repeats", "1", "--out", str(out)],
                          capture_output=True, text=True, timeout=600, env=env, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    text = out.read_text()
    rows = re.findall(r"\| (?:headless|video) \| `fg-tea run[^|]*\| ([0-9.]+) \| ([0-9.]+) \|", text)
    assert len(rows) == 2, text
    assert all(float(cpu) > 0 for cpu, _ in rows)
    ratio = re.search(r"\*\*Ratio: ([0-9.]+)x\*\*", text)
    assert ratio and float(ratio.group(1)) == pytest.approx(float(rows[1][0]) / float(rows[0][0]), rel=0.02, abs=0.06)
