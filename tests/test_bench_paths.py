"""``experiments/bench_inference.py --paths``: the bundled models through the compiled path and the
engine's path agree (max |difference| of the miss posteriors) and the table is written; no timing
is asserted (experiments/bench_paths.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_paths_side_by_side_agree_and_write_their_table(tmp_path):
    out = tmp_path / "paths.md"
    proc = subprocess.run([sys.executable, str(ROOT / "experiments" / "bench_inference.py"), "--paths",
                           "--out", str(out)], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    rows = [line.split("|")[1:-1] for line in out.read_text().splitlines() if line.startswith("| ")][1:]
    models = ["factorised", "factorised_close", "joint", "joint_close"]
    houses = ["default_apartment", "generated_medium seed 0", "generated_large seed 0"]
    assert [(r[0].strip(), r[1].strip()) for r in rows] == [(h, m) for h in houses for m in models]
    for r in rows:
        assert float(r[-1]) < 1e-12  # the two paths' posteriors
        assert float(r[4]) > 0 and float(r[7]) > 0
