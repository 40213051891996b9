"""How far is the object-by-object belief update from the exact coupled one, under occlusion?

With ``[perception] occlusion = true`` an object's chance of being seen at a site depends on which
other objects share the site (docs/design.md §3.4, "Facing and company"). The exact likelihood of a
look then couples the objects' locations: a miss of the teabag on the counter is likelier if the
kettle stands there too. A joint belief keeps that coupling exactly; a factorised one cannot, and
updates object by object with each object's detection probability under the belief (eqs. 60, 34
and 31). This script measures what that costs, and checks the joint belief on the way.

In generated houses (the world distributions named by ``--world``, house seeds 0 .. --houses - 1)
it runs chains of ``--looks`` looks from viewpoints drawn at random. Detections are drawn from the
company model itself at the house's true placement, so the model is right and only the update
differs. After every look it compares each object's marginal under the update the agent uses (its
own belief engine, with ``positive_update = "likelihood"`` so that both sides use eq. 31) with the
exact coupled posterior, computed by enumerating every joint placement (K^N states; houses above
``--max-states`` are skipped and listed). It reports the KL divergence KL(exact || update), summed
over objects, per look: mean, 95th percentile and maximum, per world distribution and model.

Writes ``steps.csv`` (one row per look) and ``summary.md`` to ``--out``:

    python experiments/occlusion_error.py --houses 3 --chains 2            # a quick look
    # the committed table (experiments/results/occlusion_error/):
    python experiments/occlusion_error.py --houses 10 --chains 5 --looks 20 --seed 0 \\
        --out experiments/results/occlusion_error
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import shlex
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from fg_tea.common.errors import run_script
from fg_tea.common.files import atomic_write_text, out_folder
from fg_tea.common.tables import markdown_table

WORLDS = ["generated_small", "generated_small_milk_sugar", "generated_medium"]
MODELS = ["factorised_occlusion", "joint_occlusion"]
COLUMNS = ["world", "house", "sites", "objects", "model", "chain", "look", "viewpoint", "kind",
           "seen", "kl", "max_abs"]


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.options import MODELS_HELP, SEED_HELP, WORLD_HELP, experiment_parser

    p = experiment_parser(__doc__, __file__, "§3.4")
    p.add_argument("--world", action="append", default=None, help=f"{WORLD_HELP} (repeatable; "
                   f"default {', '.join(WORLDS)})")
    p.add_argument("--houses", type=int, default=3, help="house seeds per world distribution")
    p.add_argument("--chains", type=int, default=2, help="chains of looks per house and model")
    p.add_argument("--looks", type=int, default=20, help="looks per chain")
    p.add_argument("--models", nargs="+", default=MODELS, help=MODELS_HELP + " (each with occlusion)")
    p.add_argument("--seed", type=int, default=0, help=SEED_HELP)
    p.add_argument("--max-states", type=int, default=2_000_000,
                   help="largest joint (sites^objects) enumerated; larger houses are skipped")
    p.add_argument("--out", type=out_folder, default="runs/experiments/occlusion_error",
                   help="output folder")
    return p


def kl(p: np.ndarray, q: np.ndarray) -> float:
    """KL(p || q) in nats over one marginal (0 log 0 = 0)."""
    keep = p > 0
    return float(np.sum(p[keep] * (np.log(p[keep]) - np.log(np.maximum(q[keep], 1e-300)))))


def marginals(joint: np.ndarray) -> np.ndarray:
    n = joint.ndim
    return np.stack([joint.sum(axis=tuple(a for a in range(n) if a != o)) for o in range(n)])


def run_chain(scenario, model, views, rng: np.random.Generator, looks: int) -> list[dict]:
    """One chain: the engine's update and the exact coupled posterior, side by side."""
    from fg_tea.beliefs.engine import BeliefEngine
    from fg_tea.beliefs.occlusion import coupled_likelihood

    engine = BeliefEngine(scenario, model)
    objects, k = list(engine.objects), len(engine.sites)
    exact = engine.location_joint().copy()
    truth = [engine.sites.index(scenario.object(o).true_site) for o in objects]
    rows = []
    for look in range(looks):
        views.reweigh(engine.location_matrix(), engine.pairwise() if engine.correlated else None)
        view = views.views[int(rng.integers(len(views.views)))]
        table = views.company.tables[view.name]
        found: dict[int, int | None] = {}
        for o, j in enumerate(truth):
            found[o] = None
            if j in view.sites:
                mask = sum(1 << x for x, jx in enumerate(truth) if x != o and jx == j)
                if rng.random() < table[o, view.sites.index(j), mask]:
                    found[o] = j
        exact = exact * coupled_likelihood(table, view.sites, k, found, model.false_positive_rate)
        exact /= exact.sum()
        engine.observe_viewpoint(view, {objects[o]: (None if j is None else engine.sites[j])
                                        for o, j in found.items()})
        ours, truth_m = engine.location_matrix(), marginals(exact)
        rows.append({"look": look + 1, "viewpoint": view.name, "kind": view.kind,
                     "seen": sum(j is not None for j in found.values()),
                     "kl": sum(kl(truth_m[o], ours[o]) for o in range(len(objects))),
                     "max_abs": float(np.abs(truth_m - ours).max())})
    return rows


