"""experiments/rerun_given_up.py: the committed rows the default give-up can change, run again
(docs/design.md §7.8)."""

from __future__ import annotations

import dataclasses
import importlib.util
from pathlib import Path

import pytest

from fg_tea.study.rows import read_rows, write_csv_atomic

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "experiments" / "results"


def _script():
    spec = importlib.util.spec_from_file_location("_rerun_given_up", ROOT / "experiments" / "rerun_given_up.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_the_committed_tables_hold_the_rows_the_rerun_put_there():
    """Every row the switch ran again is in its table with the reason it came out with, and no
    table still holds a row the probability rule gave up."""
    from fg_tea.study.analysis import given_up_by_probability

    replaced = read_rows(RESULTS / "give_up_default" / "replaced.csv")
    assert len(replaced) > 100
    tables: dict[str, dict] = {}
    for r in replaced:
        if r["table"] not in tables:
            tables[r["table"]] = {row["key"]: row for row in read_rows(RESULTS / r["table"])}
        assert tables[r["table"]][r["key"]]["reason"] == r["reason_after"], r["key"]
    script = _script()
    for path in script.sweep_tables(RESULTS):
        name = path.relative_to(RESULTS).as_posix()
        if name not in script.KEPT and "give_up_default" not in name:
            # a probability give-up left is the default's safety net (R_o below about 1e-6)
            assert not [row["key"] for row in read_rows(path)
                        if given_up_by_probability(row) and row["reason"].endswith("< 0.001)")], name


def test_a_given_up_row_is_run_again_in_place_and_the_rest_left_alone(tmp_path, monkeypatch):
    """A table with a row the probability rule gave up (the mug the camera never reports) and
    one it finished: --write replaces the first in place, keeps the second byte for byte and
    records the change; a second run has nothing left to do."""
    import fg_tea.study.sweep as sweep

    made = sweep.job_model

    def probability_rule(ref, overrides):
        m = made(ref, overrides)
        return dataclasses.replace(m, planning=dataclasses.replace(m.planning, give_up="probability"))

    jobs = [sweep.Job("correlated", 0, "factorised_close", "efe", env="fake", env_overrides={"unfindable": "mug"},
                      gtsam_check=False),
            sweep.Job("correlated", 1, "factorised_close", "efe", env="fake", gtsam_check=False)]
    with monkeypatch.context() as m:
        m.setattr(sweep, "job_model", probability_rule)
        rows = [sweep.run_job(j) for j in jobs]
    assert rows[0]["reason"].endswith("< 0.001)") and rows[1]["reason"] == "complete"
    table = tmp_path / "results" / "t" / "episodes.csv"
    table.parent.mkdir(parents=True)
    write_csv_atomic(table, rows)
    before = table.read_text().splitlines()
    script = _script()
    out = tmp_path / "out"
    args = ["--results", str(tmp_path / "results"), "--write", "--workers", "1", "--out", str(out)]
    assert script.main(args) == 0
    after = table.read_text().splitlines()
    assert after[0] == before[0] and after[2] == before[2] and after[1] != before[1]
    fresh = read_rows(table)[0]
    assert fresh["reason"].startswith("not_found: mug") and "per chance of finding it" in fresh["reason"]
    assert fresh["search_distance"] > rows[0]["search_distance"]  # the cost rule looked on
    replaced = read_rows(out / "replaced.csv")
    assert [(r["table"], r["key"]) for r in replaced] == [("t/episodes.csv", jobs[0].key)]
    assert "| t/episodes.csv | 2 | 1 | 0 | 1 | 0 |" in (out / "summary.md").read_text()
    assert script.main(args) == 0  # nothing left to run: the same table and record
    assert table.read_text().splitlines() == after
    assert read_rows(out / "replaced.csv") == replaced


def test_a_table_that_would_lose_a_line_is_refused(tmp_path):
    """A line that does not parse as a row of the header, or a column the fresh rows lack, is one
    line naming the table, and the table is left as it was."""
    from fg_tea.common.errors import InputError

    splice = _script().splice
    table = tmp_path / "episodes.csv"
    for text, field in (("key,reason\nk1,complete\nk2,complete,extra\n", "rows"),
                        ("key,reason,other\nk1,complete,1\n", "header")):
        table.write_text(text)
        with pytest.raises(InputError, match=field):
            splice(table, {"k1": {"key": "k1", "reason": "complete"}})
        assert table.read_text() == text
