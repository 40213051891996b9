"""Each committed sweep result still reproduces from its command (slow).

A committed ``episodes.csv`` row names its job completely in its ``key`` (world, world seed,
knobs, model, overrides, planner, seed, environment, camera, task): the first row of each file is
run again here through ``fg_tea.study.sweep.run_job`` and must give the same row, every column
(numbers to 1e-9 relative: KL values can move in the last bit between machines). Stale results
were found this way and regenerated from their commands (CHANGELOG.md).

The lifelong curves are rebuilt from their own episodes by ``experiments/lifelong.py`` (checked in
``tests/test_learning.py``); the planner frontier, the lookahead budget, the benchmarks and the
test times hold CPU times, which no rerun repeats.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from fg_tea.study.rows import read_rows
from fg_tea.study.keys import job_from_key
from fg_tea.study.sweep import Job, run_job

ROOT = Path(__file__).resolve().parent.parent
#: Rows of an earlier planner kept to compare against (they reproduce at the commit they name).
HISTORICAL = {"experiments/results/lookahead_scale/before_grouping.csv"}
SWEEPS = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "experiments" / "results").rglob("*.csv")
                if p.read_text(encoding="utf-8").startswith("key,")
                and str(p.relative_to(ROOT)) not in HISTORICAL)
#: Columns that spell the job (checked through the key) rather than measure the episode.
SPELLING = {"key", "knobs", "model_overrides", "env_overrides", "model_ref"}


def job_of(row: dict) -> Job:
    """The job a committed row names (its key must come out the same)."""
    return job_from_key(row["key"], gtsam_check=False)


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, (int, float)) and not isinstance(b, bool):
        return (math.isnan(a) and math.isnan(b)) or math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12)
    return a == b or (a in (None, "") and b in (None, "", ()))


def test_every_committed_sweep_is_covered():
    assert len(SWEEPS) >= 5, SWEEPS


@pytest.mark.slow
@pytest.mark.parametrize("path", SWEEPS)
def test_the_first_row_of_a_committed_sweep_reproduces(path, monkeypatch):
    monkeypatch.chdir(ROOT)  # model and camera files written beside a result are named from here
    committed = read_rows(ROOT / path)[0]
    fresh = read_rows_like(run_job(job_of(committed)))
    differ = {c: (committed[c], fresh.get(c)) for c in committed
              if c not in SPELLING and not _same(committed[c], fresh.get(c))}
    assert not differ, f"{path} no longer reproduces from its command: {differ}"


def read_rows_like(row: dict) -> dict:
    """A fresh row as the CSV reader would give it back (the same cell parsing)."""
    import csv
    import io

    from fg_tea.study.rows import _cell, parse_cell  # the sweep CSV's own cell format

    buffer = io.StringIO()
    writer = csv.writer(buffer)
    writer.writerow([_cell(v) for v in row.values()])
    values = next(csv.reader(io.StringIO(buffer.getvalue())))
    return {k: parse_cell(v) for k, v in zip(row, values)}


def test_every_historical_table_is_committed():
    """The exclusion list names files that exist (it does not outlive them)."""
    assert all((ROOT / path).is_file() for path in HISTORICAL)
