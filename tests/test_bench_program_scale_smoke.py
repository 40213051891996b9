"""Smoke test: ``experiments/bench_program_scale.py --quick`` runs end to end on the 45-site house
beyond the dense joint, elimination agrees with the dense joint where both run, and the case over
the budget is refused in one line."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_bench_program_scale_quick(tmp_path):
    out = tmp_path / "scale.md"
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, str(ROOT / "experiments" / "bench_program_scale.py"),
                           "--quick", "--out", str(out)],
                          capture_output=True, text=True, timeout=600, env=env, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    text = out.read_text()
    assert "| co-location + user factor | elimination | 4 + 1 |" in text
    assert "| + capacity 1 on 15 sites | refused |" in text
    refusal = re.search(r"refused in one line: `([^`]*)`", text)
    assert refusal and "elimination width" in refusal.group(1) and "budget" in refusal.group(1)
    agreement = re.search(r"hypothetical posterior: ([0-9.e+-]+); vs gtsam's marginals "
                          r"\(check_against_gtsam\): ([0-9.e+-]+)\.", text)
    assert agreement and all(float(x) < 1e-9 for x in agreement.groups())
