"""Ablations (docs/design.md §11) against the full model, on the same sampled worlds.

Each ablation is a named model file in ``models/ablations`` (a switch in the TOML, not a code
edit); an ablation of the camera's side (no_site_association) also has a camera file of its
name in ``cameras/``, which its episodes run with. Each is run with the EFE planner on the same N worlds and seeds as the full factorised model:

| configuration | original ablation | what changes |
|---|---|---|
| no_epistemic | yes | w_e = 0: probability-and-distance search |
| no_relevance | yes | lambda = 0: no top-down task relevance |
| weak_negative | yes | miss likelihood 0.95: negative evidence nearly uninformative |
| euclidean | yes | Euclidean instead of geodesic planning distances |
| certain_effects | yes | every action effect succeeds with probability 1 |
| no_site_association | yes | detections not checked against the inspected site (eq. 29) |
| no_repeat_penalty | extra | w_a = 0 |
| direct_effects | extra | direct effects q'(z) = rho (docs/design.md eqs. 25-26) |

"Original ablation": yes for the six ablations fg_tea's original design listed, extra for the
switches fg_tea added (docs/design.md §11 lists them all).

Every ablation is reported against the full model as paired differences (ablation − full, world
by world) with 95 % Student-t intervals. Writes ``ablations.csv`` (one row per episode, resumable
like every sweep) and ``ablations.md`` (plus ``ablations.png``) to ``--out`` (default
``runs/experiments/ablations``). The committed results in ``experiments/results/ablations`` change
only when ``--out`` names that folder:

    python experiments/ablations.py --out experiments/results/ablations   # docs/results.md table, 100 worlds
    python experiments/ablations.py --worlds 3 --ablations no_epistemic weak_negative   # under runs/
"""

from __future__ import annotations

import argparse
import shlex
import sys
from dataclasses import replace
from pathlib import Path

from fg_tea.common.files import out_folder, atomic_write_text
from fg_tea.study.analysis import (METRICS, markdown_table, paired_differences, plot_bars,
    summary_markdown, summary_table)
from fg_tea.common.errors import InputError
from fg_tea.common.options import PLANNER_HELP, WORLD_HELP, experiment_parser
from fg_tea.env.camera import camera_names
from fg_tea.model.spec import load_model
from fg_tea.study.seeds import add_episode_seed_argument, episode_seed_scheme
from fg_tea.study.sweep import (ablation_names, add_execution_arguments, model_path, plan_sweep,
    run_sweep)

#: Default output folder, relative to the working directory like every fg-tea output under runs/;
#: the committed results (experiments/results/ablations) are written only when --out names them.
DEFAULT_OUT = Path("runs") / "experiments" / "ablations"
#: The six ablations the original design listed (the others are extra switches).
ORIGINAL = ("no_epistemic", "no_relevance", "weak_negative", "euclidean", "certain_effects",
             "no_site_association")


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§11")
    p.add_argument("--worlds", type=int, default=100, help="number of sampled worlds")
    p.add_argument("--world", default="correlated", help=WORLD_HELP)
    p.add_argument("--full", default="factorised", help="the full model the ablations are compared with")
    p.add_argument("--ablations", nargs="+", default=None,
                   help="ablation models (default: every file in models/ablations)")
    p.add_argument("--planner", default="efe", help=PLANNER_HELP)
    add_episode_seed_argument(p)
    add_execution_arguments(p, "ablations.csv")
    p.add_argument("--out", type=out_folder, default=str(DEFAULT_OUT),
                   help="output folder (default: %(default)s; committed: experiments/results/ablations)")
    return p


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    return build_parser().parse_args(argv)


def report(rows: list[dict], full: str, ablations: list[str], out: Path, command: str) -> Path:
    """Write ablations.md and ablations.png from the sweep rows; return the markdown path."""
    metrics = METRICS + ("success",)
    diffs = {d["model"]: d for d in paired_differences(rows, "model", full, metrics, by=("planner",))}
    header = ["configuration", "original ablation", "what changes", "pairs", "search travel (m): full",
              "ablation", "difference [95% CI]", "inspections: difference", "total travel (m): difference",
              "success rate: full → ablation"]
    body = []
    for name in ablations:
        model = load_model(model_path(name))
        d = diffs.get(model.name)
        if d is None:
            continue
        body.append([model.name, "yes" if name in ORIGINAL else "extra", model.description, d["pairs"],
                     f"{d['search_distance_baseline'].mean:.2f}", f"{d['search_distance_other'].mean:.2f}",
                     d["search_distance"].fmt(2), d["inspections"].fmt(2), d["total_distance"].fmt(2),
                     f"{d['success_baseline'].mean:.3f} → {d['success_other'].mean:.3f}"])
    order = {name: i for i, name in enumerate([full] + [load_model(model_path(a)).name for a in ablations])}
    summary = summary_table(sorted(rows, key=lambda r: (order.get(r["model"], len(order)), r["key"])),
                            ("model", "planner"))
    worlds = len({r["world_seed"] for r in rows})
    text = "\n".join([
        "# Ablations (docs/design.md §11) against the full model", "",
        "Reproduce with:", "", f"    {command}", "",
        f"{worlds} worlds of `{rows[0]['world'] if rows else '?'}`, planner `{rows[0]['planner'] if rows else '?'}`; "
        f"every configuration solves the same worlds with the same seeds. Differences are "
        f"ablation − full model ({full}), world by world, with 95 % Student-t intervals; positive "
        "travel or inspection differences mean the ablation searches worse.", "",
        markdown_table(header, body), "",
        "## Means per configuration", "", summary_markdown(summary), ""])
    plot_bars(summary, out / "ablations.png", ("search_distance", "inspections"), group="model",
              series="planner", title="Ablations: search travel and inspections (95 % CI)")
    return atomic_write_text(out / "ablations.md", text)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        bundled = ablation_names()
        ablations = args.ablations or ([a for a in ORIGINAL if a in bundled]
                                       + [a for a in bundled if a not in ORIGINAL])
        out = Path(args.out)
        jobs = plan_sweep([args.world], args.worlds, [args.full, *ablations], [args.planner], env=args.env,
                          episode_seeds=episode_seed_scheme(args))
        # An ablation of the camera's side (eq. 29's site association) is a bundled camera of the
        # ablation's name, which that ablation's episodes run with (docs/design.md §1.3, §11).
        cameras = set(camera_names())
        jobs = [replace(j, camera=j.model) if j.model in cameras and j.model in ablations else j
                for j in jobs]
        rows = run_sweep(jobs, out / "ablations.csv", args.executor, workers=args.workers or None,
                         address=args.address, resume=args.resume, label="ablations")
        command = shlex.join(["python", "experiments/ablations.py", "--worlds", str(args.worlds),
                              "--world", args.world, "--planner", args.planner, "--ablations", *ablations,
                              "--episode-seeds", episode_seed_scheme(args), "--out", args.out])
        path = report(rows, load_model(model_path(args.full)).name, ablations, out, command)
    except InputError as exc:
        print(f"ablations: error: {exc}", file=sys.stderr)
        return 2
    print(path.read_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
