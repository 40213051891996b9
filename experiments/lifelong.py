"""Lifelong learning curves: does an agent that learns from its own episodes search less?

For each household (a seed) the agent lives K consecutive episodes in the same house; episode k
uses the model learned (docs/design.md §12) from that household's episodes 0..k-1. Beside it, on
the same placements and seeds: a hand-set control, and for joint models an arm that learns the
co-location weights too (eqs. 54-55) where the ``learned`` arm keeps the hand-set ones. The
logic is :mod:`fg_tea.study.households` (also ``fg-tea compare --lifelong K``); this script adds fixed
scenarios, several forgetting factors, moving an object, learned action effects
(``--learn-transitions``, docs/design.md §12.5) and worlds whose effects fail
(``--effect-success boil 0.6``, environment only).

Placements are drawn, episode by episode, from a world distribution whose habits differ from the
agent's priors (default ``contrary_household``: every object placed from the inverse of the
prior; the mug is on the study shelf 59 % of the time, where the prior says 0.01), or, with
``--scenario``, are one scenario's own (``prior_violation``: the mug always on the study shelf).

Outputs (under ``--out``, default ``runs/experiments/lifelong``): ``episodes.csv`` (one row per
episode), ``curves.csv`` (mean and 95 % interval over households per model, arm and episode),
``summary.md`` (episode 1 against episode K, paired over households) and ``curves.png``.

    python experiments/lifelong.py --households 30 --episodes 10 --out experiments/results/lifelong
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

from fg_tea.common.files import out_folder
from fg_tea.common.errors import InputError, run_script
from fg_tea.common.options import (ENV_HELP, MODELS_HELP, OUT_HELP, PLANNER_HELP,
                                   WORKERS_HELP, experiment_parser)
from fg_tea.study.households import (HouseholdSpec, check_move, relation_pairs, run_lifelong,
    write_outputs)


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§12.4")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--world", default=None,
                       help="world distribution the placements are drawn from, a bundled name or a world "
                       "JSON file (default: contrary_household)")
    where.add_argument("--scenario", default=None,
                       help="a scenario whose own placements every episode uses (e.g. prior_violation)")
    p.add_argument("--models", nargs="+", default=["factorised", "joint"], help=MODELS_HELP)
    p.add_argument("--households", type=int, default=30, help="number of households (one seed each)")
    p.add_argument("--episodes", type=int, default=10, help="consecutive episodes K per household")
    p.add_argument("--first-household", type=int, default=0, help="seed of the first household")
    p.add_argument("--env", choices=("fake", "pybullet"), default="fake", help=ENV_HELP)
    p.add_argument("--planner", default="efe", help=PLANNER_HELP)
    p.add_argument("--workers", type=int, default=1, help=WORKERS_HELP)
    p.add_argument("--out", type=out_folder, default="runs/experiments/lifelong", help=OUT_HELP)
    p.add_argument("--forgetting", type=float, nargs="+", default=None,
                   help="forgetting factor(s) gamma of the learned arms (default 1: never forget); "
                   "several values run the learned arms once per value")
    p.add_argument("--move", nargs=3, metavar=("OBJECT", "SITE", "AFTER"), default=None,
                   help="from episode AFTER+1 on, OBJECT always stands at SITE (recovery experiment)")
    p.add_argument("--focus", default="mug", help="the object whose inspections are reported")
    p.add_argument("--learn-transitions", action="store_true",
                   help="the learned arms also use learned action effect successes (docs/design.md §12.5)")
    p.add_argument("--effect-success", nargs=2, action="append", metavar=("EFFECT", "P"), default=None,
                   help="environment only: a truth EFFECT (boil, fill, ...) happens with probability P "
                   "when its action reports success; repeatable")
    p.add_argument("--logs", default=None, metavar="DIR",
                   help="write every learned arm's episode logs under DIR/MODEL/ARM/householdH/ "
                   "(then `fg-tea learn` on them rebuilds that arm's learned model)")
    return p


def main(argv=None) -> int:
    p = build_parser()
    args = p.parse_args(argv)
    started, cpu = time.time(), time.process_time()
    try:
        specs = _specs(args)
    except InputError as exc:
        p.error(str(exc))
    rows = run_lifelong(specs, args.workers)
    source = args.scenario or args.world or "contrary_household"
    title = (f"Lifelong learning: {source}{' (fixed placements)' if args.scenario else ''}, "
             f"{args.households} households x {args.episodes} episodes, {args.env} house"
             + (f"; {args.move[0]} moved to {args.move[1]} after episode {args.move[2]}" if args.move else ""))
    command = shlex.join(["python", "experiments/lifelong.py", *(argv if argv is not None else sys.argv[1:])])
    write_outputs(rows, Path(args.out), title, command, args.focus)
    print((Path(args.out) / "summary.md").read_text())
    print(f"{len(rows)} episodes in {time.time() - started:.0f} s wall, "
          f"{time.process_time() - cpu:.0f} s CPU (this process)")
    return 0


def _check_planner(planner: str, house, models) -> None:
    """A plug-in planner's factory and check() run once before any episode, as compare's do: a
    fault is one line and status 2, not a failed household."""
    from fg_tea.cli.common import planner_size_fault, plugin_planner
    from fg_tea.tasks.load import load_task

    if not plugin_planner(planner):
        return
    for model in models:
        fault = planner_size_fault(planner, house, load_task("make_tea", model, house), model)
        if fault is not None:
            raise InputError("<command line>", f"--planner {planner}", f"{fault} ({house.name})")


def _specs(args) -> list[HouseholdSpec]:
    from fg_tea.model.spec import load_model
    from fg_tea.world.scenario import load_scenario
    from fg_tea.world.distributions import load_world

    if args.households < 1 or args.episodes < 1 or args.first_household < 0:
        raise InputError("<command line>", "--households/--episodes", "expected positive counts")
    if args.episodes > 1000:
        raise InputError("<command line>", "--episodes", "at most 1000 (seeds are 1000 h + k)")
    gammas = tuple(args.forgetting) if args.forgetting else (None,)
    for g in gammas:
        if g is not None and not 0 < g <= 1:
            raise InputError("<command line>", "--forgetting", f"must be in (0, 1], got {g}")
    fixed = args.scenario is not None
    source = args.scenario or args.world or "contrary_household"
    house = load_scenario(source) if fixed else load_world(source).sample(0)
    move = None
    if args.move:
        try:
            after = int(args.move[2])
        except ValueError:
            raise InputError("<command line>", "--move", f"AFTER must be an integer, got {args.move[2]!r}") from None
        move = (args.move[0], args.move[1], after)
        check_move(move, house, args.episodes)
    models = [load_model(m) for m in args.models]
    _check_planner(args.planner, house, models)
    pairs = relation_pairs(models)
    from fg_tea.env.truth import check_effect_success

    effects = []
    for name, value in args.effect_success or []:
        try:
            effects.append((name, float(value)))
            check_effect_success(dict(effects))
        except ValueError as exc:
            raise InputError("<command line>", "--effect-success", str(exc)) from None
    return [HouseholdSpec(source, fixed, ref, h, args.episodes, args.env, args.planner, gammas,
                          move, args.focus, pairs, args.logs, args.learn_transitions, tuple(effects))
            for ref in args.models
            for h in range(args.first_household, args.first_household + args.households)]


if __name__ == "__main__":
    run_script(main, "lifelong.py")
