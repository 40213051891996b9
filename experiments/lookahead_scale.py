"""Did the faster lookahead give up quality? Its episodes beside the lookahead's before, world by world.

Two changes made the lookahead (docs/design.md §6.6) fast enough for 27- and 45-site houses and
let it plan on joint beliefs of any size: a room glance's outcomes are grouped by who is seen
rather than where, and a correlated belief beyond the dense table is held as the engine's
subset program. Grouping changes no value for a factorised belief, but it changes which nodes
the 20-node budget reaches, so the choices differ; for a joint belief the tree plans as if a
glance told only who it showed. This script pairs the episodes of the lookahead now with those
of the lookahead before the change on the same worlds and seeds (equal sweep keys), and reports
per house size, task and belief the paired difference now − before of search travel, SPL,
inspections and success, with 95 % Student-t intervals and the share of worlds whose searches
differ. With ``--bench`` it adds the decision times of ``experiments/bench_planning.py --houses
... --json`` runs (one before, one now) side by side.

    python experiments/lookahead_scale.py --out experiments/results/lookahead_scale \\
        --bench-before experiments/results/lookahead_scale/bench_before.json \\
        --bench-now experiments/results/lookahead_scale/bench_now.json

Writes ``summary.md`` and ``paired.csv`` to ``--out``. The "before" rows are the lookahead rows
of the houses table at commit 982341a (``before_grouping.csv``); "now" is the houses table.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

from fg_tea.common.errors import InputError, run_script
from fg_tea.common.files import atomic_write_text, out_folder
from fg_tea.common.options import experiment_parser
from fg_tea.study.analysis import excluded, given_up_by_probability, markdown_table
from fg_tea.study.rows import read_rows, write_csv_atomic
from fg_tea.common.stats import t_interval

RESULTS = ROOT / "experiments" / "results"
DEFAULT_BEFORE = RESULTS / "lookahead_scale" / "before_grouping.csv"
DEFAULT_NOW = RESULTS / "joint_vs_factorised" / "houses" / "episodes.csv"
#: Rows the switch of the default give-up rule ran again (experiments/rerun_given_up.py).
DEFAULT_REPLACED = RESULTS / "give_up_default" / "replaced.csv"
DEFAULT_OUT = "runs/experiments/lookahead_scale"
METRICS = ("search_distance", "spl", "inspections", "success")
LABEL = {"search_distance": "search travel (m)", "spl": "SPL", "inspections": "inspections",
         "success": "success"}
SIZES = {"generated_small": 0, "generated_medium": 1, "generated_large": 2}


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§6.6")
    p.add_argument("--before", type=Path, default=DEFAULT_BEFORE,
                   help="episodes CSV of the lookahead before the change")
    p.add_argument("--now", type=Path, default=DEFAULT_NOW, help="episodes CSV of the lookahead now")
    p.add_argument("--planner", default="lookahead", help="the planner compared")
    p.add_argument("--replaced", type=Path, default=DEFAULT_REPLACED,
                   help="rows run again when the default give-up became the cost rule: pairs whose "
                        "search the probability rule gave up, before or now, are left out")
    p.add_argument("--bench-before", type=Path, default=None,
                   help="bench_planning.py --houses --json output of the code before")
    p.add_argument("--bench-previous", type=Path, default=None,
                   help="bench_planning.py --houses --json output of the commit before the last "
                        "speed change, measured in the same run as --bench-now")
    p.add_argument("--bench-now", type=Path, default=None,
                   help="bench_planning.py --houses --json output of the code now")
    p.add_argument("--out", type=out_folder, default=DEFAULT_OUT, help="output folder")
    return p


def _value(row, metric: str) -> float:
    v = row.get(metric)
    if metric == "success":
        return 1.0 if v in (True, "True", 1) else 0.0
    return float(v)


def pairs(before: list[dict], now: list[dict], planner: str, rule_changed: frozenset[str] = frozenset()
          ) -> list[dict]:
    """Per (world, task, model): the paired now − before differences of every metric. Keys in
    `rule_changed` (and before rows the probability rule gave up) are left out: the rows before
    ran under the probability give-up, the rows now under the cost rule, and only in those
    episodes do the rules differ (docs/design.md §7.8), so the rest compare the planners alone."""
    old = {r["key"]: r for r in before if r["planner"] == planner and not excluded(r)
           and not given_up_by_probability(r)}
    cells: dict[tuple, list[tuple[dict, dict]]] = {}
    for r in now:
        if r["planner"] != planner or excluded(r) or r["key"] not in old or r["key"] in rule_changed:
            continue
        cells.setdefault((r["world"], r["task"], r["model"]), []).append((old[r["key"]], r))
    out = []
    for (world, task, model), matched in sorted(cells.items(), key=lambda kv: (
            SIZES.get(kv[0][0].replace("_milk_sugar", ""), 9), kv[0][1], kv[0][2])):
        row: dict = {"world": world, "task": task, "model": model, "pairs": len(matched),
                     "share_differ": sum(_value(a, "search_distance") != _value(b, "search_distance")
                                         or a.get("inspections") != b.get("inspections")
                                         for a, b in matched) / len(matched)}
        for m in METRICS:
            diffs = [_value(b, m) - _value(a, m) for a, b in matched]
            iv = t_interval(diffs)
            row.update({f"{m}_before": sum(_value(a, m) for a, _ in matched) / len(matched),
                        f"{m}_now": sum(_value(b, m) for _, b in matched) / len(matched),
                        f"{m}_diff": iv.mean, f"{m}_low": iv.low, f"{m}_high": iv.high})
        out.append(row)
    return out


def _bench(path: Path | None) -> dict[tuple, dict]:
    if path is None:
        return {}
    try:
        records = json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        raise InputError(path, "json", f"not a bench_planning.py --json file ({exc})") from None
    return {(r["house"], r["model"], r["planner"]): r for r in records if "house" in r}


def report(args, rows: list[dict], command: str) -> str:
    lines = ["# The lookahead before and after grouping glance outcomes (and the subset-program form)",
             "", f"Regenerate: `{command}`", "",
             "Each row pairs the lookahead's episodes now with the lookahead's before the change "
             "on the same worlds and seeds (equal sweep keys): now − before, mean over worlds with a "
             "95 % Student-t interval; positive SPL and negative travel favour now. \"Differ\": the "
             "share of worlds whose searches differ in travel or inspections. Joint beliefs beyond "
             "the dense table were refused before, so they have no pairs. "
             f"{args.left_out} pairs are left out: the probability rule gave a search up in the episode "
             "before, or in the episode now before the default became the cost rule "
             "(docs/design.md §7.8); the rules differ only there, so the pairs left compare the "
             "planners alone.", ""]
    header = ["house", "task", "belief", "pairs", "differ"]
    body = []
    for r in rows:
        cells = [r["world"], r["task"], r["model"], r["pairs"], f"{r['share_differ']:.2f}"]
        for m in METRICS:
            cells.append(f"{r[f'{m}_before']:.3f} → {r[f'{m}_now']:.3f}; "
                         f"{r[f'{m}_diff']:+.3f} [{r[f'{m}_low']:+.3f}, {r[f'{m}_high']:+.3f}]")
        body.append(cells)
    header += [f"{LABEL[m]}: before → now; now − before [95 %]" for m in METRICS]
    lines += [markdown_table(header, body), ""]
    before, now = _bench(args.bench_before), _bench(args.bench_now)
    previous = _bench(args.bench_previous)
    if now:
        lines += ["## Decision time in whole episodes (CPU ms per decision)", "",
                  "From `experiments/bench_planning.py --houses`: every decision of make-tea "
                  "episodes in the fake house, on the same machine (commands in `commands.txt`): "
                  "the code before grouping (the package at commit 982341a, measured when "
                  "grouping came in)"
                  + (", and the commit before the last speed change and now, one after the "
                     "other in one run" if previous else " and now")
                  + ". Targets: median ≤ 5 ms, 95th percentile ≤ 50 ms.", ""]
        body = []
        for key in sorted(now, key=lambda k: (SIZES.get(k[0], 9), k[1], k[2])):
            r, b = now[key], before.get(key)

            def show(rec):
                if rec is None:
                    return "–"
                if rec["status"] != "ok":
                    return rec["status"]
                return f"{rec['cpu_median_ms']:.2f} / {rec['cpu_p95_ms']:.2f}"

            met = (r["status"] == "ok" and r["cpu_median_ms"] <= 5.0 and r["cpu_p95_ms"] <= 50.0)
            body.append([key[0], f"{r['sites']:.1f}", key[1], key[2], r["worlds"], show(b)]
                        + ([show(previous.get(key))] if previous else [])
                        + [show(r), "met" if met else "not met"])
        lines += [markdown_table(["house", "sites (mean)", "belief", "planner", "worlds",
                                  "before grouping: median / p95"]
                                 + (["previous: median / p95"] if previous else [])
                                 + ["now: median / p95", "targets"], body), ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    now_table = Path(args.now).resolve().relative_to(RESULTS).as_posix() if RESULTS in Path(args.now).resolve().parents else ""
    changed = frozenset(r["key"] for r in (read_rows(args.replaced) if args.replaced.is_file() else [])
                        if r["table"] == now_table)
    before = read_rows(args.before)
    rows = pairs(before, read_rows(args.now), args.planner, changed)
    paired = {r["key"]: r for r in before if r["planner"] == args.planner and not excluded(r)}
    args.left_out = sum(1 for r in read_rows(args.now) if r["planner"] == args.planner and not excluded(r)
                        and r["key"] in paired and (r["key"] in changed or given_up_by_probability(paired[r["key"]])))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    command = shlex.join(["python", "experiments/lookahead_scale.py",
                          *(sys.argv[1:] if argv is None else argv)])
    write_csv_atomic(out / "paired.csv", rows)
    path = atomic_write_text(out / "summary.md", report(args, rows, command) + "\n")
    print(f"report: {path}")
    return 0


if __name__ == "__main__":
    run_script(main, "lookahead_scale.py")
