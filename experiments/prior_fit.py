"""Are the worlds drawn from the agent's prior? The assumption behind the give-up's declared rate.

The search give-up (docs/design.md §7.8) ends a search when R_o, the chance that a present object
is still unseen, falls below ``give_up_probability``: a false give-up then happens in at most that
fraction of searches *when the world is drawn from the agent's own prior* (and its detection model
is right). This script measures how far a world distribution's placements are from the prior of a
model: for every world seed and object it takes the model's prior q0(L_o) (the belief before any
look) and the object's true site, and reports

- the reliability of the prior: per bin of q0, the mean q0 of the (object, site) pairs in the bin
  against the share of them that hold the object (equal for a prior the worlds are drawn from);
- the tail that matters for giving up: the share of objects whose true site has q0 below each of
  ``--tails``, against the share the prior itself expects there (the sum of q0 over those sites),
  with Wilson 95 % intervals, object by object pooled over worlds.

Writes ``summary.md`` and ``summary.csv`` to ``--out``:

    python experiments/prior_fit.py --worlds 500 --out experiments/results/prior_fit
"""

from __future__ import annotations

import argparse
import csv
import io
import shlex
import sys
from pathlib import Path

import numpy as np

from fg_tea.common.errors import InputError, run_script
from fg_tea.common.files import atomic_write_text, out_folder

WORLDS = ["correlated", "generated_small", "generated_small_milk_sugar", "generated_medium"]
BINS = (0.0, 0.01, 0.03, 0.1, 0.3, 1.0000001)


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.options import MODEL_HELP, experiment_parser

    p = experiment_parser(__doc__, __file__, "§7.8")
    p.add_argument("--world", action="append", default=None,
                   help=f"world distribution, repeatable (default: {' '.join(WORLDS)})")
    p.add_argument("--worlds", type=int, default=200, help="world seeds per distribution (from 0)")
    p.add_argument("--model", default="factorised", help=MODEL_HELP)
    p.add_argument("--tails", type=float, nargs="+", default=[0.01, 0.03, 0.1],
                   help="prior thresholds of the tail table")
    p.add_argument("--out", type=out_folder, default="runs/experiments/prior_fit", help="output folder")
    return p


def pairs_of(world: str, seeds: range, model) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(q0 of every (object, site) pair, 1 where the object truly stands there, object names)."""
    from fg_tea.beliefs.engine import BeliefEngine
    from fg_tea.study.sweep import world_path
    from fg_tea.world.distributions import load_world

    dist = load_world(world_path(world))
    q, hit, names = [], [], []
    for seed in seeds:
        scenario = dist.sample(seed)
        engine = BeliefEngine(scenario, model)
        m = engine.location_matrix()
        for o, obj in enumerate(engine.objects):
            truth = engine.sites.index(scenario.object(obj).true_site)
            q.append(m[o])
            row = np.zeros(len(engine.sites))
            row[truth] = 1.0
            hit.append(row)
            names.append(obj)
    return q, hit, names  # type: ignore[return-value]


def main(argv: list[str] | None = None) -> int:
    from fg_tea.common.stats import wilson_interval
    from fg_tea.model.spec import load_model
    from fg_tea.study.analysis import markdown_table
    from fg_tea.study.sweep import model_path

    args = build_parser().parse_args(argv)
    if args.worlds < 1:
        raise InputError("<command line>", "--worlds", f"{args.worlds}: must be at least 1")
    if any(not 0.0 < t < 1.0 for t in args.tails):
        raise InputError("<command line>", "--tails", "every threshold must lie in (0, 1)")
    model = load_model(model_path(args.model))
    worlds = args.world or WORLDS
    reliability, tails, rows = [], [], []
    for world in worlds:
        q, hit, _ = pairs_of(world, range(args.worlds), model)
        qs, hs = np.concatenate(q), np.concatenate(hit)
        for lo, hi in zip(BINS[:-1], BINS[1:]):
            sel = (qs >= lo) & (qs < hi)
            if sel.any():
                share = wilson_interval(int(hs[sel].sum()), int(sel.sum()))
                reliability.append([world, f"[{lo:g}, {min(hi, 1):g})", str(int(sel.sum())),
                                    f"{qs[sel].mean():.4f}", share.fmt(4)])
        objects = len(q)
        for t in args.tails:
            expected = float(np.mean([row[row < t].sum() for row in q]))
            observed = sum(int(h[row < t].sum()) for row, h in zip(q, hit))
            share = wilson_interval(observed, objects)
            tails.append([world, f"{t:g}", str(objects), f"{expected:.4f}", share.fmt(4),
                          f"{share.mean / expected:.2f}" if expected > 0 else "–"])
            rows.append({"world": world, "tail": t, "objects": objects, "expected": f"{expected:.6f}",
                         "observed": f"{share.mean:.6f}", "low": f"{share.low:.6f}",
                         "high": f"{share.high:.6f}"})
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    atomic_write_text(out / "summary.csv", buf.getvalue())
    command = "python experiments/prior_fit.py " + shlex.join(argv if argv is not None else sys.argv[1:])
    atomic_write_text(out / "summary.md", "\n".join([
        f"# Are the worlds drawn from the prior of `{model.name}`?", "",
        f"Generated by `{command.strip()}`; world seeds 0 .. {args.worlds - 1} of each distribution.", "",
        "## Where the objects stand, against where the prior expects them", "",
        "Share of objects whose true site has prior q0 below the threshold, against the prior's own "
        "mass there (equal if the worlds were drawn from the prior), Wilson 95 % intervals.", "",
        markdown_table(["world", "q0 below", "objects", "prior expects", "worlds have [95 %]",
                        "ratio"], tails), "",
        "## Reliability of the prior", "",
        markdown_table(["world", "q0 bin", "(object, site) pairs", "mean q0",
                        "share holding the object [95 %]"], reliability), ""]))
    print(f"wrote {out / 'summary.md'} and {out / 'summary.csv'}")
    return 0


if __name__ == "__main__":
    run_script(main, Path(__file__).name)
