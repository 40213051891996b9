"""Does modelling what hides what change the answer? The company models beside the plain ones.

Reads the episodes of ``compare_at_scale.py --looks occlusion`` (models ``factorised_occlusion``
and ``joint_occlusion``, docs/design.md §3.4, "Facing and company") and the committed episodes of
the plain models (``factorised``, ``joint``) in the same cells (house size, task, planner) and
worlds, and reports, per cell and seed set (discovery below ``--confirmation-first-seed``,
confirmation from it):

- the joint − factorised difference in search travel under each detection model, paired by world,
  with its 95 % interval, as the comparison at scale reports it;
- each company model − its plain model, paired by world (same house, placement and episode seed);
- false give-ups: episodes that ended ``not_found`` although every object was there to be found
  (all objects are findable in these worlds), with Wilson 95 % intervals, and per object searched.

Writes ``summary.md`` and ``summary.csv`` to ``--out``:

    python experiments/occlusion_beside_plain.py \\
        --out experiments/results/joint_vs_factorised_occlusion/beside_plain
"""

from __future__ import annotations

import argparse
import csv
import io
import shlex
import sys
from pathlib import Path

from fg_tea.common.errors import InputError, run_script
from fg_tea.common.files import atomic_write_text, out_folder

PAIRS = (("factorised", "factorised_occlusion"), ("joint", "joint_occlusion"))
COLUMNS = ["world", "task", "planner", "seed_set", "worlds", "model", "plain_model",
           "jf_plain", "jf_company", "company_minus_plain", "given_up", "given_up_share",
           "searches", "plain_given_up", "plain_given_up_share"]


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.options import experiment_parser

    p = experiment_parser(__doc__, __file__, "§3.4")
    p.add_argument("--occlusion", nargs="+", default=[
        f"experiments/results/joint_vs_factorised_occlusion{tail}/houses/episodes.csv"
        for tail in ("", "_27", "_45")],
        help="episodes of the company models (compare_at_scale.py --looks occlusion), one CSV per "
             "folder of declared seed sets")
    p.add_argument("--plain", default="experiments/results/joint_vs_factorised/houses/episodes.csv",
                   help="episodes of the plain models in the same worlds")
    p.add_argument("--confirmation-first-seed", type=int, default=10000,
                   help="first world seed of the confirmation set")
    p.add_argument("--out", type=out_folder, default="runs/experiments/occlusion_beside_plain",
                   help="output folder")
    return p


def _rows(path: str) -> list[dict]:
    from fg_tea.study.rows import read_rows

    if not Path(path).is_file():
        raise InputError(path, "file", "no such episodes CSV")
    return read_rows(Path(path))


def _objects(task: str) -> int:
    return 5 if "milk_sugar" in task else 3


def main(argv: list[str] | None = None) -> int:
    from fg_tea.common.stats import t_interval, wilson_interval
    from fg_tea.study.analysis import markdown_table

    args = build_parser().parse_args(argv)
    occ, plain = [r for path in args.occlusion for r in _rows(path)], _rows(args.plain)
    by_key: dict[tuple, dict] = {}
    for r in occ + plain:
        key = (r["world"], r["task"], r["planner"], r["model"], int(r["world_seed"]), int(r["seed"]))
        by_key[key] = r
    cells = sorted({(r["world"], r["task"], r["planner"]) for r in occ})
    out_rows, body = [], []
    for world, task, planner in cells:
        for seed_set in ("discovery", "confirmation"):
            def in_set(seed: int) -> bool:
                return (seed >= args.confirmation_first_seed) == (seed_set == "confirmation")

            seeds = sorted({(int(r["world_seed"]), int(r["seed"])) for r in occ
                            if (r["world"], r["task"], r["planner"]) == (world, task, planner)
                            and in_set(int(r["world_seed"]))})
            if not seeds:
                continue

            def row(model: str, ws: int, s: int) -> dict | None:
                return by_key.get((world, task, planner, model, ws, s))

            jf = {}
            for label, (fact, joint) in (("plain", ("factorised", "joint")),
                                         ("company", ("factorised_occlusion", "joint_occlusion"))):
                diffs = [float(row(joint, *k)["search_distance"]) - float(row(fact, *k)["search_distance"])
                         for k in seeds if row(joint, *k) and row(fact, *k)]
                jf[label] = t_interval(diffs)
            for plain_m, occ_m in PAIRS:
                mine = [row(occ_m, *k) for k in seeds if row(occ_m, *k)]
                theirs = [row(plain_m, *k) for k in seeds if row(plain_m, *k)]
                diffs = [float(row(occ_m, *k)["search_distance"]) - float(row(plain_m, *k)["search_distance"])
                         for k in seeds if row(occ_m, *k) and row(plain_m, *k)]
                if mine and not diffs:  # e.g. run with the other --episode-seeds scheme
                    raise InputError(args.plain, "seed", f"no {plain_m} episode of {world} ({planner}, "
                                     f"{seed_set} set) has the world and episode seeds of the {occ_m} "
                                     "episodes: nothing to pair them with")
                gave = sum(str(r["reason"]).startswith("not_found") for r in mine)
                gave_plain = sum(str(r["reason"]).startswith("not_found") for r in theirs)
                rec = {"world": world, "task": task, "planner": planner, "seed_set": seed_set,
                       "worlds": len(seeds), "model": occ_m, "plain_model": plain_m,
                       "jf_plain": jf["plain"].fmt(2), "jf_company": jf["company"].fmt(2),
                       "company_minus_plain": t_interval(diffs).fmt(2),
                       "given_up": gave, "given_up_share": wilson_interval(gave, len(mine)).fmt(3),
                       "searches": len(mine) * _objects(task), "plain_given_up": gave_plain,
                       "plain_given_up_share": wilson_interval(gave_plain, len(theirs)).fmt(3)}
                out_rows.append(rec)
                body.append([world, planner, seed_set, str(len(seeds)), f"{plain_m} → {occ_m}",
                             t_interval(diffs).fmt(2), f"{gave_plain} → {gave}",
                             f"{rec['plain_given_up_share']} → {rec['given_up_share']}"])
            body.append([world, planner, seed_set, str(len(seeds)), "joint − factorised",
                         f"{jf['plain'].fmt(2)} → {jf['company'].fmt(2)}", "", ""])
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(out_rows)
    atomic_write_text(out / "summary.csv", buf.getvalue())
    command = "python experiments/occlusion_beside_plain.py " + shlex.join(argv if argv is not None else sys.argv[1:])
    text = "\n".join([
        "# The company detection models beside the plain ones", "",
        f"Generated by `{command.strip()}` from {', '.join(f'`{p}`' for p in args.occlusion)} "
        f"and `{args.plain}`.", "",
        "Search travel in metres, paired by world (same house, placement and episode seed), with "
        "95 % Student-t intervals; a give-up is an episode that ended `not_found` although every "
        "object was there to be found (Wilson 95 % intervals). Arrows read plain → company.", "",
        "## Paired differences and give-ups", "",
        markdown_table(["world", "planner", "seed set", "worlds", "comparison",
                        "search travel (m) [95 %]", "give-ups", "share given up [95 %]"], body),
        ""])
    atomic_write_text(out / "summary.md", text)
    print(f"wrote {out / 'summary.md'} and {out / 'summary.csv'}")
    return 0


if __name__ == "__main__":
    run_script(main, Path(__file__).name)
