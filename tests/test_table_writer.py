"""The one markdown table writer (fg_tea/common/tables.py) and the tables written through it.

The writer's own form (header, separator, rows, alignment, escaping, refusals), then the study
modules' tables regenerated from the committed result files and compared byte for byte with the
committed markdown (the docs read numbers out of those tables), and, where no committed file holds
a table's input (the search limit's CPU times and gap analyses), the tables of a small input
pinned to the bytes the hand-built code wrote before the writer replaced it.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

from fg_tea.common.tables import markdown_table, table_lines

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "experiments" / "results"


# ------------------------------------------------------------------------------ the writer
def test_header_separator_and_rows():
    assert table_lines(["a", "b"], [["x", "y"], ["1", "z"]], align="left") == [
        "| a | b |", "|---|---|", "| x | y |", "| 1 | z |"]
    assert markdown_table(["a", "b"], [["x", "y"]], align="left") == "| a | b |\n|---|---|\n| x | y |\n"


def test_auto_alignment_right_aligns_columns_of_numbers():
    text = markdown_table(["name", "n", "mean [95 %]"], [["a", 3, "1.50 [1.2, 1.8]"], ["b", 4.5, "2.00 [1.0, 3.0]"]])
    assert text.splitlines()[1] == "|---|---:|---:|"
    assert markdown_table(["name", "n"], [["a", 1], ["b", "–"]]).splitlines()[1] == "|---|---|"
    assert markdown_table(["name", "n"], []) == "| name | n |\n|---|---|\n"  # no rows: nothing to align


def test_alignment_letters_per_column():
    assert table_lines(["a", "b", "c"], [], align="lrr")[1] == "|---|---:|---:|"


def test_a_pipe_in_a_cell_stays_one_cell():
    lines = table_lines(["command", "n"], [["a | b", 1]], align="left")
    assert lines[2] == "| a \\| b | 1 |"


def test_per_column_formats_leave_string_cells_as_they_are():
    lines = table_lines(["name", "x", "n"], [["a", 1.23456, 12345], ["b", "–", 7]], align="left",
                        formats=["", ".2f", ","])
    assert lines[2:] == ["| a | 1.23 | 12,345 |", "| b | – | 7 |"]


def test_a_row_of_the_wrong_length_is_refused():
    with pytest.raises(ValueError, match=r"row 1 has 3 cells, the header 2"):
        table_lines(["a", "b"], [["x", "y"], ["x", "y", "z"]])


@pytest.mark.parametrize("kwargs, fault", [({"align": "lx"}, "align 'lx'"), ({"align": "lrr"}, "align 'lrr'"),
                                           ({"formats": [""]}, "1 formats for 2 columns")])
def test_bad_alignment_or_formats_are_refused(kwargs, fault):
    with pytest.raises(ValueError, match=re.escape(fault)):
        table_lines(["a", "b"], [["x", "y"]], **kwargs)


def test_the_study_analysis_name_is_the_same_writer():
    from fg_tea.study import analysis

    assert analysis.markdown_table is markdown_table


# --------------------------------------------------- study tables from committed result files
def _number(value: str):
    """A CSV cell as the int or float it spells, else as it is (text, or "" for none)."""
    for kind in (int, float):
        try:
            return kind(value)
        except ValueError:
            pass
    return value


def _read_csv(path: Path, text_columns: set[str]) -> list[dict]:
    with path.open(newline="") as fh:
        return [{k: v if k in text_columns else _number(v) for k, v in row.items()} for row in csv.DictReader(fh)]


def _table_after(text: str, header_start: str) -> str:
    """The table whose header line starts with `header_start`, lines joined without a final newline."""
    lines = text.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith(header_start))
    last = next((i for i in range(first, len(lines)) if not lines[i].startswith("|")), len(lines))
    return "\n".join(lines[first:last])


@pytest.mark.parametrize("folder", sorted(p.relative_to(RESULTS).as_posix()
                                          for p in (RESULTS / "search_bound").glob("*/*")))
def test_bound_table_regenerated_from_the_committed_csv(folder):
    from fg_tea.study.analysis import refused, step_limited
    from fg_tea.study.bounds import bound_markdown

    here = RESULTS / folder
    summary = _read_csv(here / "summary.csv", {"model", "planner", "search_bound_fault"})
    episodes = _read_csv(here / "episodes.csv", {"model", "planner", "reason", "key"})
    table = []
    for s in summary:
        mine = [r for r in episodes if r["model"] == s["model"] and r["planner"] == s["planner"]
                and r["search_distance"] != "" and not refused(r) and not step_limited(r)]
        travel = sum(float(r["search_distance"]) for r in mine) / len(mine)
        table.append({"model": s["model"], "planner": s["planner"], "episodes": len(mine), "search_travel": travel,
                      "bound": s["search_bound"] if s["search_bound"] != "" else None,
                      "travel_over_bound": s["search_travel_over_bound"] or None,
                      "bound_fault": s["search_bound_fault"]})
    committed = (here / "summary.md").read_text(encoding="utf-8")
    assert bound_markdown(table) == _table_after(committed, "| model | planner | episodes | search travel (m) |")


def _frontier_rows() -> list[dict]:
    rows = []
    for planner in ("optimal", "efe", "pouct:100"):
        for seed in range(3):
            row = {"model": "factorised", "world": "w", "env": "fake", "miss_rate": 0.05, "planner": planner,
                   "seed": seed, "search_distance": 5.0 + seed + (planner == "efe") * 1.5,
                   "decision_seconds": [0.001 * (seed + 1), 0.003], "inspections": 2 + seed, "success": seed != 1}
            if planner != "pouct:100":
                row["decision_cpu_seconds"] = [0.0005 * (seed + 1), 0.002]
            if planner != "efe" or seed:
                row["spl"] = 0.5 + 0.1 * seed
            rows.append(row)
    return rows


def test_frontier_table_is_the_hand_built_one(tmp_path):
    from fg_tea.study.frontier import summarise

    summarise(_frontier_rows(), tmp_path)
    assert (tmp_path / "frontier.md").read_text().split("\n\n## ")[1] == (
        "model `factorised`, world `w`, env `fake`, detector miss rate 0.05\n\n| planner | worlds | search travel "
        "(m) | ratio to optimal [95 %] | ms/decision mean | ms/decision median | p95 | CPU ms mean | CPU ms median | "
        "CPU ms per episode | inspections | success | SPL [95 %] |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
        "---|\n| optimal | 3 | 6.00 | 1.000 [1.000, 1.000] | 2.50 | 3.00 | 3.00 | 1.50 | 1.75 | 3.0 | 3.00 | 0.67 | "
        "0.600 [0.500, 0.700] |\n| efe | 3 | 7.50 | 1.250 [1.214, 1.300] | 2.50 | 3.00 | 3.00 | 1.50 | 1.75 | 3.0 | "
        "3.00 | 0.67 | 0.650 [0.600, 0.700] (of 2 worlds) |\n| pouct:100 | 3 | 6.00 | 1.000 [1.000, 1.000] | 2.50 | "
        "3.00 | 3.00 | n/a | n/a | n/a | 3.00 | 0.67 | 0.600 [0.500, 0.700] |\n\n")


def test_frontier_regenerated_from_the_kept_episodes(tmp_path):
    """frontier.md from the episode rows its run kept (gitignored: only where they were run)."""
    from fg_tea.study.episode_files import file_part
    from fg_tea.study.frontier import summarise

    here = RESULTS / "planner_frontier"
    if not (here / "episodes").is_dir():
        pytest.skip("experiments/results/planner_frontier/episodes is not kept in git; run the frontier to get it")
    committed = (here / "frontier.md").read_bytes()
    models = re.findall(r"^## model `([^`]+)`", committed.decode(), flags=re.M)
    section = committed.decode().split("## model")[1]
    planners = [line.split(" | ")[0][2:] for line in section.splitlines()
                if line.startswith("| ") and not line.startswith("| planner")]
    rows = [json.loads(path.read_text()) for model in models for planner in planners
            for path in sorted((here / "episodes").glob(f"correlated__{model}__{file_part(planner)}__*.json"))]
    assert len(rows) == 1000
    summarise(rows, tmp_path)
    assert (tmp_path / "frontier.md").read_bytes() == committed


#: Lifelong runs whose summary.md regenerates from their CSVs. Not ``lifelong/forgetting``: one of
#: its calibration cells (0.1625 in the run) rounds the other way from curves.csv's six decimals.
LIFELONG = ("lifelong", "lifelong/prior_violation", "lifelong/prior_violation_pybullet")


@pytest.mark.parametrize("folder", LIFELONG)
def test_lifelong_summary_regenerated_from_the_committed_csvs(folder):
    from fg_tea.study.households import summary_markdown

    here = RESULTS / folder
    rows = _read_csv(here / "episodes.csv", {"model", "arm", "focus_site"})
    table = _read_csv(here / "curves.csv", {"model", "arm"})
    committed = (here / "summary.md").read_text(encoding="utf-8")
    title = committed.splitlines()[0][2:]
    command = re.search(r"Regenerate: `(.*)`", committed).group(1)
    focus = re.search(r"inspections until the (\S+) is found", committed).group(1)
    assert summary_markdown(rows, table, title, command, focus) == committed


# ----------------------------------------- search-limit tables: pinned to the hand-built bytes
def _limit():
    return SimpleNamespace(lower=10.0, upper=10.5, cap=3, lower_cap=2, caps=(), viewpoints=7)


def test_search_limit_summary_table_is_the_hand_built_one():
    from fg_tea.study.yardstick import PolicyCost, summarise

    rows = [{"task": "find_mug", "planner": p, "seed": s, "cost": 10.0 + s + (p == "greedy"), "looks": 2 + s,
             "success": s != 2, "decision_cpu_seconds": [0.001 * (s + 1), 0.002]}
            for p in ("lookahead", "greedy") for s in range(3)]
    policies = {("find_mug", "lookahead"): PolicyCost(cost=10.8, unexpanded=1e-5, given_up=0.0125, states=4,
                                                      completion=0.25)}
    text = summarise(rows, {"find_mug": (_limit(), ["mug"])}, "w", "m", "cmd", policies)
    assert [line for line in text.splitlines() if line.startswith("|")] == [
        "| planner | policy cost (m) | policy / optimum | given up | unexpanded | sweep (m) | worlds | episodes: "
        "mean cost (m) [95 %] | episodes / optimum [95 %] | looks | success | CPU ms mean | CPU ms median | "
        "CPU ms p95 | CPU ms per episode |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
        "| lookahead | 10.8000 | [1.0286, 1.0800] | 0.013 | 1e-05 | 0.2500 | 3 | 11.000 [10.000, 12.000] | "
        "[1.000, 1.200] | 3.00 | 0.667 | 2.00 | 2.00 | 2.75 | 4.0 |",
        "| greedy | – | – | – | – | – | 3 | 12.000 [11.000, 13.000] | [1.048, 1.300] | 3.00 | 0.667 | 2.00 | "
        "2.00 | 2.75 | 4.0 |"]


def test_search_limit_gaps_page_is_the_hand_built_one():
    from fg_tea.study.yardstick import gaps_markdown

    g = {"policy": SimpleNamespace(cost=12.3456), "cut_policy": 11.1111, "excess": 1.2345, "beyond_cut": 1e-4,
         "rows": [{"weight": 0.5, "here": None, "looks": {}, "pending": ["mug", "tea"], "chosen": "a", "best": "b",
                   "regret": 2.0, "weighted": 1.0},
                  {"weight": 0.25, "here": "b", "looks": {"a": 1, "b": 2}, "pending": ["tea"], "chosen": "a",
                   "best": "b", "regret": 0.9382, "weighted": 0.2345}]}
    text = gaps_markdown([("lookahead", "find_mug", g)])
    assert text.split("## Summary\n\n")[1] == (
        "| planner | task | policy cost (m) | exact policy (m) | summed regret (m) | at re-looks (m) | "
        "at the first decision (m) |\n|---|---|---|---|---|---|---|\n"
        "| lookahead | find_mug | 12.3456 | 11.1111 | 1.2345 | 0.2345 | 1.0000 |\n\n"
        "## `lookahead`, task `find_mug`\n\nPolicy cost 12.3456 m; the exact (cut) policy's 11.1111 m; summed "
        "weighted regret 1.2345 m, of which 0.2345 m where the best look was a re-look from where the agent stood "
        "and 1.0000 m at the first decision. Decisions beyond the cut (not weighed): probability 0.0001.\n\n"
        "| weighted regret (m) | probability | stood at | looks so far | still searched | chose | best | "
        "regret (m) |\n|---|---|---|---|---|---|---|---|\n"
        "| 1.0000 | 0.500 | start | 0 | mug, tea | a | b | 2.000 |\n"
        "| 0.2345 | 0.250 | b | 3 | tea | a | b | 0.938 |\n")


def _tables(text: str) -> list[str]:
    """Every markdown table of `text`, each as its lines joined."""
    blocks, current = [], []
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            current.append(line)
        elif current:
            blocks.append("\n".join(current))
            current = []
    return blocks


def test_learned_transitions_tables_regenerated_from_the_committed_csv():
    import importlib.util
    import inspect

    spec = importlib.util.spec_from_file_location("learned_transitions_script",
                                                  ROOT / "experiments" / "learned_transitions.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    here = RESULTS / "learned_transitions"
    table = _read_csv(here / "episodes.csv", {"set", "model", "arm"})
    args = SimpleNamespace(boil=0.6, scenario="default_apartment", env="fake", episodes=20)
    declared = {m: 0.995 for m in {r["model"] for r in table}}
    extra = [declared] if "declared" in inspect.signature(script.report).parameters else []
    text = script.report(table, args, "cmd", *extra)
    committed = (here / "summary.md").read_text(encoding="utf-8")
    assert len(_tables(committed)) == 4
    assert _tables(text) == _tables(committed)
