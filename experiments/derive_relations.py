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
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from fg_tea.common.errors import run_script  # noqa: E402
from fg_tea.common.files import atomic_write_text, out_file  # noqa: E402
from fg_tea.common.options import WORLD_HELP, experiment_parser  # noqa: E402
from fg_tea.common.resources import resolve_world  # noqa: E402
from fg_tea.model.learning import relation_base_rates  # noqa: E402
from fg_tea.model.spec import load_model  # noqa: E402
from fg_tea.world.distributions import load_world  # noqa: E402

DEFAULT_OUT = Path("runs") / "experiments" / "derive_relations" / "joint_derived.toml"


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§12.1 (eq. 55)")
    p.add_argument("--world", default="generated_small_milk_sugar", help=WORLD_HELP)
    p.add_argument("--worlds", type=int, default=1000, help="worlds drawn (world seeds 0..N-1)")
    p.add_argument("--out", type=out_file, default=DEFAULT_OUT, help="model file to write")
    return p


def related_pairs(world) -> list[tuple[str, str]]:
    """(object, anchor) of every co-location rule of the distribution."""
    return [(rule.object, rule.anchor) for rule in world.co_location]


def derive(world, worlds: int, floor: float) -> dict[tuple[str, str], tuple[float, float, list]]:
    """(s, r, [n_S, n_R, n_A]) per related pair, from `worlds` drawn worlds (eq. 55, pooled)."""
    from fg_tea.beliefs.factors import location_prior
    from fg_tea.beliefs.graph import prior_weights

    pairs = related_pairs(world)
    counts = {p: np.zeros(3) for p in pairs}
    base = {p: np.zeros(3) for p in pairs}
    for seed in range(worlds):
        scenario = world.sample(seed)
        rooms = [s.room for s in scenario.sites]
        room_of = {s.name: s.room for s in scenario.sites}
        truth = {o.name: o.true_site for o in scenario.objects}
        prior = {o.name: location_prior(o.name, prior_weights(scenario, o.category), floor).table
                 for o in scenario.objects}
        for a, b in pairs:
            if a not in truth or b not in truth:
                continue
            cls = 0 if truth[a] == truth[b] else 1 if room_of[truth[a]] == room_of[truth[b]] else 2
            counts[(a, b)][cls] += 1
            base[(a, b)] += relation_base_rates(prior[a], prior[b], rooms)
    out = {}
    for pair in pairs:
        n, p = counts[pair], base[pair] / max(counts[pair].sum(), 1)
        pi = n / n.sum()
        out[pair] = (float(pi[0] / pi[2] * p[2] / p[0]), float(pi[1] / pi[2] * p[2] / p[1]),
                     [int(x) for x in n])
    return out


def model_text(world_name: str, worlds: int, weights, capacity: float, command: str) -> str:
    lines = [f"# Written by experiments/derive_relations.py ({command}).",
             f"# Co-location weights derived from {worlds} worlds of `{world_name}` by eq. (55):",
             "# the world's relation frequencies against those of independent objects under the",
             "# agent's priors (docs/design.md §12.1). Counts (same site, same room, apart) per pair",
             "# are in the comments; nothing here was tuned to an episode or a result.",
             'extends = "factorised"', 'name = "joint_derived"',
             f'description = "Joint belief with co-location weights derived from the {world_name} '
             'placement rules (eq. 55)"', "", "[beliefs]", 'structure = "joint"', "",
             "[[relations]]", 'kind = "capacity"', f"penalty = {capacity!r}", ""]
    for (a, b), (s, r, n) in weights.items():
        lines += [f"# {a} ~ {b}: counts {n}", "[[relations]]", 'kind = "co_location"',
                  f'categories = ["{a}", "{b}"]', f"same_site = {round(s, 6)!r}",
                  f"same_room = {round(r, 6)!r}", ""]
    return "\n".join(lines)


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
                                           shlex.join(shown)))
    for (a, b), (s, r, n) in weights.items():
        print(f"{a} ~ {b}: same_site {s:.3f}, same_room {r:.3f} (counts {n})")
    print(f"model: {args.out}")
    return 0


if __name__ == "__main__":
    run_script(main, "derive_relations.py")
