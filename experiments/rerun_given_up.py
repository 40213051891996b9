"""Run again the committed episodes that the default give-up rule can change (docs/design.md §7.8).

The default rule (``give_up = "cost"``) weighs the cost of one more look only once a search's
remaining probability R_o is below ``give_up_probability``, where the probability rule (the earlier
default) gave the search up at once. So an episode the probability rule never gave up is the same
episode under the default, row for row (``tests/test_give_up.py`` checks this); only rows whose
search the probability rule gave up (reason ``not_found: o (...; remaining probability x < p)``)
can change. This script finds those rows in every committed sweep CSV under ``--results``, runs
their jobs again with the current code (each job once, however many tables share it) and, with
``--write``, puts the fresh rows in place of the old ones, row order kept. Without ``--write`` it
only lists what it would run. ``--check N`` also runs N of the other rows again, to show they come
out the same.

Two tables are left alone: ``lookahead_scale/before_grouping.csv`` holds rows of an earlier
planner kept as they ran, and ``give_up/`` compares the rules themselves (run it again with
``experiments/give_up.py``). Writes ``summary.md`` and ``summary.csv`` (per table: rows, rows run
again, now complete, given up later, given up the same) and ``fresh.csv`` (the fresh rows; a
re-run resumes from it) and ``replaced.csv`` (every row put in place: its table, key and reason
before and after; a re-run leaves these rows alone) to ``--out``.

    python experiments/rerun_given_up.py                      # what would be run again
    python experiments/rerun_given_up.py --write --workers 2 --out experiments/results/give_up_default
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

from fg_tea.common.errors import InputError, run_script
from fg_tea.common.files import atomic_write_text, out_folder
from fg_tea.common.tables import table_lines

#: Tables this script leaves as they are, and why.
KEPT = {"lookahead_scale/before_grouping.csv": "rows of an earlier planner, kept as they ran",
        "give_up/episodes.csv": "compares the rules themselves; run experiments/give_up.py"}


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.options import WORKERS_HELP, experiment_parser

    p = experiment_parser(__doc__, __file__, "§7.8")
    p.add_argument("--results", type=Path, default=ROOT / "experiments" / "results",
                   help="the folder of committed results to search for sweep CSVs")
    p.add_argument("--write", action="store_true", help="put the fresh rows in place of the old ones")
    p.add_argument("--check", type=int, default=0, metavar="N",
                   help="also run N rows not given up again (drawn with a fixed seed) and count "
                        "those that come out the same")
    p.add_argument("--workers", type=int, default=2, help=WORKERS_HELP)
    p.add_argument("--out", type=out_folder, default="runs/experiments/rerun_given_up", help="output folder")
    return p


def sweep_tables(results: Path) -> list[Path]:
    """Every sweep CSV (header starting with ``key,``) under `results`, sorted."""
    found = []
    for path in sorted(results.rglob("*.csv")):
        with path.open(encoding="utf-8") as fh:
            if fh.readline().startswith("key,"):
                found.append(path)
    return found


def given_up(rows: list[dict]) -> list[dict]:
    """The rows whose search the probability rule gave up."""
    from fg_tea.study.analysis import given_up_by_probability

    return [r for r in rows if given_up_by_probability(r)]


def splice(path: Path, fresh: dict[str, dict[str, str]]) -> int:
    """Put `fresh` rows (cells as strings, by key) in place of the rows of `path` with their keys,
    order and columns kept (a column added to sweep rows since the table was made is left out,
    as it is for every other row of the table), atomically. Returns rows replaced."""
    import csv

    from fg_tea.study.rows import write_csv_atomic

    with path.open(newline="", encoding="utf-8") as fh:
        header, *lines = list(csv.reader(fh))
    if not path.read_bytes().endswith(b"\n") or any(len(line) != len(header) for line in lines):
        raise InputError(path, "rows", "a line does not parse as a row of the header; the table "
                         "would lose it: mend it first")
    missing = {c for row in fresh.values() for c in header if c not in row}
    if missing:
        raise InputError(path, "header", f"the fresh rows lack {', '.join(sorted(missing))}; "
                         "putting them in would blank those cells")
    rows = [dict(zip(header, line)) for line in lines]
    replaced = 0
    for i, row in enumerate(rows):
        if row["key"] in fresh:
            rows[i], replaced = fresh[row["key"]], replaced + 1
    write_csv_atomic(path, rows, header)
    return replaced


def main(argv: list[str] | None = None) -> int:
    from fg_tea.study.rows import read_good_lines, read_rows, write_csv_atomic
    from fg_tea.study.keys import job_from_key
    from fg_tea.study.sweep import run_sweep

    args = build_parser().parse_args(argv)
    results, out = args.results.resolve(), Path(args.out)
    record = {(r["table"], r["key"]): r for r in (read_rows(out / "replaced.csv")
                                                  if (out / "replaced.csv").is_file() else [])}
    tables = []
    for path in sweep_tables(results):
        name = path.relative_to(results).as_posix()
        if name not in KEPT and out.resolve() not in path.parents:  # not this script's own rows
            rows = read_rows(path)
            pending = [r for r in given_up(rows) if (name, r["key"]) not in record]
            tables.append((name, path, len(rows), pending))
            done = sum(t == name for t, _ in record)
            print(f"{name}: {len(pending)} of {len(rows)} rows gave a search up under the probability rule"
                  + (f" ({done} run again before)" if done else ""), flush=True)
    jobs = {r["key"]: job_from_key(r["key"], gtsam_check=False) for _, _, _, rows in tables for r in rows}
    print(f"{len(jobs)} distinct jobs to run again", flush=True)
    if not args.write:
        return 0
    fresh_csv = out / "fresh.csv"
    run_sweep(list(jobs.values()), fresh_csv, "process", workers=args.workers, label="rerun_given_up")
    header, lines, _ = read_good_lines(fresh_csv)
    fresh = {row["key"]: row for row in (dict(zip(header, line)) for line in lines)}
    for name, path, _, pending in tables:
        if pending:
            splice(path, {r["key"]: fresh[r["key"]] for r in pending})
        for r in pending:
            record[(name, r["key"])] = {"table": name, "key": r["key"], "reason_before": str(r["reason"]),
                                        "reason_after": fresh[r["key"]]["reason"]}
    write_csv_atomic(out / "replaced.csv", [record[k] for k in sorted(record)],
                     ["table", "key", "reason_before", "reason_after"])
    summary = []
    for name, _, n, _ in tables:
        mine = [r for (t, _), r in sorted(record.items()) if t == name]
        complete = sum(r["reason_after"] == "complete" for r in mine)
        same = sum(r["reason_after"] == r["reason_before"] for r in mine)
        summary.append({"table": name, "rows": n, "rerun": len(mine), "complete_now": complete,
                        "given_up_the_same": same, "given_up_later": len(mine) - complete - same})
    replaced = {name: {k for t, k in record if t == name} for name, *_ in tables}
    checked = check_others(tables, replaced, args.check, out, args.workers) if args.check > 0 else None
    command = "python experiments/rerun_given_up.py " + shlex.join(argv if argv is not None else sys.argv[1:])
    write_summary(summary, out, command, checked)
    return 0


def check_others(tables: list, replaced: dict[str, set[str]], n: int, out: Path,
                 workers: int) -> tuple[int, int, list[str]]:
    """Run `n` rows that were not given up again (drawn with seed 0 across every table): (rows
    run, rows the same in every column the table has, keys of those that differ)."""
    import math
    import random

    from fg_tea.study.keys import job_from_key
    from fg_tea.study.rows import read_rows
    from fg_tea.study.sweep import run_sweep

    others = []
    for name, path, _, _ in tables:
        others += [(name, r) for r in read_rows(path) if r["key"] not in replaced[name]]
    drawn = random.Random(0).sample(others, min(n, len(others)))
    fresh = {r["key"]: r for r in run_sweep([job_from_key(r["key"], gtsam_check=False) for _, r in drawn],
                                              out / "check.csv", "process", workers=workers,
                                              label="check")}

    def same(a, b) -> bool:
        if isinstance(a, float) and isinstance(b, (int, float)) and not isinstance(b, bool):
            return (math.isnan(a) and math.isnan(b)) or math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12)
        return a == b or (a in (None, "") and b in (None, ""))

    differ = [r["key"] for _, r in drawn if not all(same(v, fresh[r["key"]].get(c)) for c, v in r.items())]
    return len(drawn), len(drawn) - len(differ), differ


def write_summary(summary: list[dict], out: Path, command: str,
                  checked: tuple[int, int, list[str]] | None = None) -> None:
    """``summary.csv`` and ``summary.md``: what switching the default did to each table."""
    from fg_tea.study.rows import write_csv_atomic

    write_csv_atomic(out / "summary.csv", [{k: str(v) for k, v in r.items()} for r in summary],
                     ["table", "rows", "rerun", "complete_now", "given_up_later", "given_up_the_same"])
    total = {k: sum(r[k] for r in summary) for k in ("rows", "rerun", "complete_now", "given_up_later",
                                                      "given_up_the_same")}
    lines = ["# The committed episodes the default give-up changed", "",
             f"Regenerate: `{command}`", "",
             "The default rule weighs the cost of one more look once a search's remaining probability "
             "is below the give-up probability (docs/design.md §7.8); the probability rule gave the "
             "search up there. Every other episode is the same under both rules, so only the rows "
             "below were run again. *Given up later*: the search went on and was given up further "
             "into the episode; *the same*: given up with the same reason.", ""]
    columns = ("table", "rows", "rerun", "complete_now", "given_up_later", "given_up_the_same")
    lines += table_lines(["table", "rows", "run again", "complete now", "given up later", "given up the same"],
                         [[r[c] for c in columns] for r in summary + [{"table": "all", **total}]], align="lrrrrr")
    if checked is not None:
        ran, kept, differ = checked
        lines += ["", f"As a check, {ran} rows that were not given up (drawn with seed 0 across the tables) "
                  f"were run again under the default: {kept} came out the same in every column"
                  + (f"; these did not: {', '.join(differ)}." if differ else ".")]
    atomic_write_text(out / "summary.md", "\n".join(lines) + "\n")


if __name__ == "__main__":
    run_script(main, "rerun_given_up.py")
