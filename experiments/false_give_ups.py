"""How often does the search give up an object that was there, against the rate the rule declares?

The probability rule (docs/design.md §7.8) ends the search for an object once R_o, the chance
that the object would have given every miss so far if it were on a reachable site, falls below
``give_up_probability`` (1e-3). R_o is the likelihood of the misses under "present", so under the
agent's own prior and detection model the chance that it ever falls below 1e-3 while the object
is there is at most 1e-3 (the likelihood ratio "absent : present" is a martingale under
"present"; Ville's inequality). Every object of the generated worlds is there, so every give-up
in them is a false one. This script counts them per configuration in episode CSVs of sweeps and
reports the rate per object search (episodes x objects the task searches for) with a Wilson 95 %
interval, per house and task and pooled, beside the declared 1e-3:

- the houses table (PyBullet house, camera drawn from its visibility curve at the rendered pixel
  count of each look: the world the results are about);
- the houses table's 13-site five-object worlds again in the PyBullet house with
  ``--episode-seeds independent``: the same worlds and camera, other detector draws (is a cell's
  excess its worlds, or its draws?);
- five-object worlds in the fake house, whose camera is the agent's detection model exactly (one
  pixel count per site, every look an independent draw): what the rule gives when its
  assumptions hold.

    python experiments/false_give_ups.py --out experiments/results/false_give_ups

Writes ``summary.md`` and ``summary.csv`` to ``--out``.
"""

from __future__ import annotations

import argparse
import math
import shlex
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

from fg_tea.common.errors import run_script
from fg_tea.common.files import atomic_write_text, out_folder
from fg_tea.common.options import experiment_parser
from fg_tea.common.stats import wilson_interval
from fg_tea.study.analysis import excluded, markdown_table
from fg_tea.study.rows import read_rows, write_csv_atomic

RESULTS = ROOT / "experiments" / "results"
SOURCES = {"PyBullet house (houses table)": RESULTS / "joint_vs_factorised" / "houses" / "episodes.csv",
           "PyBullet house, other detector draws (--episode-seeds independent)":
               RESULTS / "false_give_ups" / "independent_seeds" / "houses" / "episodes.csv",
           "fake house (camera = model)": RESULTS / "false_give_ups" / "fake" / "houses" / "episodes.csv"}
OBJECTS = {"make_tea": 3, "make_tea_milk_sugar": 5}
DECLARED = 1e-3
DEFAULT_OUT = "runs/experiments/false_give_ups"


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§7.8")
    p.add_argument("--planners", nargs="+", default=["factorised_efe", "mi_efe"],
                   help="planners counted (the one-step planners of the houses table)")
    p.add_argument("--out", type=out_folder, default=DEFAULT_OUT, help="output folder")
    return p


def count(rows: list[dict], planners: list[str]) -> dict[tuple, list[int]]:
    """(world, task, model, planner) -> [episodes, object searches, false give-ups]."""
    out: dict[tuple, list[int]] = {}
    for r in rows:
        if r["planner"] not in planners or excluded(r) or r["task"] not in OBJECTS:
            continue
        cell = out.setdefault((r["world"], r["task"], r["model"], r["planner"]), [0, 0, 0])
        cell[0] += 1
        cell[1] += OBJECTS[r["task"]]
        cell[2] += str(r["reason"]).startswith("not_found")
    return out


def rows_of(source: str, counts: dict[tuple, list[int]]) -> list[dict]:
    out = []
    pooled: dict[tuple, list[int]] = {}
    for (world, task, model, planner), (episodes, searches, given) in sorted(counts.items()):
        out.append(_row(source, world, task, model, planner, episodes, searches, given))
        total = pooled.setdefault((model, planner), [0, 0, 0])
        for i, v in enumerate((episodes, searches, given)):
            total[i] += v
    for (model, planner), (episodes, searches, given) in sorted(pooled.items()):
        out.append(_row(source, "all", "all", model, planner, episodes, searches, given))
    return out


def _row(source, world, task, model, planner, episodes, searches, given) -> dict:
    iv = wilson_interval(given, searches)
    low = 0.0 if given == 0 else iv.low  # the interval's lower end is 0 exactly with no event
    return {"source": source, "world": world, "task": task, "model": model, "planner": planner,
            "episodes": episodes, "object_searches": searches, "false_give_ups": given,
            "rate": given / searches if searches else math.nan, "low": low, "high": iv.high,
            "expected_at_declared": searches * DECLARED,
            "above_declared": bool(low > DECLARED)}


def report(rows: list[dict], command: str) -> str:
    lines = ["# False give-ups against the declared rate", "", f"Regenerate: `{command}`", "",
             f"Every object of these worlds is there, so every give-up is false. Rate per object "
             f"search (episodes x objects the task searches for), Wilson 95 % interval; the rule "
             f"declares at most {DECLARED:g} when the worlds follow the agent's prior and the "
             "camera its detection model. \"Above\": the whole interval is above the declared rate.",
             ""]
    for source in dict.fromkeys(r["source"] for r in rows):
        lines += [f"## {source}", ""]
        body = [[r["world"], r["task"], r["model"], r["planner"], r["episodes"], r["object_searches"],
                 r["false_give_ups"], f"{r['expected_at_declared']:.1f}",
                 f"{r['rate']:.2e} [{r['low']:.2e}, {r['high']:.2e}]", "yes" if r["above_declared"] else "no"]
                for r in rows if r["source"] == source]
        lines += [markdown_table(["worlds", "task", "belief", "planner", "episodes", "object searches",
                                  "false give-ups", f"searches x {DECLARED:g}", "rate [95 %]", "above"],
                                 body), ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    rows: list[dict] = []
    for source, path in SOURCES.items():
        if path.exists():
            rows += rows_of(source, count(read_rows(path), list(args.planners)))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    command = shlex.join(["python", "experiments/false_give_ups.py", *(sys.argv[1:] if argv is None else argv)])
    write_csv_atomic(out / "summary.csv", rows)
    path = atomic_write_text(out / "summary.md", report(rows, command) + "\n")
    print(f"report: {path}")
    return 0


if __name__ == "__main__":
    run_script(main, "false_give_ups.py")
