"""experiments/derive_relations.py: co-location weights from a world distribution's own rules."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "experiments/derive_relations.py", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)


def test_a_small_derivation_writes_a_valid_joint_model_with_one_relation_per_rule(tmp_path):
    out = tmp_path / "jd.toml"
    done = _run("--worlds", "30", "--out", str(out))
    assert done.returncode == 0, done.stderr
    from fg_tea.model.spec import load_model

    model = load_model(out)
    pairs = {r.categories: (r.same_site, r.same_room) for r in model.relations if r.kind == "co_location"}
    assert set(pairs) == {("teabag", "kettle"), ("sugar", "kettle")}
    assert all(s > r > 1.0 for s, r in pairs.values())  # the rules put them together, more on one site
    assert model.structure == "joint" and any(r.kind == "capacity" for r in model.relations)


@pytest.mark.slow
def test_the_bundled_derived_model_is_what_the_script_writes(tmp_path):
    out = tmp_path / "jd.toml"
    assert _run("--out", str(out)).returncode == 0
    bundled = (ROOT / "models" / "joint_derived.toml").read_text().splitlines()
    written = out.read_text().splitlines()
    assert written[1:] == bundled[1:]  # the first line names the --out it was written to


def test_too_few_worlds_to_see_every_relation_is_one_line_not_an_infinite_weight(tmp_path):
    """A pair never seen apart (or never in one room) would get an infinite (or zero) weight."""
    done = _run("--worlds", "3", "--out", str(tmp_path / "jd.toml"))
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert "draw more worlds" in done.stderr and not (tmp_path / "jd.toml").exists()
