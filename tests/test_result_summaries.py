"""Committed summaries that are computed from committed episode tables are what their scripts make
of those tables now (numbers are generated, not typed). The CSVs' floats are compared to 9
significant digits (tests/golden_match.py), as a scipy release may move their last bits; the
Markdown, which rounds them, exactly."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest
from golden_match import report, table_differences

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "experiments" / "results"


def _script(name: str):
    spec = importlib.util.spec_from_file_location(f"_summary_{name}", ROOT / "experiments" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name,folder,table,extra", [
    ("false_give_ups", "false_give_ups", "summary.csv", []),
    ("lookahead_scale", "lookahead_scale", "paired.csv",
     ["--bench-before", str(RESULTS / "lookahead_scale" / "bench_before.json"),
      "--bench-previous", str(RESULTS / "lookahead_scale" / "bench_previous.json"),
      "--bench-now", str(RESULTS / "lookahead_scale" / "bench_now.json")]),
])
@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_committed_summary_is_regenerated_from_the_committed_tables(tmp_path, name, folder, table, extra):
    committed = RESULTS / folder / table
    assert _script(name).main(["--out", str(tmp_path), *extra]) == 0
    found = table_differences(committed.read_text(), (tmp_path / table).read_text())
    assert not found, report(committed, found)  # 9 significant digits: last bits vary by library
    fresh = (tmp_path / ("summary.md")).read_text().split("\n", 3)[3]   # past the command line
    assert fresh == (RESULTS / folder / "summary.md").read_text().split("\n", 3)[3]


def test_false_give_ups_counts_every_not_found_as_false_in_findable_worlds():
    module = _script("false_give_ups")
    rows = [{"key": str(i), "planner": "efe", "task": "make_tea_milk_sugar", "world": "w", "model": "m",
             "reason": "not_found: mug" if i < 2 else "complete", "success": i >= 2} for i in range(10)]
    counts = module.count(rows, ["efe"])
    assert counts == {("w", "make_tea_milk_sugar", "m", "efe"): [10, 50, 2]}
    row = module.rows_of("s", counts)[0]
    assert row["rate"] == pytest.approx(0.04) and row["low"] > 0.001 and row["above_declared"]


def test_trace_rebuilds_the_job_of_a_row_or_says_it_cannot():
    """fg_tea.study.keys.job_from_key, through the trace's job_of: a key names its job back."""
    from fg_tea.common.errors import InputError
    from fg_tea.study.sweep import Job

    module = _script("trace_give_ups")
    job = Job("generated_small_milk_sugar", 63, model="joint", planner="factorised_efe",
              task="make_tea_milk_sugar")
    row = {"key": job.key, "world": job.world, "world_seed": 63, "model": "joint",
           "planner": "factorised_efe", "seed": 63, "env": "pybullet", "task": "make_tea_milk_sugar"}
    assert module.job_of(row) == job
    knobbed = Job("generated_small", 3, model="factorised", planner="efe", env="fake",
                  knobs={"same_site": 1.0}, model_overrides={"miss_likelihood": 0.2})
    assert module.job_of({"key": knobbed.key}) == knobbed
    with pytest.raises(InputError, match="not itself"):  # parts out of the order keys are written in
        module.job_of({**row, "key": job.key + "|knobs=same_site=1.0"})
    with pytest.raises(InputError, match="does not name a job"):
        module.job_of({"key": "world=x|ws=zero"})
    # integers stay integers; a value may hold commas
    odd = Job("correlated", 0, model="factorised", planner="efe", env="fake",
              model_overrides={"miss_likelihood": 0.2}, env_overrides={"unfindable": "mug,teabag", "look_frames": 12})
    assert module.job_of({"key": odd.key}) == odd