def summary(rows: list[dict], skipped: list[str], command: str) -> str:
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["world"], r["model"]), []).append(r)
    out = io.StringIO()
    out.write("# The object-by-object update against the exact coupled one (occlusion)\n\n")
    out.write(f"Generated by `{command}`.\n\n")
    out.write("Per look, KL(exact || update) in nats summed over objects, and the largest absolute "
              "difference of one marginal entry; detections drawn from the company model at the "
              "house's true placement (docs/design.md §3.4).\n\n")
    body = []
    for (world, model), g in sorted(groups.items()):
        k = np.array([r["kl"] for r in g])
        sites = [r["sites"] for r in g]
        body.append([world, model, len({r["house"] for r in g}), f"{min(sites)}-{max(sites)}",
                     g[0]["objects"], len(g), f"{k.mean():.2e}", f"{np.percentile(k, 95):.2e}", f"{k.max():.2e}",
                     f"{max(r['max_abs'] for r in g):.2e}"])
    out.write(markdown_table(["world", "model", "houses", "sites", "objects", "looks", "KL mean", "KL p95", "KL max",
                              "max abs diff"], body, align="left"))
    if skipped:
        out.write(f"\nSkipped (joint too large to enumerate): {', '.join(skipped)}.\n")
    return out.getvalue()


def main(argv: list[str] | None = None) -> int:
    from fg_tea.beliefs.detection import ViewModel
    from fg_tea.env.house import PyBulletHouse
    from fg_tea.episode.runner import env_config_for
    from fg_tea.model.spec import load_model
    from fg_tea.study.sweep import model_path, world_path
    from fg_tea.world.distributions import load_world

    args = build_parser().parse_args(argv)
    for flag in ("houses", "chains", "looks", "max_states"):
        if getattr(args, flag) < 1:
            print(f"{Path(__file__).name}: error: --{flag.replace('_', '-')}: must be at least 1",
                  file=sys.stderr)
            return 2
    worlds = args.world or WORLDS
    dists = {w: load_world(world_path(w)) for w in worlds}
    models = {m: load_model(model_path(m)) for m in args.models}
    for name, m in models.items():
        if not m.occlusion:
            print(f"{Path(__file__).name}: error: --models: {name!r} does not set [perception] "
                  "occlusion = true", file=sys.stderr)
            return 2
    out = Path(args.out)
    rows: list[dict] = []
    skipped: list[str] = []
    for world in worlds:
        for house in range(args.houses):
            scenario = dists[world].sample(house)
            n, k = len(scenario.objects), len(scenario.sites)
            if k ** n > args.max_states:
                skipped.append(f"{world} house {house} ({k} sites, {n} objects)")
                continue
            env = PyBulletHouse(scenario, env_config_for(next(iter(models.values()))))
            try:
                env.reset(0)
                cats = [scenario.object(o).category for o in scenario.object_names]
                expected = env.expected_pixel_counts(sorted(set(cats)))
                company = env.company_pixel_counts(sorted(cats))
            finally:
                env.close()
            for name, base in models.items():
                model = replace(base, positive_update="likelihood")
                views = ViewModel(scenario, model, scenario.object_names, expected, company)
                for chain in range(args.chains):
                    rng = np.random.default_rng([args.seed, worlds.index(world), house, chain])
                    for r in run_chain(scenario, model, views, rng, args.looks):
                        rows.append({"world": world, "house": house, "sites": k, "objects": n,
                                     "model": name, "chain": chain, **r})
            print(f"  ... {world} house {house}: {len(rows)} looks", file=sys.stderr, flush=True)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    for r in rows:
        writer.writerow({c: (f"{r[c]:.6e}" if isinstance(r[c], float) else r[c]) for c in COLUMNS})
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "steps.csv", buf.getvalue())
    command = "python experiments/occlusion_error.py " + shlex.join(argv if argv is not None else sys.argv[1:])
    atomic_write_text(out / "summary.md", summary(rows, skipped, command.strip()))
    print(f"wrote {out / 'steps.csv'} and {out / 'summary.md'}")
    return 0


if __name__ == "__main__":
    run_script(main, Path(__file__).name)
