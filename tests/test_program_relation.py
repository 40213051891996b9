"""experiments/program_relation.py: a tiny run writes its seed sets first, its worlds, rows and report."""

from __future__ import annotations

import pytest
import csv
import json
import subprocess
import sys
from pathlib import Path

from fg_tea.study.rows import read_rows
from fg_tea.world.distributions import load_world

ROOT = Path(__file__).resolve().parent.parent


def _run(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "experiments/program_relation.py", *argv], capture_output=True,
                          text=True, timeout=600, stdin=subprocess.DEVNULL, cwd=ROOT)


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_tiny_fake_run_pairs_the_program_with_the_factorised_belief(tmp_path):
    args = ("--worlds", "2", "--confirmation-worlds", "1", "--confirmation-first-seed", "500",
            "--sizes", "small", "--planners", "factorised_efe", "--env", "fake", "--executor", "serial",
            "--out", str(tmp_path))
    proc = _run(*args)
    assert proc.returncode == 0, proc.stderr[-2000:]
    sets = json.loads((tmp_path / "seed_sets.json").read_text())
    assert json.dumps(sets).count("discovery") and json.dumps(sets).count("confirmation")
    rows = read_rows(tmp_path / "episodes.csv")
    assert len(rows) == 3 * 2  # (2 + 1) worlds x {factorised, program}
    assert {r["model"] for r in rows} == {"factorised", "kept_together"}
    assert {r["structure"] for r in rows} == {"factorised", "joint"}
    assert {r["world_seed"] for r in rows} == {0, 1, 500}
    world = load_world(tmp_path / "worlds" / "kept_together_small.json")
    assert world.together[0].objects == ("mug", "teabag", "kettle")
    assert (world.together[0].within, world.together[0].weight) == (2.5, 20.0)
    for r in rows:  # each row's truth is the world's draw for its seed
        truth = {o.name: o.true_site for o in world.sample(int(r["world_seed"])).objects}
        assert all(r[f"true_site_{o}"] == site for o, site in truth.items())
    text = (tmp_path / "summary.md").read_text()
    assert "## Replication: program − factorised search travel (m)" in text
    assert "| small | eqs. 10-11 | 3 |" in text  # pooled pairs: both sets
    with (tmp_path / "replication.csv").open(newline="", encoding="utf-8") as fh:
        rep = list(csv.DictReader(fh))
    assert [(r["discovery_pairs"], r["confirmation_pairs"]) for r in rep] == [("2", "1")]
    again = _run(*args)  # resumes: nothing new to run, same rows
    assert again.returncode == 0, again.stderr[-2000:]
    assert len(read_rows(tmp_path / "episodes.csv")) == 6


def test_bad_arguments_are_one_line(tmp_path):
    proc = _run("--worlds", "0", "--out", str(tmp_path))
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    proc = _run("--planners", "no_such_planner", "--out", str(tmp_path))
    assert proc.returncode == 2 and "no_such_planner" in proc.stderr
    assert not (tmp_path / "seed_sets.json").exists()
