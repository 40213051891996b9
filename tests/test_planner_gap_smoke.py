"""experiments/planner_gap.py end to end on a few worlds: the diagnosis, the design choice, the
confirmation and the SPL tables are written from what was run (docs/design.md §6.9)."""

from __future__ import annotations

import csv
import json

import pytest
from experiment_scripts import load_experiment

from fg_tea.common.errors import InputError


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_a_quick_run_writes_every_table(tmp_path):
    gap = load_experiment("planner_gap")
    out = tmp_path / "gap"
    assert gap.main(["--phase", "all", "--worlds", "2", "--houses", "independent_small_6", "--tasks", "find_mug",
                     "--out", str(out)]) == 0
    diagnosis = (out / "diagnosis.md").read_text()
    assert "| independent_small_6 | find_mug | 8.0244 |" in diagnosis  # the lookahead's exact policy cost
    assert "| exact re-looks |" in diagnosis and "## All searches" in diagnosis
    choice = json.loads((out / "choice.json").read_text())["planner"]
    assert choice in gap.CANDIDATES
    rows = list(csv.DictReader((out / "summary.csv").open()))
    assert {r["planner"] for r in rows} == {"lookahead", "exact", gap.plain_name(choice)}
    mine = next(r for r in rows if r["planner"] == gap.plain_name(choice))
    assert float(mine["ratio_high"]) <= 1.02 and int(mine["worlds"]) == 2
    assert "| largest policy ratio (upper end) |" in (out / "summary.md").read_text()
    spl = (out / "spl.md").read_text()
    assert spl.count("+0.0000 [+0.0000, +0.0000]") == 2 and "| 0.0% |" in spl  # the lookahead's own decisions


def test_confirmation_without_a_choice_and_too_few_worlds_are_one_line_faults(tmp_path):
    gap = load_experiment("planner_gap")
    with pytest.raises(InputError, match="no discovery choice"):
        gap.main(["--phase", "confirmation", "--worlds", "2", "--out", str(tmp_path)])
    with pytest.raises(InputError, match="at least 2"):
        gap.main(["--worlds", "1", "--out", str(tmp_path)])
