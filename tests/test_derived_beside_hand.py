"""joint_derived − joint, paired across two committed tables (experiments/derived_beside_hand.py)."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _script():
    from experiment_scripts import load_experiment

    return load_experiment("derived_beside_hand")


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_each_cell_is_the_paired_difference_of_the_two_tables(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    assert _script().main(["--out", str(tmp_path)]) == 0
    rows = list(csv.DictReader((tmp_path / "replication.csv").open()))
    cell = next(r for r in rows if (r["size"], r["task"], r["planner"]) == ("small", "make_tea", "eqs. 10-11"))

    def travel(path, model):
        with open(path, newline="") as fh:
            return {(r["world_seed"], r["seed"]): float(r["search_distance"]) for r in csv.DictReader(fh)
                    if r["world"] == "generated_small" and r["task"] == "make_tea"
                    and r["model"] == model and r["planner"] == "factorised_efe"
                    and int(r["world_seed"]) >= 10000}

    derived = travel("experiments/results/joint_vs_factorised_derived/houses/episodes.csv", "joint_derived")
    hand = travel("experiments/results/joint_vs_factorised/houses/episodes.csv", "joint")
    diffs = [derived[k] - hand[k] for k in derived if k in hand]
    assert len(diffs) == int(cell["confirmation_pairs"]) == 200
    assert math.isclose(sum(diffs) / len(diffs), float(cell["confirmation_diff"]), rel_tol=1e-12)
    assert "## Replication: joint_derived − joint" in (tmp_path / "summary.md").read_text()


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_tables_of_other_seed_sets_are_refused(tmp_path, monkeypatch):
    from fg_tea.common.errors import InputError

    monkeypatch.chdir(ROOT)
    with pytest.raises(InputError, match="other seed sets"):
        _script().main(["--hand", "experiments/results/joint_vs_factorised_powered/houses",
                        "--out", str(tmp_path)])
    with pytest.raises(InputError, match="no such episodes CSV"):
        _script().main(["--hand", str(tmp_path / "none"), "--out", str(tmp_path)])


@pytest.mark.slow  # reads three large committed tables: the full suite (CI) runs it
def test_any_two_models_pair_and_a_related_tables_worlds_pair_with_the_houses_tables(tmp_path, monkeypatch):
    """The per-size derived model of the related table against joint_derived: its worlds
    (``..._related_2``) pair with the derived table's by world seed, world by world."""
    from fg_tea.common.errors import InputError

    monkeypatch.chdir(ROOT)
    related = "experiments/results/joint_vs_factorised_related_world_seeds/related"
    assert _script().main(["--derived", related, "--derived-model", "joint_related_2",
                           "--hand", "experiments/results/joint_vs_factorised_derived/houses",
                           "--hand-model", "joint_derived", "--out", str(tmp_path)]) == 0
    rows = list(csv.DictReader((tmp_path / "replication.csv").open()))
    assert {(r["size"], r["task"], r["planner"]) for r in rows} == {
        ("small", "make_tea_milk_sugar", "eqs. 10-11"), ("medium", "make_tea_milk_sugar", "eqs. 10-11")}
    assert all(r["discovery_pairs"] == r["confirmation_pairs"] == "200" for r in rows)
    committed = list(csv.DictReader(open(
        "experiments/results/joint_vs_factorised_related_world_seeds/beside_derived/replication.csv")))
    assert [r["confirmation_diff"] for r in rows] == [r["confirmation_diff"] for r in committed]
    with pytest.raises(InputError, match="name two models"):
        _script().main(["--derived-model", "joint", "--out", str(tmp_path)])
