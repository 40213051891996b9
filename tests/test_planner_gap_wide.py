"""experiments/planner_gap.py's wide-* phases (the 12-viewpoint houses, docs/design.md §6.9): the
limits kept between runs, the one-line faults, and both phases end to end on a small stand-in."""

from __future__ import annotations

import json

import pytest
from experiment_scripts import load_experiment

from fg_tea.common.errors import InputError
from fg_tea.planning.limit import Limit


def test_a_limit_is_computed_once_and_read_back_the_same(tmp_path, monkeypatch):
    gap = load_experiment("planner_gap")
    calls = []
    limit = Limit(11.8, 11.9, 3, 1000, 12, 1, 2, (4, 3, 3))

    def start_limit(world, model, task):
        calls.append((world, task))
        return limit, ["mug"]

    monkeypatch.setattr(gap.yardstick, "start_limit", start_limit)
    path = tmp_path / "limits.json"
    assert gap.kept_limit("independent_small_12", "find_mug", path) == (limit, ["mug"])
    assert gap.kept_limit("independent_small_12", "find_mug", path) == (limit, ["mug"])
    assert calls == [("independent_small_12", "find_mug")]
    assert "independent_small_12/factorised_close/find_mug" in json.loads(path.read_text())
    gap.kept_limit("independent_small_12", "find_three", path)  # another task is computed
    assert len(calls) == 2


def test_wide_confirmation_without_its_choice_or_the_first_confirmation_is_a_one_line_fault(tmp_path):
    gap = load_experiment("planner_gap")
    with pytest.raises(InputError, match="no discovery choice"):
        gap.main(["--phase", "wide-confirmation", "--worlds", "2", "--out", str(tmp_path)])
    with pytest.raises(InputError, match="no confirmation of near_exact"):
        gap.same_policy_rows("near_exact:restrict=1", tmp_path)


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_both_wide_phases_write_their_tables(tmp_path, monkeypatch):
    """On the 6-site house (the tables of every viewpoint fit, so restrict changes nothing): the
    choice, the confirmation's verdict and the same policy as near_exact's."""
    gap = load_experiment("planner_gap")
    monkeypatch.setattr(gap, "WIDE_HOUSES", ("independent_small_6",))
    monkeypatch.setattr(gap, "WIDE_TASKS", ("find_mug",))
    monkeypatch.setattr(gap, "WIDE_CANDIDATES", ("near_exact:restrict=1,slack=0.01",))
    out = tmp_path / "gap"
    out.mkdir()
    (out / "summary.csv").write_text("house,task,planner,policy_cost\n"
                                     "independent_small_6,find_mug,near_exact,7.74836\n")
    assert gap.main(["--phase", "wide-discovery", "--worlds", "2", "--out", str(out)]) == 0
    assert json.loads((out / "wide" / "choice.json").read_text())["planner"] == "near_exact:restrict=1,slack=0.01"
    assert gap.main(["--phase", "wide-confirmation", "--worlds", "2", "--out", str(out)]) == 0
    text = (out / "wide" / "summary.md").read_text()
    assert "| independent_small_6 | find_mug | 7.74836 | 7.74836 | yes |" in text
    assert "| near_exact:restrict=1,slack=0.01 | 1 |" in text
    assert (out / "wide" / "limits.json").is_file()
