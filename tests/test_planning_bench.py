"""Smoke test of experiments/bench_planning.py at tiny N (it must run and print its table)."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "experiments" / "bench_planning.py"


def test_bench_planning_smoke(capsys):
    spec = importlib.util.spec_from_file_location("bench_planning", SCRIPT)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    status = bench.main(["--repeats", "1", "--sites", "8", "12", "--sizes"])
    out = capsys.readouterr().out
    assert status in (0, 1)  # 1 = target missed (timing depends on the machine)
    n = len(bench.BENCH_PLANNERS) * 2 * 2  # planners x {factorised, joint} x {8, 12} sites
    assert f"[{n}/{n}]" in out and "ratio = planner / efe" in out
    assert "joint      3x12" in out and "refused" in out  # optimal declines 12 sites
    assert "target: EFE decision on the joint 3x8 model < 5 ms" in out


def test_bench_planning_glance_sizes_and_json(capsys, tmp_path):
    # The short form of the larger sizes: 5 objects x 10 sites with room glances (above the dense-gain switch, so the structured gain runs), with --json.
    spec = importlib.util.spec_from_file_location("bench_planning", SCRIPT)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    out_file = tmp_path / "bench.json"
    status = bench.main(["--repeats", "1", "--sites", "--sizes", "5x10", "--json", str(out_file)])
    out = capsys.readouterr().out
    assert status in (0, 1)
    assert "joint      5x10g" in out and "belief_update" in out
    records = json.loads(out_file.read_text())
    keys = {"model", "planner", "objects", "sites", "median_ms"}
    assert all(keys <= set(r) for r in records)
    cells = {(r["model"], r["planner"], r["objects"], r["sites"]) for r in records}
    assert ("joint", "efe", 5, 10) in cells and ("factorised", "factorised_efe", 5, 10) in cells
    assert ("joint", "belief_update", 5, 10) in cells
    efe = next(r for r in records if r["model"] == "joint" and r["planner"] == "efe")
    assert efe["median_ms"] > 0
    optimal = next(r for r in records if r["planner"] == "optimal" and r["model"] == "joint")
    assert optimal["status"] in ("ok", "refused")


def test_bench_planning_times_whole_episodes_in_generated_houses(capsys, tmp_path):
    """--houses times every decision of whole episodes, factorised and joint, and records the
    median and 95th percentile CPU per decision against the house-scale targets."""
    spec = importlib.util.spec_from_file_location("bench_planning", SCRIPT)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    out_file = tmp_path / "bench.json"
    status = bench.main(["--sites", "--sizes", "--planners", "efe", "--houses", "generated_small",
                         "--house-worlds", "1", "--json", str(out_file)])
    out = capsys.readouterr().out
    assert status in (0, 1)
    records = [r for r in json.loads(out_file.read_text()) if "house" in r]
    assert {(r["model"], r["planner"]) for r in records} == {("factorised", "lookahead"),
                                                            ("joint", "lookahead")}
    for r in records:
        assert r["status"] == "ok" and r["decisions"] > 0 and r["sites"] >= 12
        assert 0 < r["cpu_median_ms"] <= r["cpu_p95_ms"] and r["success"] == 1.0
    assert out.count("target: lookahead in generated_small") == 2
    with pytest.raises(SystemExit) as bad:
        bench.main(["--houses", "no_such_house"])
    assert bad.value.code == 2 and "--houses" in capsys.readouterr().err
