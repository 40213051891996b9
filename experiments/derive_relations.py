"""Derive a joint model's co-location weights from a world distribution's own placement rules.

The bundled `joint` model sets its co-location weights by hand (same site 3, same room 2). This
script derives them from what the house generator actually does instead, with no episode and no
result involved: it draws `--worlds` worlds of a distribution (default `generated_small_milk_sugar`,
whose rules put the teabag and the sugar by the kettle), counts for every pair of related
categories how often their true sites are the same site, the same room or apart, and turns the
frequencies into weights with eq. (55) (docs/design.md §12.1): s = (pi_S / pi_A)(p_A / p_S) and
r = (pi_R / pi_A)(p_A / p_R), where pi are the world's frequencies and p the frequencies two
independent objects with the agent's location priors would show, averaged over the drawn houses.
The related pairs are the ones the distribution's rules state: each object with its anchor. (Two
objects with one anchor are correlated through it already; a factor between them derived from
their raw co-occurrence would count that twice.) The capacity relation is the `joint` model's.

Writes a model file that `extends = "factorised"` (``--out``, default
``runs/experiments/derive_relations/joint_derived.toml``); the bundled ``models/joint_derived.toml``
is this script's output with the defaults and ``--out models/joint_derived.toml``:

    python experiments/derive_relations.py --out models/joint_derived.toml
"""

from __future__ import annotations

import argparse
from pathlib import Path

from fg_tea.common.errors import run_script
from fg_tea.common.files import atomic_write_text, out_file
from fg_tea.common.options import WORLD_HELP, experiment_parser
from fg_tea.common.resources import resolve_world
from fg_tea.model.spec import load_model
from fg_tea.study.relations import derive, model_text
from fg_tea.world.distributions import load_world

DEFAULT_OUT = Path("runs") / "experiments" / "derive_relations" / "joint_derived.toml"


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§12.1 (eq. 55)")
    p.add_argument("--world", default="generated_small_milk_sugar", help=WORLD_HELP)
    p.add_argument("--worlds", type=int, default=1000, help="worlds drawn (world seeds 0..N-1)")
    p.add_argument("--out", type=out_file, default=DEFAULT_OUT, help="model file to write")
    return p


def main(argv: list[str] | None = None) -> int:
    import shlex

    args = build_parser().parse_args(argv)
    world = load_world(resolve_world(args.world))
    joint = load_model("joint")
    capacity = next(r.penalty for r in joint.relations if r.kind == "capacity")
    weights = derive(world, args.worlds, joint.prior_floor)
    shown = ["python", "experiments/derive_relations.py", "--world", args.world, "--worlds",
             str(args.worlds), "--out", str(args.out)]
    atomic_write_text(args.out, model_text(world.name, args.worlds, weights, capacity,
                                           f"experiments/derive_relations.py ({shlex.join(shown)})"))
    for (a, b), (s, r, n) in weights.items():
        print(f"{a} ~ {b}: same_site {s:.3f}, same_room {r:.3f} (counts {n})")
    print(f"model: {args.out}")
    return 0


if __name__ == "__main__":
    run_script(main, "derive_relations.py")
