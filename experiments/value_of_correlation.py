"""The value of correlation: what the joint model saves over the factorised one, and when.

"Value of correlation" = search travel and inspections saved by the joint model (factorised −
joint, world by world on the same worlds and seeds, 95 % Student-t intervals; positive = the
joint model searches less) as a function of three knobs, each swept with the others at the
``correlated`` world's defaults:

(a) correlation strength: the world's teabag-kettle co-location ``same_site`` = s in
    {0, 0.25, 0.5, 0.75, 0.9}, with ``same_room`` = min(s / 2, 1 - s) (so s = 0.5 is the bundled
    ``correlated`` world and s = 0 removes the correlation entirely). The agent's joint model keeps
    its own co-location factor: at low s it assumes a correlation the world does not have;
(b) detector miss rate: ``EnvConfig.detection_miss_rate`` r in {0, 0.1, 0.2, 0.3} (a would-be
    detection is dropped with probability r); both models' ``miss_likelihood`` is set to
    max(0.05, r) so the agent's detector model matches the environment's;
(c) prior violation: the world knob ``prior_violation`` in {0, 0.25, 0.5} (object sites drawn
    partly from the inverse of the agent's prior);
(d) room correlation: ``same_site`` = 0 and ``same_room`` = s in {0, 0.25, 0.5, 0.75, 0.9}: the
    teabag is kept in the kettle's room but never on its site. Site co-location (a) carries little
    value because one inspection sees every object on the site; room co-location is what a
    detection of the kettle can tell about *other* sites.

Writes ``value_of_correlation.csv`` (one row per episode; resumable), ``value_of_correlation.md``
and one plot per sweep (``voc_correlation.png``, ``voc_miss_rate.png``,
``voc_prior_violation.png``, ``voc_room_correlation.png``) to ``--out`` (default
``runs/experiments/value_of_correlation``). The committed results in
``experiments/results/value_of_correlation`` change only when ``--out`` names that folder:

    python experiments/value_of_correlation.py --out experiments/results/value_of_correlation
                                                            # 30 worlds per point: ~9 min on 2 cores
    python experiments/value_of_correlation.py --worlds 100  # writes under runs/
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from fg_tea.common.files import out_folder, atomic_write_text
from fg_tea.study.analysis import (Interval, markdown_table, paired_differences, plot_sweep,
    step_limited)
from fg_tea.common.errors import InputError
from fg_tea.common.options import PLANNER_HELP, WORLD_HELP, experiment_parser
from fg_tea.study.seeds import add_episode_seed_argument, episode_seed_scheme
from fg_tea.study.sweep import add_execution_arguments, plan_sweep, run_sweep

#: Default output folder, relative to the working directory like every fg-tea output under runs/;
#: the committed results (experiments/results/value_of_correlation) change only when --out names them.
DEFAULT_OUT = Path("runs") / "experiments" / "value_of_correlation"
METRICS = ("search_distance", "inspections", "total_distance")
FULL = {"correlation": (0.0, 0.25, 0.5, 0.75, 0.9), "miss_rate": (0.0, 0.1, 0.2, 0.3),
        "prior_violation": (0.0, 0.25, 0.5), "room_correlation": (0.0, 0.25, 0.5, 0.75, 0.9)}
QUICK = {"correlation": (0.0, 0.9), "miss_rate": (0.0, 0.3), "prior_violation": (0.0, 0.5),
         "room_correlation": (0.0, 0.9)}
TITLES = {"correlation": "(a) correlation strength: world same_site",
          "miss_rate": "(b) detector miss rate (model miss likelihood matched, >= 0.05)",
          "prior_violation": "(c) prior violation",
          "room_correlation": "(d) room correlation: world same_room, same_site = 0"}
#: The row column that holds each sweep's knob value.
X_COLUMN = {"correlation": "same_site_teabag_kettle", "miss_rate": "detection_miss_rate",
            "prior_violation": "prior_violation", "room_correlation": "same_room_teabag_kettle"}


def sweep_jobs(name: str, value: float, world: str, n: int, models: list[str], planner: str, env: str,
               episode_seeds: str = "independent"):
    """The paired jobs of one sweep point."""
    if name == "correlation":
        return plan_sweep([world], n, models, [planner], env=env, episode_seeds=episode_seeds,
                          knobs={"same_site": value, "same_room": round(min(value / 2, 1.0 - value), 6)})
    if name == "miss_rate":
        return plan_sweep([world], n, models, [planner], env=env, episode_seeds=episode_seeds,
                          env_overrides={"detection_miss_rate": value},
                          # The injected misses act on the threshold detector only (docs/design.md
                          # §3.4), so this sweep's models look closely with it, as when its
                          # committed results were run.
                          model_overrides={"miss_likelihood": max(0.05, value),
                                           "detector": "threshold", "room_glances": False})
    if name == "room_correlation":
        return plan_sweep([world], n, models, [planner], env=env, episode_seeds=episode_seeds,
                          knobs={"same_site": 0.0, "same_room": value})
    return plan_sweep([world], n, models, [planner], env=env, episode_seeds=episode_seeds,
                      knobs={"prior_violation": value})


def saved(iv: Interval) -> Interval:
    """Negate a difference interval (joint − factorised -> saved by joint)."""
    return Interval(0.0 - iv.mean, 0.0 - iv.high, 0.0 - iv.low, iv.n)


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§11")
    p.add_argument("--worlds", type=int, default=30, help="sampled worlds per sweep point")
    p.add_argument("--world", default="correlated", help=WORLD_HELP)
    p.add_argument("--planner", default="efe", help=PLANNER_HELP)
    p.add_argument("--sweeps", nargs="+", choices=tuple(FULL), default=list(FULL),
                   help="which sweeps to run (each varies one world or model parameter)")
    p.add_argument("--quick", action="store_true", help="two values per sweep (smoke test)")
    add_episode_seed_argument(p)
    add_execution_arguments(p, "value_of_correlation.csv")
    p.add_argument("--out", type=out_folder, default=str(DEFAULT_OUT),
                   help="output folder (default: %(default)s; "
                        "committed: experiments/results/value_of_correlation)")
    return p


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    return build_parser().parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    grid = QUICK if args.quick else FULL
    models = ["factorised", "joint"]
    out = Path(args.out)
    try:
        plan = {(name, v): sweep_jobs(name, v, args.world, args.worlds, models, args.planner, args.env,
                                         episode_seed_scheme(args))
                for name in args.sweeps for v in grid[name]}
        rows = run_sweep([j for jobs in plan.values() for j in jobs], out / "value_of_correlation.csv",
                         args.executor, workers=args.workers or None, address=args.address,
                         resume=args.resume, label="value of correlation")
    except InputError as exc:
        print(f"value_of_correlation: error: {exc}", file=sys.stderr)
        return 2
    by_key = {r["key"]: r for r in rows}
    command = shlex.join(["python", "experiments/value_of_correlation.py", "--worlds", str(args.worlds),
                          "--world", args.world, "--planner", args.planner, "--sweeps", *args.sweeps,
                          "--episode-seeds", episode_seed_scheme(args)]
                         + (["--quick"] if args.quick else []) + ["--out", args.out])
    lines = ["# The value of correlation", "", "Reproduce with:", "", f"    {command}", "",
             f"Saved by the joint model = factorised − joint, world by world ({args.worlds} worlds per "
             f"point, planner `{args.planner}`, 95 % Student-t intervals); positive = the joint model "
             "searches less. Episodes the sweep stopped at its step limit (the planner kept re-inspecting a "
             "site in place after a missed detection) are left out of the pairs and counted per model.", ""]
    for name in args.sweeps:
        x = X_COLUMN[name]
        sweep_rows = [by_key[j.key] for v in grid[name] for j in plan[(name, v)]]
        diffs = paired_differences(sweep_rows, "model", "factorised", METRICS + ("success",), by=(x,))
        diffs.sort(key=lambda d: d[x])
        header = [x, "pairs", "step-limited (f / j)"]
        for m in METRICS:
            header += [f"{m}: factorised", "joint", "saved [95% CI]"]
        body = []
        for d in diffs:
            point = [r for r in sweep_rows if r[x] == d[x]]
            stuck = [sum(step_limited(r) for r in point if r["model"] == m) for m in models]
            line = [d[x], d["pairs"], f"{stuck[0]} / {stuck[1]}"]
            for m in METRICS:
                line += [f"{d[f'{m}_baseline'].mean:.2f}", f"{d[f'{m}_other'].mean:.2f}", saved(d[m]).fmt(2)]
            body.append(line)
        png = f"voc_{name}.png"
        plot_sweep(diffs, x, out / png, ("search_distance", "inspections"), sign=-1.0,
                   title=f"Value of correlation vs {TITLES[name]}")
        lines += [f"## {TITLES[name]}", "", markdown_table(header, body), f"Plot: `{png}`", ""]
    path = atomic_write_text(out / "value_of_correlation.md", "\n".join(lines))
    print(path.read_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
