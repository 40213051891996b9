"""Smoke test: ``experiments/inspect_marginals.py`` (the README's worked API example) runs end to end.

It steps one PyBullet episode, prints every object's marginal and every hidden state after each
step, and writes its PNG atomically to ``--out``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "experiments" / "inspect_marginals.py"


@pytest.mark.parametrize("model", ["joint", "factorised"])
@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_inspect_marginals_prints_every_object_and_writes_the_png(tmp_path, model):
    out = tmp_path / "plots" / "marginals.png"
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, str(SCRIPT), "--model", model, "--seed", "1",
                           "--out", str(out)],
                          capture_output=True, text=True, timeout=300, env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    text = proc.stdout
    assert out.is_file() and out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in out.parent.iterdir()] == ["marginals.png"]    # no temporary left
    assert "step 0 (prior)" in text and "done: complete" in text
    for obj in ("mug", "kettle", "teabag"):
        assert f"\n  {obj} " in text                    # a row of the marginal table
        assert f"{obj} SEEN" in text                    # the inspection that found it
    for state in ("kettle.contains_water", "mug.tea_brewed", "mug.served"):
        assert state in text
    assert "decide   look for" in text and "observe  " in text and "act      " in text
