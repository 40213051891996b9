"""``experiments/bench_paths.py`` (also ``bench_inference.py --paths``): the bundled models through
the compiled path and the engine's path agree (max |difference| of the miss posteriors), and whole
episodes through ``--solver compiled`` make the engine's decisions; both tables are written; no
timing is asserted."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _rows(text: str, heading: str) -> list[list[str]]:
    block = text.split(heading, 1)[1].split("\n## ", 1)[0]
    return [[c.strip() for c in line.split("|")[1:-1]] for line in block.splitlines() if line.startswith("| ")][1:]


@pytest.mark.slow
def test_paths_side_by_side_agree_and_write_their_tables(tmp_path):
    out = tmp_path / "paths.md"
    proc = subprocess.run([sys.executable, str(ROOT / "experiments" / "bench_paths.py"), "--repeats", "2",
                           "--episode-repeats", "1", "--out", str(out)],
                          capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    text = out.read_text()
    rows = _rows(text, "## Compiled path vs engine path")
    models = ["factorised", "factorised_close", "joint", "joint_close"]
    houses = ["default_apartment", "generated_medium seed 0", "generated_large seed 0"]
    assert [(r[0], r[1]) for r in rows] == [(h, m) for h in houses for m in models]
    for r in rows:
        assert float(r[-1]) < 1e-12  # the two paths' posteriors
        assert float(r[4]) > 0 and float(r[7]) > 0
    episodes = _rows(text, "## Whole episodes through each path")
    assert len(episodes) == 12 and all(r[-1] == "yes" for r in episodes)  # the same decisions
