"""A comparison's report puts a lower bound on the optimum beside each planner's search travel
(fg_tea/study/bounds.py, docs/design.md §6.9)."""

from __future__ import annotations

import csv

import pytest

from fg_tea.planning.bracket import search_limit
from fg_tea.planning.limit_bound import lower_bound
from fg_tea.study.bounds import row_bound, start_bound
from fg_tea.study.report import comparison_report
from fg_tea.study.sweep import plan_sweep, run_sweep
from fg_tea.study.yardstick import start_problem


def _rows(tmp_path, models, task, world="independent", worlds=2):
    jobs = plan_sweep([world], worlds, models, ["efe", "lookahead"], env="fake", task=task)
    return run_sweep(jobs, tmp_path / "episodes.csv", "serial", progress=False)


def test_search_only_comparison_reports_the_bound_beside_each_planner(tmp_path):
    rows = _rows(tmp_path, ["factorised_close"], "find_mug")
    files = comparison_report(rows, tmp_path, title="bounds")
    text = files["summary.md"].read_text()
    assert "## Search travel beside a lower bound on the optimum" in text
    with open(files["summary.csv"], newline="") as f:
        summary = list(csv.DictReader(f))
    assert {s["planner"] for s in summary} == {"efe", "lookahead"}
    bounds = {float(s["search_bound"]) for s in summary}
    assert len(bounds) == 1  # the same worlds under the same model: the same bound
    bound = bounds.pop()
    assert f"| {bound:.3f} |" in text
    # it is the bound of the start problem with no look cost, and below that problem's exact limit
    problem, _ = start_problem("independent", "factorised_close", "find_mug")
    problem.look = problem.look * 0.0
    assert bound == pytest.approx(lower_bound(problem), rel=1e-9)
    assert 0.0 < bound <= search_limit(problem, tolerance=1e-3).lower
    for s in summary:
        travel = float(s["search_distance_mean"])
        assert float(s["search_travel_over_bound"]) == pytest.approx(travel / bound)


def test_bound_at_27_and_45_sites_is_computed():
    for world in ("generated_medium", "generated_large"):  # 27 and 44 viewpoints in world seed 0's house
        got = start_bound(world, 0, "factorised_close", "find_three")
        assert isinstance(got, float) and got > 0.0, (world, got)


def test_make_tea_and_joint_rows_say_why_there_is_no_bound():
    make_tea = {"key": "world=correlated|ws=000000|model=factorised|planner=efe|seed=000000"}
    assert "task make_tea" in str(row_bound(make_tea))
    joint = {"key": "world=independent|ws=000000|model=joint_close|planner=efe|seed=000000|env=fake"
                    "|task=find_mug"}
    assert "correlated" in str(row_bound(joint))
    assert "names no episode" in str(row_bound({"key": "nonsense"}))


def test_search_bound_script_writes_the_bound_beside_each_planner(tmp_path):
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "experiments" / "search_bound.py"
    spec = importlib.util.spec_from_file_location("_search_bound", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(["--worlds", "1", "--tasks", "find_mug", "--planners", "efe", "--out", str(tmp_path)]) == 0
    with open(tmp_path / "find_mug" / "summary.csv", newline="") as f:
        (row,) = list(csv.DictReader(f))
    assert float(row["search_bound"]) == pytest.approx(start_bound("independent_medium", 0, "factorised_close",
                                                                   "find_mug"))
    assert float(row["search_bound"]) > 0
