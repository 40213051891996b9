"""``fg-tea compare``: models x planners over sampled worlds, paired, with a report (docs/design.md §11, §12.4).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fg_tea.cli.common import (
    CAMERA_HELP,
    EXIT_STATUS,
    MAX_SEED,
    Failed,
    check_out_dir,
    check_scenario,
    command,
    integer,
    out_path,
    planner_name,
    planner_size_fault,
    plugin_planner,
    remove_outputs,
    safe_name,
)
from fg_tea.common.errors import InputError, PlannerFault
from fg_tea.study.seeds import add_episode_seed_argument, episode_seed_scheme
from fg_tea.common.files import (
    check_outputs_in,
)

#: Files `compare` writes besides episodes.csv (fg_tea.study.report.comparison_report).
COMPARE_REPORT_OUTPUTS = ("summary.md", "summary.csv", "paired.csv", "paired.png",
                          "ratio_to_optimal.png", "travel_inspections.png", "entropy.png")


#: What `fg-tea compare`'s exit status says (its --help epilog; docs/reference/cli.md shows it).
COMPARE_EXIT_STATUS = ("Exit status: 0 when every episode ran and the report is written (episodes "
                       "that did not complete their task are results, rows of episodes.csv); 1 when "
                       "a job failed for a reason that is not the input (an error in fg_tea or a "
                       "built-in planner, a worker that died): one line naming the job, and the "
                       "finished episodes stay in OUT/episodes.csv for a resume; " + EXIT_STATUS
                       + "; a damaged OUT/episodes.csv is bad input too.")


# ------------------------------------------------------------ compare (docs/design.md §11)
#: Planners of the full comparison, and of --quick.
#: Most worlds one comparison may ask for (each is a row per model and planner; a sweep of more is
#: several commands with --first-seed, which resume into one CSV).
MAX_WORLDS = 100_000
COMPARE_PLANNERS = ("efe", "factorised_efe", "nearest", "greedy", "random", "optimal")


COMPARE_QUICK_PLANNERS = ("efe", "greedy", "nearest", "optimal")


@command("compare")
def cmd_compare(args: argparse.Namespace) -> int:
    """Models x planners over N sampled worlds, paired; write episodes.csv, summary.md and plots."""
    import os
    import shlex

    from fg_tea.study.report import comparison_report
    from fg_tea.study.executors import SweepError
    from fg_tea.study.seeds import check_resumable
    from fg_tea.study.sweep import plan_sweep, run_sweep

    if args.workers < 0:
        raise InputError("<command line>", "--workers", f"expected 0 (every core) or more, got {args.workers}")
    if args.lifelong is not None:
        return _compare_lifelong(args)
    if args.forgetting is not None:
        raise InputError("<command line>", "--forgetting", "applies only with --lifelong K")
    if getattr(args, "learn_transitions", False):
        raise InputError("<command line>", "--learn-transitions", "applies only with --lifelong K")
    n_worlds = args.worlds if args.worlds is not None else (10 if args.quick else 200)
    planners = args.planners or list(COMPARE_QUICK_PLANNERS if args.quick else COMPARE_PLANNERS)
    out = Path(args.out) if args.out else Path("runs") / safe_name(f"compare-{Path(args.world).stem}")
    from fg_tea.model.spec import load_model
    from fg_tea.study.sweep import check_jobs, model_path, world_path
    from fg_tea.tasks.load import load_task
    from fg_tea.world.distributions import load_world

    check_jobs(plan_sweep([args.world], 1, args.models, planners, first_seed=args.first_seed,
                          env=args.env, camera=args.camera or ""))  # unknown inputs named first
    world = load_world(world_path(args.world))
    base = world.base if world.base is not None else world.house(args.first_seed)
    if "optimal" in planners:  # the Bayes-optimal DP's size limit, checked before any episode
        graph = load_task("make_tea", load_model(model_path(args.models[0])), base)
        fault = planner_size_fault("optimal", base, graph, load_model(model_path(args.models[0])))
        if fault is not None and args.planners:
            where = "its houses" if world.generate is not None else "its house"
            raise InputError(world.source or args.world, "--planners optimal",
                             f"{fault} ({where}: {base.name}, world seed {args.first_seed})")
        if fault is not None:
            planners = [p for p in planners if p != "optimal"]
            sys.stderr.write(f"compare: planner optimal left out of the default planners: "
                             f"{fault.split(': ', 1)[-1].split('; ')[0]} in {base.name}\n")
    for spec in planners:  # a plug-in's factory and check() run once here, before any episode
        if plugin_planner(spec):
            first = load_model(model_path(args.models[0]))
            fault = planner_size_fault(spec, base, load_task("make_tea", first, base), first)
            if fault is not None:
                raise InputError(world.source or args.world, f"--planners {spec}", f"{fault} ({base.name})")
    sets = _seed_sets(args, n_worlds)
    check_out_dir(out)
    jobs = plan_sweep([args.world], n_worlds, args.models, planners, first_seed=args.first_seed,
                      env=args.env, camera=args.camera or "", episode_seeds=episode_seed_scheme(args))
    if sets:
        jobs += plan_sweep([args.world], sets[1].count, args.models, planners,
                           first_seed=sets[1].first, env=args.env, camera=args.camera or "",
                           episode_seeds=episode_seed_scheme(args))
    check_resumable(jobs, out / "episodes.csv", args.resume)  # before anything in OUT is replaced
    if sets:  # the confirmation set, declared in OUT before any episode (docs/design.md §11.1)
        from fg_tea.study.replication import declare_seed_sets

        check_outputs_in(out, ["seed_sets.json", "replication.md"])
        declare_seed_sets(out, sets)
    if args.env == "pybullet":  # the house checks each episode would make, once, before any starts
        check_jobs(jobs)
        for ref in args.models:
            check_scenario(base, load_model(model_path(ref)))
    csv_path = out / "episodes.csv"
    check_outputs_in(out, ["episodes.csv"])  # appended to, so never a FIFO or a device
    # The report is rebuilt from this sweep's rows: no summary or plot of an earlier sweep with
    # other planners or models stays beside it (episodes.csv is the resumable record).
    remove_outputs(out, COMPARE_REPORT_OUTPUTS)
    try:
        rows = run_sweep(jobs, csv_path, args.executor, workers=args.workers or None,
                         address=args.address, resume=args.resume, label="compare")
    except SweepError as exc:
        kept = f"finished episodes are in {csv_path}; run again to resume"
        cause = exc.cause
        if isinstance(cause, PlannerFault) and plugin_planner(cause.planner):  # the user's input
            raise InputError("<command line>", f"--planners {cause.planner}", f"{cause} ({kept}), "
                             f"in job {exc.job.key}") from None
        raise Failed(f"{exc} ({kept})") from None
    shown = os.path.relpath(out) if not os.path.relpath(out).startswith("..") else str(out)
    command = shlex.join(["fg-tea", "compare", "--world", args.world, "--worlds", str(n_worlds),
                          "--models", *args.models, "--planners", *planners, "--first-seed",
                          str(args.first_seed), "--env", args.env,
                          *(["--camera", args.camera] if args.camera else []),
                          "--episode-seeds", episode_seed_scheme(args),
                          *(["--confirmation-first-seed", str(sets[1].first), "--confirmation-worlds",
                             str(sets[1].count)] if sets else []), "--out", shown])
    files = comparison_report(rows, out, title=f"Factorised vs joint beliefs on `{args.world}` worlds",
                              command=command)
    print(f"episodes: {csv_path} ({len(rows)} rows)")
    print("wrote: " + ", ".join(str(files[name]) for name in sorted(files)))
    from fg_tea.study.pages import write_compare_pages

    pages = write_compare_pages(jobs, rows, out, getattr(args, "pages", 20), f"Worlds of {args.world}",
                                progress=True)
    print(f"explorer: {pages['index']} ({pages['pages']} side-by-side pages)")
    if len(args.models) > 1:  # how far these worlds go, and how many would settle each cell
        from fg_tea.study.replication import pairs_to_resolve_lines

        for line in pairs_to_resolve_lines(rows, "model", load_model(model_path(args.models[0])).name):
            print(f"resolution: {line}")
    if sets:
        _replication(rows, sets, out, [load_model(model_path(m)).name for m in args.models[:2]],
                     command)
    return 0


def _seed_sets(args: argparse.Namespace, n_worlds: int):
    """The discovery and confirmation sets of ``--confirmation-first-seed`` (None without it)."""
    if args.confirmation_first_seed is None:
        if args.confirmation_worlds is not None:
            raise InputError("<command line>", "--confirmation-worlds",
                             "applies only with --confirmation-first-seed")
        return None
    from fg_tea.study.replication import SeedSet, check_seed_sets

    if len(args.models) < 2:
        raise InputError("<command line>", "--confirmation-first-seed", "a replicated comparison "
                         "needs two models (--models A B: B is judged against A)")
    sets = [SeedSet("discovery", args.first_seed, n_worlds),
            SeedSet("confirmation", args.confirmation_first_seed,
                    args.confirmation_worlds or n_worlds)]
    check_seed_sets(sets)
    return sets


def _replication(rows, sets, out: Path, models: list[str], command: str) -> None:
    """replication.md: the second model against the first per planner, each seed set judged
    on its own (docs/design.md §11.1); one ``replication:`` line per planner."""
    from fg_tea.common.files import atomic_write_text
    from fg_tea.study.replication import replication_cells, replication_markdown

    cells = replication_cells(rows, sets, vary="model", baseline=models[0], other=models[1],
                              by=("planner",))
    atomic_write_text(out / "replication.md", "\n".join([
        f"# Replication: {models[1]} − {models[0]} search travel (m)", "", "Reproduce with:", "",
        f"    {command}", "", replication_markdown(cells, sets, ("planner",))]))
    for c in cells:
        conf = c[sets[1].name]["difference"]
        print(f"replication: {models[1]} - {models[0]} (planner={c['planner']}): {c['verdict']} "
              f"(discovery {c[sets[0].name]['difference'].fmt()}, confirmation {conf.fmt()})")


def _compare_lifelong(args: argparse.Namespace) -> int:
    """``compare --lifelong K``: K consecutive episodes per household, episode k with the model
    learned from that household's episodes before k, beside the hand-set model (and, for joint
    models, learned co-location weights), on the same placements (docs/design.md §12)."""
    import os
    import shlex

    from fg_tea.model.spec import load_model
    from fg_tea.study.households import (
        SEED_STRIDE,
        HouseholdSpec,
        relation_pairs,
        run_lifelong,
        write_outputs,
    )
    from fg_tea.study.sweep import check_jobs, model_path, plan_sweep, world_path
    from fg_tea.world.distributions import load_world

    if args.camera:
        raise InputError("<command line>", "--camera", "does not apply with --lifelong (each "
                         "model runs with the camera of the detector it assumes)")
    if args.episode_seeds is not None:
        raise InputError("<command line>", "--episode-seeds", "does not apply with --lifelong "
                         "(a household's episodes take their seeds from the household's)")
    k = args.lifelong
    households = args.worlds if args.worlds is not None else (10 if args.quick else 30)
    if households < 1:
        raise InputError("<command line>", "--worlds", f"expected at least 1 household, got {households}")
    if (args.first_seed + households) * SEED_STRIDE > MAX_SEED:
        raise InputError("<command line>", "--first-seed", "households x 1000 exceed the largest seed")
    if args.forgetting is not None and not 0.0 < args.forgetting <= 1.0:
        raise InputError("<command line>", "--forgetting", f"expected a value in (0, 1], got {args.forgetting}")
    planners = args.planners or ["efe"]
    if len(planners) != 1:
        raise InputError("<command line>", "--planners", "--lifelong runs one planner; name one")
    if args.executor == "ray":
        raise InputError("<command line>", "--executor", "--lifelong runs serial or process; not ray")
    check_jobs(plan_sweep([args.world], 1, args.models, planners, first_seed=args.first_seed,
                          env=args.env))  # unknown worlds, models, planners named first
    world = load_world(world_path(args.world))
    models = [load_model(model_path(m)) for m in args.models]
    for m in models:
        if m.facing_tolerance or m.occlusion:
            raise InputError("<command line>", "--models", f"{m.name!r} sets [perception] "
                             "facing_tolerance or occlusion, which learned detection "
                             "probabilities (eq. 51) cannot be combined with yet")
    base = world.base if world.base is not None else world.house(args.first_seed)
    for m in models:  # a program's learnable tables can be counted (docs/design.md §12.6), before any episode
        if m.program is not None:
            from fg_tea.model.program_file import program_for
            from fg_tea.study.program_learning import count_tables, declared_states

            count_tables(program_for(base, m), [], declared_states(base))
    if planners[0] == "optimal":  # the Bayes-optimal DP's size limit, before any episode
        from fg_tea.tasks.load import load_task

        fault = planner_size_fault("optimal", base, load_task("make_tea", models[0], base), models[0])
        if fault is not None:
            raise InputError(world.source or args.world, "--planners optimal", f"{fault} ({base.name})")
    if plugin_planner(planners[0]):  # a plug-in's factory and check() run once here, as compare's do
        from fg_tea.tasks.load import load_task

        fault = planner_size_fault(planners[0], base, load_task("make_tea", models[0], base), models[0])
        if fault is not None:
            raise InputError(world.source or args.world, f"--planners {planners[0]}", f"{fault} ({base.name})")
    if args.env == "pybullet":
        for m in models:
            check_scenario(base, m)
    out = Path(args.out) if args.out else Path("runs") / safe_name(f"compare-lifelong-{Path(args.world).stem}")
    check_out_dir(out)
    from fg_tea.study.households import OUTPUTS

    remove_outputs(out, OUTPUTS)
    pairs = relation_pairs(models)
    specs = [HouseholdSpec(str(world_path(args.world)), False, str(model_path(ref)), h, k, args.env,
                           planners[0], (args.forgetting,), None, "mug", pairs,
                           learn_transitions=getattr(args, "learn_transitions", False))
             for ref in args.models for h in range(args.first_seed, args.first_seed + households)]
    workers = 1 if args.executor == "serial" else (args.workers or os.cpu_count() or 1)
    rows = run_lifelong(specs, workers)
    shown = os.path.relpath(out) if not os.path.relpath(out).startswith("..") else str(out)
    command = shlex.join(["fg-tea", "compare", "--lifelong", str(k), "--world", args.world,
                          "--worlds", str(households), "--models", *args.models, "--planners",
                          *planners, "--first-seed", str(args.first_seed), "--env", args.env,
                          *(["--forgetting", str(args.forgetting)] if args.forgetting is not None else []),
                          *(["--learn-transitions"] if getattr(args, "learn_transitions", False) else []),
                          "--out", shown])
    files = write_outputs(rows, out, f"Lifelong learning on `{args.world}`: {households} households "
                          f"x {k} episodes, {args.env} house", command)
    print(f"episodes: {files['episodes']} ({len(rows)} rows)")
    print("wrote: " + ", ".join(str(files[n]) for n in ("curves", "summary", "plot", "focus_plot")))
    return 0


def add_parser(sub) -> None:
    p = sub.add_parser("compare", help="compare models and planners over many sampled worlds (paired)",
                       description="Run every model with every planner on the same N sampled worlds "
                       "(headless), then write OUT/episodes.csv (one row per episode), OUT/summary.md "
                       "(means, 95% CIs, paired differences, ratio to the Bayes-optimal planner, "
                       "ablations when other models are given) and PNG plots. Episodes already in "
                       "OUT/episodes.csv are not run again (--no-resume starts afresh).",
                       epilog=COMPARE_EXIT_STATUS)
    add_compare_arguments(p)


def add_compare_arguments(p: argparse.ArgumentParser, out: str | None = None) -> None:
    """Add the options of ``fg-tea compare`` to `p` (also used by experiments/compare_beliefs.py).

    `out` is the default output folder; None leaves it to the command (``runs/compare-WORLD``).
    """
    from fg_tea.study.sweep import add_execution_arguments

    p.set_defaults(command="compare")
    p.add_argument("--worlds", type=integer(1, MAX_WORLDS), default=None,
                   help=f"number of worlds, 1 to {MAX_WORLDS:,} (default: 200; 10 with --quick)")
    p.add_argument("--world", default="correlated",
                   help="world distribution, bundled name or JSON file (default: %(default)s)")
    p.add_argument("--first-seed", type=integer(0, MAX_SEED), default=0, help="first world seed (default: %(default)s)")
    p.add_argument("--confirmation-first-seed", type=integer(0, MAX_SEED), default=None,
                   help="also run a confirmation set of worlds from this seed, disjoint from the "
                   "discovery set (--first-seed, --worlds), declared in OUT/seed_sets.json before "
                   "any episode; replication.md judges the second model against the first on it "
                   "(docs/design.md §11.1)")
    p.add_argument("--confirmation-worlds", type=integer(1, MAX_WORLDS), default=None,
                   help="worlds of the confirmation set (default: --worlds)")
    add_episode_seed_argument(p)
    p.add_argument("--models", nargs="+", default=["factorised", "joint"],
                   help="models: bundled names, bundled ablations, files, or model programs (.py, "
                   "module:attr, fg_tea.models entry points; building each is limited to "
                   "FG_TEA_MODEL_SECONDS seconds, default 60) (default: factorised joint)")
    p.add_argument("--camera", default=None, help=CAMERA_HELP.replace("the model assumes",
                                                                       "each model assumes"))
    p.add_argument("--planners", nargs="+", type=planner_name, default=None,
                   help="planners: built-in names, names registered in the fg_tea.planners "
                   "entry-point group, or module:attribute for planners of your own "
                   f"(default: {' '.join(COMPARE_PLANNERS)}; "
                   f"with --quick: {' '.join(COMPARE_QUICK_PLANNERS)})")
    add_execution_arguments(p, "episodes.csv")
    if out is None:
        p.add_argument("--out", type=out_path, help="output folder (default: runs/compare-WORLD)")
    else:
        p.add_argument("--out", type=out_path, default=out, help="output folder (default: %(default)s)")
    p.add_argument("--pages", type=integer(0, MAX_WORLDS), default=20, metavar="N",
                   help="side-by-side explorer pages (fg-tea explore) of the N worlds whose pair "
                   "(the first two models, or planners) differs most in search travel, linked from "
                   "OUT/index.html; each world's pair is re-run with its logs (default: %(default)s)")
    p.add_argument("--quick", action="store_true",
                   help=f"10 worlds and planners {' '.join(COMPARE_QUICK_PLANNERS)} (CI size)")
    p.add_argument("--lifelong", type=integer(1, 1000), default=None, metavar="K",
                   help="lifelong learning curves (docs/design.md §12): K consecutive episodes per "
                   "household (--worlds households, default 30; 10 with --quick), episode k with "
                   "the model learned from the household's episodes before k, beside the hand-set "
                   "model on the same placements; one planner (default efe); episodes are run afresh "
                   "(--resume does not apply)")
    p.add_argument("--learn-transitions", action="store_true",
                   help="with --lifelong: a TOML model's learned arm also uses the transition successes "
                   "learned from its episodes (docs/design.md §12.5, eq. 63); without it they are counted "
                   "but the declared successes kept, as in earlier results. A model program's learned arm "
                   "always uses those of the transitions it marks learnable (m.learnable_transition)")
    p.add_argument("--forgetting", type=float, default=None, metavar="GAMMA",
                   help="with --lifelong: forgetting factor gamma in (0, 1] of the learned arms "
                   "(default 1: never forget)")
