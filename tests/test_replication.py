"""Replication built into the method (fg_tea.study.replication, docs/design.md §11.1)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fg_tea.common.errors import InputError
from fg_tea.study.replication import (ESTABLISHED, NO_DIFFERENCE, NOT_RESOLVED, SeedSet,
                                      declare_seed_sets, pairs_to_resolve_lines, read_seed_sets,
                                      replication_cells, replication_markdown)

SETS = [SeedSet("discovery", 0, 60), SeedSet("confirmation", 5000, 60)]


def _rows(effect: dict, seeds, rng, planner="efe", world="w", same_share=0.0):
    """Sweep-like rows: factorised travels 20 +- 3 m; joint differs by `effect[set]` on the worlds
    that do not repeat the factorised searches (a share `same_share` of them)."""
    rows = []
    for seed in seeds:
        base = 20 + 3 * rng.standard_normal()
        same = rng.random() < same_share
        shift = 0.0 if same else effect(seed) + rng.standard_normal()
        for model, travel in (("factorised", base), ("joint", base + shift)):
            rows.append({"world": world, "world_seed": seed, "seed": seed, "task": "make_tea",
                         "planner": planner, "model": model, "search_distance": travel,
                         "inspections": 5 if same or model == "factorised" else 4,
                         "success": True, "reason": "complete"})
    return rows


def test_a_real_effect_is_established_and_a_chance_one_is_not():
    rng = np.random.default_rng(1)
    seeds = list(range(60)) + list(range(5000, 5060))
    rows = _rows(lambda s: -1.0, seeds, rng, planner="real", same_share=0.5)
    # discovery shows an effect that the confirmation set does not have
    rows += _rows(lambda s: -1.0 if s < 5000 else 0.0, seeds, rng, planner="chance")
    rows += _rows(lambda s: 0.0, seeds, rng, planner="none", same_share=1.0)
    cells = {c["planner"]: c for c in replication_cells(rows, SETS)}
    assert cells["real"]["verdict"] == ESTABLISHED
    assert cells["chance"]["verdict"] == NOT_RESOLVED
    assert cells["none"]["verdict"] == NO_DIFFERENCE
    real = cells["real"]
    assert 0.3 < real["discovery"]["share_differ"] < 0.7
    assert real["discovery"]["if_differ"].mean < real["discovery"]["difference"].mean < 0
    adjusted, raw = real["confirmation"]["adjusted"], real["confirmation"]["difference"]
    assert adjusted.low < raw.low and adjusted.high > raw.high
    assert real["confirmation"]["p_holm"] >= real["confirmation"]["p"]
    from fg_tea.common.stats import pairs_needed

    diffs = np.array(real["discovery"]["diffs"])
    assert real["pairs_needed"] == pairs_needed(float(diffs.std(ddof=1)),
                                                0.03 * real["discovery"]["baseline"])
    assert 8 < real["pairs_needed"] < 40  # 3 % of ~20 m is ~0.6 m; the differences' sd is ~0.9 m
    text = replication_markdown(list(cells.values()), SETS)
    assert "confirmation (world seeds 5000-5059)" in text and "**established**" in text


def test_seed_sets_are_declared_once_and_must_be_disjoint(tmp_path):
    path = declare_seed_sets(tmp_path, SETS)
    assert json.loads(path.read_text())["sets"][1] == {"name": "confirmation", "first": 5000, "count": 60}
    assert declare_seed_sets(tmp_path, SETS) == path and read_seed_sets(tmp_path) == SETS
    with pytest.raises(InputError, match="a run with other seed sets goes to another --out"):
        declare_seed_sets(tmp_path, [SeedSet("discovery", 0, 60), SeedSet("confirmation", 6000, 60)])
    with pytest.raises(InputError, match="overlap"):
        declare_seed_sets(tmp_path / "b", [SeedSet("discovery", 0, 60), SeedSet("confirmation", 30, 60)])
    assert read_seed_sets(tmp_path / "none") == []


def test_a_single_comparison_says_how_many_pairs_would_resolve_it():
    rng = np.random.default_rng(2)
    lines = pairs_to_resolve_lines(_rows(lambda s: -0.5, range(20), rng), "model", "factorised")
    assert len(lines) == 1 and "over 20 pairs" in lines[0] and "pairs would resolve 3% of search_distance" in lines[0]


@pytest.mark.slow
def test_fg_tea_compare_runs_a_declared_confirmation_set(tmp_path, capsys):
    from fg_tea.cli.main import main

    out = tmp_path / "c"
    argv = ["compare", "--env", "fake", "--worlds", "3", "--planners", "efe", "nearest",
            "--confirmation-first-seed", "10000", "--out", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    lines = [line for line in printed.splitlines() if line.startswith("replication: ")]
    assert len(lines) == 2 and "(planner=nearest): no difference" in lines[1]
    assert json.loads((out / "seed_sets.json").read_text())["sets"][1]["first"] == 10000
    text = (out / "replication.md").read_text()
    assert "--confirmation-first-seed 10000 --confirmation-worlds 3" in text and "| efe |" in text
    assert main([*argv[:-4], "--confirmation-first-seed", "20000", "--out", str(out)]) == 2
    assert "another --out" in capsys.readouterr().err
    for bad, fault in ((["--confirmation-worlds", "3"], "applies only with --confirmation-first-seed"),
                       (["--models", "joint", "--confirmation-first-seed", "10"], "needs two models"),
                       (["--confirmation-first-seed", "1"], "overlap")):
        assert main(["compare", "--env", "fake", "--worlds", "3", *bad, "--out", str(tmp_path / "x")]) == 2
        assert fault in capsys.readouterr().err


def test_a_cell_a_planner_refused_has_no_pairs_not_a_verdict():
    from fg_tea.study.replication import NO_PAIRS

    rng = np.random.default_rng(3)
    rows = _rows(lambda s: -1.0, list(range(60)) + list(range(5000, 5060)), rng, planner="la")
    for r in rows:
        if r["model"] == "joint":
            r.update(reason="refused: belief: lookahead planner: too many joint truths", success=False)
    (cell,) = replication_cells(rows, SETS)
    assert cell["verdict"] == NO_PAIRS and cell["discovery"]["pairs"] == 0


def test_planner_pairs_are_judged_and_adjusted_over_every_comparison():
    """Pairs of planners on the same worlds and belief (vary="planner"); adjusting the union of
    several comparisons multiplies more p-values, so no cell's Holm p falls and the Bonferroni
    intervals widen."""
    from fg_tea.study.replication import adjust

    rng = np.random.default_rng(2)
    seeds = list(range(60)) + list(range(5000, 5060))
    rows = []
    for r in _rows(lambda s: -2.0, seeds, rng, planner="x"):
        # relabel: the "joint" row becomes planner lookahead, the "factorised" one efe, one belief
        rows.append({**r, "planner": "lookahead" if r["model"] == "joint" else "efe", "model": "factorised"})
    one = replication_cells(rows, SETS, vary="planner", baseline="efe", other="lookahead", by=("task", "model"))
    assert len(one) == 1 and one[0]["verdict"] == ESTABLISHED and one[0]["confirmation"]["pairs"] == 60
    before = one[0]["confirmation"]["p_holm"], one[0]["confirmation"]["adjusted"]
    noise = replication_cells(_rows(lambda s: 0.0, seeds, rng, planner="y"), SETS, by=("task", "planner"))
    both = adjust(one + noise, SETS)
    assert both[0]["confirmation"]["p_holm"] >= before[0]
    assert both[0]["confirmation"]["adjusted"].low < before[1].low
    text = replication_markdown(both, SETS, ("task",), compared="planners")
    assert "two planners' searches" in text


def test_the_table_gives_each_difference_in_per_cent_of_the_baseline():
    from fg_tea.common.stats import t_interval
    from fg_tea.study.replication import _percent

    entry = {"pairs": 3, "difference": t_interval([-1.0, -2.0, -3.0]), "baseline": 20.0}
    pct = _percent(entry)
    assert pct.mean == -10.0 and pct.low == 100.0 * entry["difference"].low / 20.0
    assert _percent({"pairs": 0, "difference": t_interval([]), "baseline": 0.0}).fmt() == "–"
