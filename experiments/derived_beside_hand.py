"""Do the weights derived from the world's rules beat the hand-set ones? ``joint_derived`` − ``joint``.

The joint model ``joint_derived`` takes its co-location weights from the house generator's
placement rules (docs/design.md §3.7, ``experiments/derive_relations.py``); ``joint`` has the
hand-set weights. Both were run by ``compare_at_scale.py --table houses`` on the same worlds,
seed sets and episode seeds (``--looks derived`` and the default looks), so their episodes pair
world by world across the two tables. This reads both tables' episodes, keeps the two joint
models' rows, and judges ``joint_derived`` − ``joint`` search travel per cell (house size, task,
planner) and seed set the way the tables judge joint − factorised (docs/design.md §11.1):
paired intervals, Holm's adjustment over the cells, the pairs a 3 % difference needs, the verdict
on the confirmation set. The seed sets are the derived table's declaration (``seed_sets.json``),
which must equal the hand-set table's. No episode is run.

Any two joint models run on the same worlds, seed sets and episode seeds pair the same way
(``--derived-model``, ``--hand-model``; a related-objects table's world names pair with the
houses table's, its ``_related_<n>`` suffix dropped): for example the models the related table
derives for each house size against ``joint_derived``, derived in 13-site houses for every size.

Writes ``summary.md`` and ``replication.csv`` to ``--out``:

    python experiments/derived_beside_hand.py --out experiments/results/joint_vs_factorised_derived/beside_hand
"""

from __future__ import annotations

import argparse
import re
import shlex
import sys
from pathlib import Path

from fg_tea.common.errors import InputError, run_script
from fg_tea.common.files import atomic_write_text, out_folder

HAND, DERIVED = "joint", "joint_derived"
SIZES = {"generated_small": "small", "generated_medium": "medium", "generated_large": "large"}
PLANNERS = {"factorised_efe": "eqs. 10-11", "mi_efe": "exact MI"}


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.options import experiment_parser

    p = experiment_parser(__doc__, __file__, "§11.1")
    p.add_argument("--derived", default="experiments/results/joint_vs_factorised_derived/houses",
                   help="the derived weights' houses table (its folder)")
    p.add_argument("--hand", default="experiments/results/joint_vs_factorised/houses",
                   help="the hand-set weights' houses table on the same worlds (its folder)")
    p.add_argument("--derived-model", default=DERIVED,
                   help="the model name of --derived's rows (default: %(default)s)")
    p.add_argument("--hand-model", default=HAND,
                   help="the model name of --hand's rows (default: %(default)s)")
    p.add_argument("--out", type=out_folder, default="runs/experiments/derived_beside_hand",
                   help="output folder")
    return p


def _table(folder: str, model: str) -> tuple[list[dict], list]:
    """The rows of `model` in a table folder, each tagged with its cell, and the folder's sets."""
    from fg_tea.study.replication import read_seed_sets
    from fg_tea.study.rows import read_rows

    path = Path(folder) / "episodes.csv"
    if not path.is_file():
        raise InputError(str(path), "file", "no such episodes CSV")
    sets = read_seed_sets(Path(folder))
    if not sets:
        raise InputError(str(Path(folder) / "seed_sets.json"), "sets", "no declared seed sets")
    rows = []
    for r in read_rows(path):
        world = re.sub(r"_related_\d+$", "", str(r["world"]))  # a related table's worlds
        if r["model"] == model and world.replace("_milk_sugar", "") in SIZES:
            rows.append({**r, "world": world, "model": model,
                         "size": SIZES[world.replace("_milk_sugar", "")]})
    return rows, sets


def main(argv: list[str] | None = None) -> int:
    from fg_tea.study.replication import adjust, replication_cells, replication_markdown
    from fg_tea.study.rows import write_csv_atomic

    args = build_parser().parse_args(argv)
    hand_model, derived_model = args.hand_model, args.derived_model
    if hand_model == derived_model:
        raise InputError("derived_beside_hand.py", "--derived-model",
                         f"{derived_model!r} is also --hand-model: name two models")
    derived, sets = _table(args.derived, derived_model)
    hand, hand_sets = _table(args.hand, hand_model)
    if sets != hand_sets:
        raise InputError(str(Path(args.hand) / "seed_sets.json"), "sets",
                         "the two tables declared other seed sets: their worlds do not pair")
    cells = replication_cells(derived + hand, sets, vary="model", baseline=hand_model, other=derived_model,
                              by=("size", "task", "planner"))
    order = {"small": 0, "medium": 1, "large": 2}
    cells.sort(key=lambda c: (order[c["size"]], c["task"], c["planner"]))
    # Cells neither table ran (or a planner refused) have no pairs: out of the family, which is
    # then adjusted over the cells that remain.
    cells = [c for c in cells if c[sets[0].name]["pairs"] and c[sets[-1].name]["pairs"]]
    if not cells:
        raise InputError(args.derived, "rows", f"no {derived_model} episode pairs with a {hand_model} one")
    adjust(cells, sets)
    for c in cells:
        c["planner"] = PLANNERS.get(c["planner"], c["planner"])
    rows = []
    for c in cells:
        row = {k: c[k] for k in ("size", "task", "planner")}
        for s in sets:
            e = c[s.name]
            row.update({f"{s.name}_pairs": e["pairs"], f"{s.name}_diff": e["difference"].mean,
                        f"{s.name}_low": e["difference"].low, f"{s.name}_high": e["difference"].high,
                        f"{s.name}_baseline": e["baseline"], f"{s.name}_p_holm": e.get("p_holm"),
                        f"{s.name}_share_differ": e["share_differ"]})
        row.update(pairs_needed=c["pairs_needed"], verdict=c["verdict"])
        rows.append(row)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv_atomic(out / "replication.csv", rows)
    command = shlex.join(["python", "experiments/derived_beside_hand.py",
                          *(sys.argv[1:] if argv is None else argv)])
    text = "\n".join([
        f"# {derived_model} beside {hand_model}: {derived_model} − {hand_model}", "",
        f"Generated by `{command}` from `{args.derived}/episodes.csv` and "
        f"`{args.hand}/episodes.csv` (no episode run). Negative: {derived_model} searched less.",
        "", f"## Replication: {derived_model} − {hand_model} search travel (m)", "",
        replication_markdown(cells, sets, ("size", "task", "planner"), compared="models"), ""])
    atomic_write_text(out / "summary.md", text)
    print(f"wrote {out / 'summary.md'} and {out / 'replication.csv'}")
    return 0


if __name__ == "__main__":
    run_script(main, Path(__file__).name)
