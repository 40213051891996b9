"""Where do joint beliefs help? Belief structure and information gain as separate factors, at scale.

This script answers: in generated houses of about 12, 24 and 48 sites, for the make-tea and the
milk-and-sugar tasks, how much search travel, how many inspections and how much SPL (docs/design.md
§11) does a joint location belief save over a factorised one — separately for the information gain
of eqs. (10)-(11)/(41) (planner ``factorised_efe``) and the exact mutual information of eqs.
(38)/(42) (planner ``mi_efe``) — and what does it cost in decision time?

The four cells {factorised, joint} × {eqs. 10-11, exact MI} are the models ``factorised`` and
``joint`` (room glances, visibility detector; ``--looks close`` takes ``factorised_close`` and
``joint_close``) under the planners ``factorised_efe`` and ``mi_efe``; the baselines ``nearest``
and ``greedy`` (most probable site) run with both models. Every configuration solves the same
worlds with the same seeds, so every cell is reported as the paired joint − factorised
difference world by world, with a 95 % Student-t interval.

Tables (one command each; every table resumes after an interruption, skipping the episodes
already in its CSV):

- ``--table houses``: house size (``generated_small``/``medium``/``large``, 3/6/10 rooms) × task
  (``make_tea``, and ``make_tea_milk_sugar`` in the ``generated_*_milk_sugar`` worlds).
- ``--table detectability``: the detector's half-probability pixel count n_50 for the small
  objects (``--small-categories``, default the teabag; camera and agent curve changed together,
  written as model files under OUT/TABLE/models/ and camera files under OUT/TABLE/cameras/) × correlation strength c (the probability that the
  teabag is placed by the kettle: 2c/3 on its site, c/3 elsewhere in its room, so c = 0.75 is the
  bundled worlds' 0.5 / 0.25) × house size.
- ``--table related``: the number of related objects (``--related``, 0-4) × house size, in the
  five-object houses of the milk-and-sugar task: the first n of teabag, sugar, milk and mug are
  placed by the kettle (0.5 on its site, 0.25 elsewhere in its room, as the bundled worlds place
  the teabag), the rest from their priors (world files written under OUT/related/worlds/). The
  joint model of each n and house size relates exactly those objects to the kettle, with weights
  derived from the placement rule by eq. (55) over ``--derive-worlds`` houses of that size drawn
  from seeds no cell evaluates (``fg_tea.study.relations``; model files under
  OUT/related/models/, the folder's number of worlds declared in OUT/related/derivation.json), so
  no weight is tuned to an episode; the factorised belief is the same in every cell.

Each writes under ``runs/experiments/compare_at_scale/<table>/`` by default: ``episodes.csv`` (one row per
episode, the sweep CSV of :mod:`fg_tea.study.sweep`), ``<table>.md`` (markdown tables of every cell),
``<table>_paired.csv``, a heat map ``<table>_heatmap.png`` of the paired joint − factorised
difference in search travel, and ``decision_times.csv``: the median wall time per decision of each
model and planner, measured in-process on the first ``--timing-worlds`` worlds of each house size
(kept out of the episode CSV, which holds no wall-clock time).

Long sweeps: ``--executor ray --address auto`` (or ``ray://head:10001``) runs the episodes as Ray
tasks on a cluster with fg_tea installed on every node; the CSV is the same bytes as on the
process pool.

``--models FIRST SECOND`` (houses table) compares two models of your own instead of the ``--looks``
pair — model files, bundled names or model programs (``my_model.py``, ``module:attr``;
docs/how-to/model-as-program.md) — the first with a factorised belief, the second a joint one.

Each report covers every row of its CSV whose model is one of ``--looks``' pair (or ``--models``; the related
table: ``factorised`` and ``joint_related_<n>``), not only
the episodes the last command planned: cells run by separate commands (for example fewer worlds
for the 45-site houses) share one report, each with its own number of pairs, and
``commands.txt`` in the table's folder lists every command that added rows. Decision times merge
the same way (a new measurement of a configuration replaces the old one).

Above 50,000 joint states joint ``efe`` and ``mi_efe`` take the exact gain from the subset dynamic
program (docs/design.md §6.2), so every house size and both tasks run with every planner.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import math
import shlex
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from fg_tea.study.analysis import (markdown_table, paired_differences, save_figure,
    summary_markdown, summary_table)
from fg_tea.common.errors import run_script
from fg_tea.common.errors import InputError
from fg_tea.common.files import atomic_write_text, out_folder
from fg_tea.common.options import experiment_parser
from fg_tea.env.camera import load_camera
from fg_tea.planning import check_planner
from fg_tea.study.relations import (DERIVE_FIRST_SEED, RELATED_ORDER, derive,
                                    model_text, related_world)
from fg_tea.study.replication import (SeedSet, adjust, check_seed_sets,
                                      declare_seed_sets, read_seed_sets, replication_cells,
                                      replication_markdown, ESTABLISHED)
from fg_tea.study.rows import parse_cell, read_rows, write_csv_atomic
from fg_tea.study.reuse import copy_rows, match as match_reuse
from fg_tea.study.seeds import (add_episode_seed_argument, check_episode_seeds,
                               check_resumable, episode_seed_scheme, recorded_argv)
from fg_tea.study.sweep import Job, add_execution_arguments, plan_sweep, run_sweep
from fg_tea.world.housegen import CATEGORIES

SIZES = {"small": "generated_small", "medium": "generated_medium", "large": "generated_large"}
TASKS = {"make_tea": "", "make_tea_milk_sugar": "_milk_sugar"}
LOOKS = {"glances": ("factorised", "joint"), "close": ("factorised_close", "joint_close"),
         "derived": ("factorised", "joint_derived"),
         "occlusion": ("factorised_occlusion", "joint_occlusion")}
GAINS = ("factorised_efe", "mi_efe")
BASELINES = ("nearest", "greedy")
METRICS = ("search_distance", "inspections", "spl")
LABEL = {"search_distance": "search travel (m)", "inspections": "inspections", "spl": "SPL"}
GAIN_LABEL = {"factorised_efe": "eqs. 10-11", "mi_efe": "exact MI", "nearest": "nearest",
              "greedy": "most probable", "lookahead": "lookahead"}
DEFAULT_HALF_PIXELS = (25.0, 50.0, 100.0)
DEFAULT_STRENGTHS = (0.0, 0.75, 1.0)
DEFAULT_RELATED = (0, 1, 2, 3, 4)
DEFAULT_DERIVE_WORLDS = 1000


DEFAULT_OUT = "runs/experiments/compare_at_scale"

def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§11 (the information gains: §6.2)")
    p.add_argument("--table", choices=("houses", "detectability", "related"), default="houses",
                   help="which table to run (default: %(default)s)")
    p.add_argument("--worlds", type=int, default=200, help="worlds per cell (default: %(default)s)")
    p.add_argument("--first-seed", type=int, default=0,
                   help="first world seed (of the discovery set, with --confirmation-first-seed; "
                   "default: %(default)s)")
    p.add_argument("--confirmation-first-seed", type=int, default=None,
                   help="declare a confirmation set of worlds from this seed, disjoint from the "
                   "discovery set (--first-seed, --worlds); both are written to seed_sets.json "
                   "before any episode, and the report judges every cell on it "
                   "(docs/design.md §11.1)")
    p.add_argument("--confirmation-worlds", type=int, default=None,
                   help="worlds of the confirmation set (default: --worlds)")
    p.add_argument("--sizes", nargs="+", choices=tuple(SIZES), default=list(SIZES),
                   help="house sizes: small (3 rooms, ~13 sites), medium (6, ~27), large (10, ~45) "
                   "(default: all)")
    p.add_argument("--tasks", nargs="+", choices=tuple(TASKS), default=list(TASKS),
                   help="tasks of the houses table (default: both)")
    p.add_argument("--looks", choices=tuple(LOOKS), default="glances",
                   help="glances: factorised/joint (room glances, visibility detector); derived: "
                   "factorised/joint_derived (co-location weights derived from the generator's "
                   "placement rules, experiments/derive_relations.py); occlusion: "
                   "factorised_occlusion/joint_occlusion (detection that knows the turn tolerance "
                   "and what shares a site, docs/design.md §3.4); close: "
                   "factorised_close/joint_close (default: %(default)s)")
    p.add_argument("--models", nargs=2, default=None, metavar=("FACTORISED", "JOINT"),
                   help="houses table: the two models compared instead of the --looks pair, a "
                   "factorised-structure one then a joint-structure one: model files, bundled names "
                   "or model programs (.py, module:attr; docs/how-to/model-as-program.md)")
    p.add_argument("--planners", nargs="+", default=list(GAINS + BASELINES),
                   help=f"planner names (default: {' '.join(GAINS + BASELINES)})")
    p.add_argument("--half-pixels", nargs="+", type=float, default=list(DEFAULT_HALF_PIXELS),
                   help="detectability table: n_50 of the small objects, pixels "
                   f"(default: {' '.join(map(str, DEFAULT_HALF_PIXELS))}; the models' own is 50)")
    p.add_argument("--strengths", nargs="+", type=float, default=list(DEFAULT_STRENGTHS),
                   help="detectability table: correlation strengths c in [0, 1] "
                   f"(default: {' '.join(map(str, DEFAULT_STRENGTHS))})")
    p.add_argument("--related", nargs="+", type=int, default=list(DEFAULT_RELATED),
                   help="related table: how many objects are placed by the kettle, 0 to "
                   f"{len(RELATED_ORDER)} (the first of {', '.join(RELATED_ORDER)}; default: "
                   f"{' '.join(map(str, DEFAULT_RELATED))})")
    p.add_argument("--derive-worlds", type=int, default=1000,
                   help="related table: houses of each size drawn to derive each joint model's "
                   "weights (eq. 55; world seeds from 1,000,000; default: %(default)s)")
    p.add_argument("--small-categories", nargs="+", default=["teabag"],
                   help="object categories whose detection curve the detectability table changes")
    p.add_argument("--timing-worlds", type=int, default=2,
                   help="worlds per house size whose decisions are timed in-process (0: none)")
    p.add_argument("--gtsam-check", action="store_true",
                   help="cross-check every episode's final belief against gtsam, as `fg-tea run` does "
                   "(docs/design.md §4.7); off by default here: it changes no row and is most of an "
                   "episode's cost with five objects")
    add_episode_seed_argument(p)
    p.add_argument("--reuse", type=Path, default=None, metavar="CSV",
                   help="another episodes CSV: its rows of this run's jobs are copied instead of "
                   "run, e.g. the one-step planners' episodes of a larger table beside new "
                   "lookahead rows. A row is a job's when its key is the job's, or differs only in "
                   "the paths of generated files (another --out) that have the same name and bytes "
                   "(fg_tea.study.reuse); stderr counts every other row under its reason and the "
                   "jobs left to run")
    add_execution_arguments(p, "episodes.csv")
    p.add_argument("--out", type=out_folder, default=DEFAULT_OUT,
                   help="output folder; each table writes into OUT/TABLE (default: %(default)s)")
    return p


def parse_args(argv=None) -> argparse.Namespace:
    p = build_parser()
    args = p.parse_args(argv)
    if args.worlds < 1:
        p.error("--worlds must be at least 1")
    if args.confirmation_worlds is not None and args.confirmation_worlds < 1:
        p.error(f"--confirmation-worlds: {args.confirmation_worlds}: must be at least 1")
    if args.confirmation_worlds is not None and args.confirmation_first_seed is None:
        p.error("--confirmation-worlds needs --confirmation-first-seed")
    if args.timing_worlds < 0:
        p.error(f"--timing-worlds: {args.timing_worlds}: must be 0 (none) or more")
    if args.reuse is not None:
        if args.reuse.exists() and not args.reuse.is_file():  # a folder, FIFO or device: never opened
            p.error(f"--reuse: {args.reuse}: not a regular file")
        try:
            with args.reuse.open(newline="", encoding="utf-8") as fh:
                header = next(csv.reader(fh), [])
        except (OSError, UnicodeDecodeError, csv.Error) as exc:
            p.error(f"--reuse: {args.reuse}: {getattr(exc, 'strerror', None) or exc}")
        if "key" not in header:
            p.error(f"--reuse: {args.reuse}: not an episodes CSV written by a sweep (no 'key' column)")
    if args.first_seed < 0 or (args.confirmation_first_seed or 0) < 0:
        p.error("world seeds must not be negative")
    for c in args.strengths:
        if not 0.0 <= c <= 1.0:
            p.error(f"--strengths: {c} is outside [0, 1]")
    for n in args.half_pixels:
        if not (n > 0 and math.isfinite(n)):
            p.error(f"--half-pixels: {n} is not a positive pixel count")
    for n in args.related:
        if not 0 <= n <= len(RELATED_ORDER):
            p.error(f"--related: {n} is outside 0..{len(RELATED_ORDER)}")
    if args.derive_worlds < 1:
        p.error(f"--derive-worlds: {args.derive_worlds}: must be at least 1")
    if args.table == "related" and args.looks != "glances":
        p.error(f"--looks: {args.looks}: the related table derives its joint models from the "
                "placement rules beside the factorised model with room glances (--looks glances)")
    for c in args.small_categories:
        if c not in CATEGORIES:
            p.error(f"--small-categories: {c!r} is not an object of the generated houses "
                    f"({', '.join(CATEGORIES)})")
    if args.models is not None:
        if args.table != "houses":
            p.error(f"--models: the {args.table} table has models of its own; --models is for --table houses")
        from fg_tea.model.spec import load_model

        try:
            structures = [load_model(m).structure for m in args.models]
        except InputError as exc:
            p.error(f"--models: {exc}")
        if structures != ["factorised", "joint"]:
            p.error(f"--models: {' '.join(args.models)}: the first must have a factorised belief and the "
                    f"second a joint one (they have {structures[0]} and {structures[1]})")
    for name in args.planners:  # before seed_sets.json is declared or any row copied
        try:
            check_planner(name)   # built-ins, family specs and plug-ins, as the sweep checks them
        except (ValueError, InputError) as exc:
            p.error(f"--planners: {exc}")
    return args


# ---------------------------------------------------------------------------------- the jobs
def detectability_models(out: Path, models: tuple[str, str], half_pixels: float,
                         categories: list[str]) -> tuple[dict[str, str], str]:
    """Model files (paths) and a camera file (path) that set n_50 of `categories` alike, for the
    agent's assumed curve and the camera's (docs/design.md §1.3)."""
    paths = {}
    n50 = f"n_50 = {half_pixels:g} px for {', '.join(categories)}"
    curve = [line for c in categories
             for line in (f"[{{table}}.visibility.categories.{c}]", f"half_pixels = {half_pixels!r}", "")]

    def write(path: Path, head: list[str], table: str) -> str:
        text = "\n".join(head + [line.format(table=table) for line in curve])
        path.parent.mkdir(parents=True, exist_ok=True)
        if not path.exists() or path.read_text() != text:
            atomic_write_text(path, text)
        return str(path)

    for base in models:
        tag = f"{base}_n50_{half_pixels:g}"
        paths[base] = write(out / "models" / f"{tag}.toml",
                            [f"# Written by experiments/compare_at_scale.py: {base} with {n50}",
                             "# (the agent's assumed curve; the camera file beside it sets the camera's).",
                             f'extends = "{base}"', f'name = "{tag}"',
                             f'description = "{base}; {n50}"', ""], "perception")
    camera = load_camera("visibility")
    assert camera.curve is not None  # the bundled visibility camera
    tag = f"visibility_n50_{half_pixels:g}"
    head = [f"# Written by experiments/compare_at_scale.py: the bundled visibility camera with {n50}.",
            f'name = "{tag}"', f'description = "visibility camera; {n50}"', "", "[camera]",
            'detector = "visibility"', "", "[camera.visibility]",
            f"half_pixels = {camera.curve.half_pixels!r}", f"slope = {camera.curve.slope!r}",
            f"max_probability = {camera.curve.max_probability!r}", ""]
    return paths, write(out / "cameras" / f"{tag}.toml", head, "camera")


RELATED_TASK = "make_tea_milk_sugar"


def related_files(out: Path, size: str, count: int, derive_worlds: int) -> tuple[str, str]:
    """(world file, joint model file) of the related table's cell (size, count): the size's
    milk-and-sugar worlds with `count` objects placed by the kettle, and the joint model whose
    relations are derived from that rule by eq. (55) over `derive_worlds` worlds of the same
    size, seeds from :data:`~fg_tea.study.relations.DERIVE_FIRST_SEED` (disjoint from every
    discovery and confirmation set). The model's second line names what it was derived from
    (the world file's digest, the worlds drawn, the seeds, the capacity penalty and the prior
    floor); it is derived again only when that line differs, and the world file is rewritten
    only when its text differs.

    Raises:
        InputError: (``--derive-worlds``) too few worlds to see every relation class of a pair.
    """
    import hashlib
    import json
    import tempfile

    from fg_tea.common.resources import resolve_world
    from fg_tea.model.spec import load_model
    from fg_tea.world.distributions import load_world

    base = json.loads(resolve_world(SIZES[size] + TASKS[RELATED_TASK]).read_text(encoding="utf-8"))
    name = f"{SIZES[size]}{TASKS[RELATED_TASK]}_related_{count}"
    text = json.dumps(related_world(base, count, name), indent=2) + "\n"
    world, model = out / "worlds" / f"{name}.json", out / "models" / f"joint_related_{count}_{size}.toml"
    joint = load_model("joint")
    capacity = next(r.penalty for r in joint.relations if r.kind == "capacity")
    source = (f"# Source: world sha256 {hashlib.sha256(text.encode()).hexdigest()[:16]}, "
              f"{derive_worlds} worlds from seed {DERIVE_FIRST_SEED}, capacity {capacity!r}, "
              f"prior floor {joint.prior_floor!r}.")
    lines = model.read_text(encoding="utf-8").splitlines() if model.is_file() else []
    if len(lines) < 2 or lines[1] != source:
        with tempfile.TemporaryDirectory() as tmp:   # derived before anything is written
            draft = Path(tmp) / world.name
            draft.write_text(text, encoding="utf-8")
            try:
                weights = derive(load_world(draft), derive_worlds, joint.prior_floor,
                                 first_seed=DERIVE_FIRST_SEED)
            except InputError as exc:
                raise InputError("compare_at_scale.py", "--derive-worlds",
                                 f"{derive_worlds}: {name}: {exc.fault}") from None
        body = model_text(name, derive_worlds, weights, capacity,
                          f"experiments/compare_at_scale.py --table related ({count} related "
                          f"objects, {size} houses)", name=f"joint_related_{count}").splitlines()
        atomic_write_text(model, "\n".join(body[:1] + [source] + body[1:]) + "\n")
    if not world.is_file() or world.read_text(encoding="utf-8") != text:
        atomic_write_text(world, text)
    return str(world), str(model)


def check_derivation(out: Path, derive_worlds: int, declare: bool = False) -> None:
    """Refuse a related-table folder whose models were derived from another number of worlds:
    its rows' keys name the model files, not their weights, so mixing the two would pair rows of
    different models under one cell. With `declare`, write ``derivation.json`` if the folder has
    none (before any episode).

    Raises:
        InputError: the folder declares another ``--derive-worlds``.
    """
    import json

    path = out / "derivation.json"
    if path.is_file():
        declared = json.loads(path.read_text(encoding="utf-8")).get("derive_worlds")
        if declared != derive_worlds:
            raise InputError(path, "derive_worlds", f"this folder's models were derived from "
                             f"{declared} worlds, not {derive_worlds}: use that --derive-worlds "
                             "or another --out")
    elif declare:
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, json.dumps({"derive_worlds": derive_worlds,
                                            "first_seed": DERIVE_FIRST_SEED}, indent=2) + "\n")


def strength_knobs(c: float) -> dict[str, float]:
    """World knobs of correlation strength c: 2c/3 on the anchor's site, c/3 in its room."""
    return {"same_site": round(2 * c / 3, 12), "same_room": round(c / 3, 12)}


def compared_models(args) -> tuple[str, str]:
    """The two models of the table: ``--models``, or the ``--looks`` pair."""
    return tuple(args.models) if getattr(args, "models", None) else LOOKS[args.looks]


def model_names(models: tuple[str, ...]) -> tuple[str, ...]:
    """The names rows carry for these model references (a program file's name is its stem)."""
    from fg_tea.model.spec import load_model

    return tuple(load_model(m).name for m in models)


def plan(args, out: Path) -> tuple[list[Job], list[dict]]:
    """The job list and, per job key, the cell it belongs to."""
    models = compared_models(args)
    jobs: list[Job] = []
    cells: list[dict] = []

    def add(batch: list[Job], cell: dict) -> None:
        jobs.extend(batch)
        cells.extend({"key": j.key, **cell} for j in batch)

    if args.table == "houses":
        for size in args.sizes:
            for task in args.tasks:
                world = SIZES[size] + TASKS[task]
                add(plan_sweep([world], args.worlds, list(models), args.planners,
                               first_seed=args.first_seed, env=args.env, task=task,
                               episode_seeds=episode_seed_scheme(args)),
                    {"size": size, "task": task})
    elif args.table == "related":
        for size in args.sizes:
            for count in args.related:
                world, joint = related_files(out, size, count, args.derive_worlds)
                add(plan_sweep([world], args.worlds, [models[0], joint], args.planners,
                               first_seed=args.first_seed, env=args.env, task=RELATED_TASK,
                               episode_seeds=episode_seed_scheme(args)),
                    {"size": size, "related": count})
    else:
        for size in args.sizes:
            for n50 in args.half_pixels:
                files, camera = detectability_models(out, models, n50, args.small_categories)
                for c in args.strengths:
                    add(plan_sweep([SIZES[size]], args.worlds, [files[m] for m in models],
                                   args.planners, first_seed=args.first_seed, env=args.env,
                                   knobs=strength_knobs(c), episode_seeds=episode_seed_scheme(args),
                                   # close looks: the threshold camera, which has no curve
                                   camera=camera if args.looks == "glances" else ""),
                        {"size": size, "half_pixels": n50, "strength": c})
    return jobs, cells


def seed_sets(args) -> list[SeedSet]:
    """The discovery and confirmation sets of a replicated run (empty without one)."""
    if args.confirmation_first_seed is None:
        return []
    sets = [SeedSet("discovery", args.first_seed, args.worlds),
            SeedSet("confirmation", args.confirmation_first_seed,
                    args.confirmation_worlds or args.worlds)]
    check_seed_sets(sets)
    return sets


# ---------------------------------------------------------------------------------- decision time
def decision_times(jobs: list[Job], worlds: int) -> list[dict]:
    """Wall and CPU time (ms) per planner decision, median and 95th percentile, per house size,
    model and planner.

    Runs the first `worlds` worlds of each (world, model, planner) again in this process, timing
    every ``planner.choose``; the episodes are the sweep's own (same seeds), only their clock is
    new.
    """
    from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
    from fg_tea.study.sweep import job_env, job_model, job_world
    from fg_tea.study.frontier import DecisionClock

    first = min(j.world_seed for j in jobs) if jobs else 0
    picked = [j for j in jobs if j.world_seed < first + worlds]
    samples: dict[tuple, list[tuple[float, float]]] = {}
    for job in picked:
        world, model = job_world(job.world, job.knobs), job_model(job.model, job.model_overrides)
        scenario = world.sample(job.world_seed)
        env = job_env(job.env, scenario, env_config_for(model, **dict(job.env_overrides)))
        try:
            runner = EpisodeRunner(scenario, model, env, RunConfig(seed=job.seed, planner=job.planner,
                                                                    max_frames=job.max_frames,
                                                                    task=job.task,
                                                                    gtsam_check=job.gtsam_check))
            clock = DecisionClock(runner.agent.planner)
            try:
                for _ in range(job.max_steps):
                    runner.step()
                    if runner.done:
                        break
            finally:
                samples.setdefault((job.world, job.task, model.name, model.structure, job.planner), []).extend(
                    (wall * 1e3, cpu * 1e3) for wall, cpu in zip(clock.wall, clock.cpu))
        except ValueError:
            pass  # a refusal (dense limit, optimal size): no time to report for this cell
        finally:
            env.close()
    def stat(values: list[float], q: float) -> float | None:
        return round(float(np.quantile(values, q)), 4) if values else None

    return [{"world": w, "task": t, "model": m, "structure": s, "planner": p, "decisions": len(v),
             "median_ms": stat([x for x, _ in v], 0.5), "p95_ms": stat([x for x, _ in v], 0.95),
             "cpu_median_ms": stat([c for _, c in v], 0.5), "cpu_p95_ms": stat([c for _, c in v], 0.95)}
            for (w, t, m, s, p), v in sorted(samples.items())]


# ---------------------------------------------------------------------------------- the report
def _natural(value):
    """Sort key: house sizes small < medium < large, numbers by value, other text by name."""
    if value in SIZES:
        return (0, list(SIZES).index(value), "")
    if isinstance(value, (int, float)):
        return (1, float(value), "")
    return (2, 0.0, str(value))


def house_cell(world: str) -> dict | None:
    """The houses table's cell (size, task) of a world name, or None for another world."""
    for size, base in SIZES.items():
        for task, suffix in TASKS.items():
            if world == base + suffix:
                return {"size": size, "task": task}
    return None


def row_cell(row: dict, table: str, models: tuple[str, ...]) -> dict | None:
    """The cell of an episode row in `table`, or None if the row belongs to no cell of it.

    Rows are matched by what they are, not by the command that ran them: the houses table by
    world name, the detectability table by world size, the model file's n_50 tag (written by
    :func:`detectability_models`) and the world knobs of :func:`strength_knobs`.
    """
    if table == "houses":
        return house_cell(str(row["world"])) if row["model"] in models else None
    if table == "related":
        base, sep, count = str(row["world"]).rpartition("_related_")
        cell = house_cell(base) if sep and count.isdigit() else None
        if cell is None or cell["task"] != RELATED_TASK or \
                row["model"] not in (models[0], f"joint_related_{count}"):
            return None
        return {"size": cell["size"], "related": int(count)}
    base, sep, n50 = str(row["model"]).partition("_n50_")
    size = next((k for k, v in SIZES.items() if v == row["world"]), None)
    if not sep or base not in models or size is None:
        return None
    knobs = dict(kv.split("=") for kv in str(row["knobs"] or "").split(",") if "=" in kv)
    strength = round(float(knobs.get("same_site", 0)) + float(knobs.get("same_room", 0)), 9)
    return {"size": size, "half_pixels": float(n50), "strength": strength}


def merged_times(path: Path, times: list[dict]) -> list[dict]:
    """Earlier decision times in `path`, with this run's measurements replacing theirs."""
    ident = ("world", "task", "model", "structure", "planner")
    earlier = []
    if path.exists():
        with path.open(newline="", encoding="utf-8") as fh:
            earlier = [{k: parse_cell(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    merged = {tuple(t[c] for c in ident): t for t in earlier}
    merged.update({tuple(t[c] for c in ident): t for t in times})
    return sorted(merged.values(), key=lambda t: tuple(str(t[c]) for c in ident))


def cell_of(rows: list[dict], cells: dict[str, dict], columns: tuple[str, ...]) -> list[dict]:
    out = []
    for r in rows:
        cell = cells.get(r["key"])
        if cell is not None:
            out.append({**r, **{c: cell[c] for c in columns}, "belief": r["structure"]})
    return out


def paired(rows: list[dict], columns: tuple[str, ...]) -> list[dict]:
    """joint − factorised per cell and planner, paired world by world."""
    return paired_differences(rows, "belief", "factorised", METRICS + ("success",),
                              by=columns + ("planner",))


def heatmap(diffs: list[dict], row: str, col: str, panel: str | None, path: Path, title: str,
            verdicts: dict[tuple, str] | None = None) -> Path:
    """Mean paired joint − factorised search travel (m) per cell; '*' marks a CI excluding 0.

    With `verdicts` (cell key -> replication verdict, docs/design.md §11.1) a cell is marked
    "established" or "not resolved" under its value instead.
    """
    from matplotlib.figure import Figure

    planners = list(dict.fromkeys(d["planner"] for d in diffs))
    panels = list(dict.fromkeys(d[panel] for d in diffs)) if panel else [None]
    rows_v = sorted(dict.fromkeys(d[row] for d in diffs), key=_natural)
    cols_v = sorted(dict.fromkeys(d[col] for d in diffs), key=_natural)
    fig = Figure(figsize=(3.2 * len(planners) + 1, 2.4 * len(panels) + 0.8), layout="constrained")
    axes = fig.subplots(len(panels), len(planners), squeeze=False)
    values = [d["search_distance"].mean for d in diffs if not math.isnan(d["search_distance"].mean)]
    span = max((abs(v) for v in values), default=1.0) or 1.0
    image = None
    for a, pv in enumerate(panels):
        for b, planner in enumerate(planners):
            ax = axes[a][b]
            grid = [[math.nan] * len(cols_v) for _ in rows_v]
            marks = [[""] * len(cols_v) for _ in rows_v]
            for d in diffs:
                if d["planner"] != planner or (panel and d[panel] != pv):
                    continue
                i, j = rows_v.index(d[row]), cols_v.index(d[col])
                iv = d["search_distance"]
                grid[i][j] = iv.mean
                sig = not math.isnan(iv.low) and (iv.low > 0 or iv.high < 0)
                marks[i][j] = f"{iv.mean:+.2f}{'*' if sig and verdicts is None else ''}"
                if verdicts is not None:
                    key = (d[row], d[col]) + ((d[panel],) if panel else ()) + (planner,)
                    marks[i][j] += "\n" + verdicts.get(key, "")
            image = ax.imshow(grid, cmap="RdBu_r", vmin=-span, vmax=span, aspect="auto")
            for i in range(len(rows_v)):
                for j in range(len(cols_v)):
                    dark = not math.isnan(grid[i][j]) and abs(grid[i][j]) > span / 2
                    ax.text(j, i, marks[i][j], ha="center", va="center", fontsize=8,
                            color="white" if dark else "black")
            ax.set_xticks(range(len(cols_v)), [str(v) for v in cols_v], fontsize=8)
            ax.set_yticks(range(len(rows_v)), [str(v) for v in rows_v], fontsize=8)
            ax.set_xlabel(col, fontsize=8)
            ax.set_ylabel(row, fontsize=8)
            ax.set_title(f"{GAIN_LABEL.get(planner, planner)}" + (f", {panel} {pv}" if panel else ""),
                         fontsize=9)
    if image is not None:
        fig.colorbar(image, ax=axes, shrink=0.8, label="joint − factorised search travel (m)")
    fig.suptitle(title, fontsize=10)
    return save_figure(fig, path)


REGENERATED = " Regenerated since from the rows: 0 new episodes."


def wall_time_line(path: Path, seconds: float, ran: int) -> str:
    """The report's wall-time line: this command's, or, when it ran no episode (a report
    regenerated from the rows), the line of the report it replaces."""
    if not ran and path.is_file():
        for line in path.read_text(encoding="utf-8").splitlines():
            first = line.split(REGENERATED)[0].rstrip()
            if line.startswith("Wall time: ") and "for 0 new episodes" not in first:
                return f"{first}{REGENERATED}"
    return (f"Wall time: {seconds:.0f} s for {ran} new episodes"
            + (f" ({seconds / ran:.2f} s per episode on this machine)" if ran else "") + ".")


def report(args, out: Path, rows: list[dict], cells: dict[str, dict], times: list[dict],
           command: str, seconds: float, ran: int) -> Path:
    columns = {"houses": ("size", "task"), "related": ("size", "related")}.get(
        args.table, ("size", "half_pixels", "strength"))
    tagged = cell_of(rows, cells, columns)
    diffs = paired(tagged, columns)
    order = {p: i for i, p in enumerate(args.planners)}
    rank = {c: {v: i for i, v in enumerate(sorted({d[c] for d in diffs}, key=_natural))} for c in columns}
    diffs.sort(key=lambda d: tuple(rank[c][d[c]] for c in columns) + (order.get(d["planner"], 99),))
    header = list(columns) + ["information gain / planner", "pairs"] + \
        [f"{LABEL[m]}: factorised → joint" for m in METRICS] + \
        [f"{LABEL[m]}: joint − factorised [95 % CI]" for m in METRICS] + ["success: joint − factorised"]
    body = [[d[c] for c in columns] + [GAIN_LABEL.get(d["planner"], d["planner"]), d["pairs"]]
            + [f"{d[m + '_baseline'].mean:.2f} → {d[m + '_other'].mean:.2f}" for m in METRICS]
            + [d[m].fmt(2 if m != "spl" else 3) for m in METRICS] + [d["success"].fmt(3)]
            for d in diffs]
    flat = []
    for d in diffs:
        entry = {c: d[c] for c in columns}
        entry.update(planner=d["planner"], pairs=d["pairs"])
        for m in METRICS + ("success",):
            iv = d[m]
            entry.update({f"{m}_diff": iv.mean, f"{m}_low": iv.low, f"{m}_high": iv.high,
                          f"{m}_factorised": d[m + "_baseline"].mean, f"{m}_joint": d[m + "_other"].mean})
        flat.append(entry)
    write_csv_atomic(out / f"{args.table}_paired.csv", flat)
    sets = read_seed_sets(out)
    replication: list[str] = []
    verdicts = None
    if sets:
        cells_r = replication_cells(tagged, sets, vary="belief", baseline="factorised", other="joint",
                                    by=columns + ("planner",))
        cells_r.sort(key=lambda c: tuple(rank[k].get(c[k], 99) for k in columns)
                     + (order.get(c["planner"], 99),))
        key_of = {"houses": ("size", "task"), "detectability": ("half_pixels", "strength", "size"),
                  "related": ("related", "size")}
        verdicts = {tuple(c[k] for k in key_of[args.table]) + (c["planner"],): c["verdict"]
                    for c in cells_r}
        resolve = resolve_commands(args, cells_r, sets)
        for c in cells_r:
            c["planner"] = GAIN_LABEL.get(c["planner"], c["planner"])
        write_csv_atomic(out / f"{args.table}_replication.csv", replication_rows(cells_r, sets, columns))
        replication = ["", "## Replication: joint − factorised search travel (m)", "",
                       "The table above pools both seed sets; here each is judged on its own.", "",
                       replication_markdown(cells_r, sets, columns + ("planner",))]
        replication += planner_pairs(args, out, tagged, sets, columns, rank) + resolve
    if args.table == "houses":
        png = heatmap(diffs, "size", "task", None, out / f"{args.table}_heatmap.png",
                      "Joint − factorised search travel (m) per house size and task; "
                      + ("replication verdicts (docs/design.md §11.1)" if verdicts
                         else "* 95 % CI excludes 0"), verdicts)
    elif args.table == "related":
        png = heatmap(diffs, "related", "size", None, out / f"{args.table}_heatmap.png",
                      "Joint − factorised search travel (m): objects placed by the kettle "
                      "× house size; " + ("replication verdicts" if verdicts
                                          else "* 95 % CI excludes 0"), verdicts)
    else:
        png = heatmap(diffs, "half_pixels", "strength", "size", out / f"{args.table}_heatmap.png",
                      "Joint − factorised search travel (m): n_50 of the small objects × correlation; "
                      + ("replication verdicts" if verdicts else "* 95 % CI excludes 0"), verdicts)
    summary = summary_table(sorted(tagged, key=lambda r: r["key"]), columns + ("model", "planner"),
                            METRICS + ("clairvoyant_search_travel",))
    n_worlds = len({(r["world"], r["world_seed"]) for r in tagged})
    lines = [f"# Joint vs factorised beliefs at scale: the {args.table} table", "",
             "Reproduce with:", "", f"    {command}", "",
             f"{len(tagged)} episodes over {n_worlds} sampled worlds; every configuration solves the "
             "same worlds with the same seeds. Each cell is the paired difference joint − factorised "
             "(negative travel or inspections, positive SPL: the joint belief did better), mean with "
             "a 95 % Student-t interval over worlds. Information gain: eqs. 10-11/41 (planner "
             "`factorised_efe`) or the exact mutual information of eqs. 38/42 (`mi_efe`); the "
             "baselines `nearest` (distance only) and `greedy` (most probable site) read the "
             "belief's marginals. SPL = clairvoyant ÷ max(search travel, clairvoyant), 0 when an "
             "object was never found (docs/design.md §11).", "",
             wall_time_line(out / f"{args.table}.md", seconds, ran), "",
             "## Paired differences", "", markdown_table(header, body), "",
             f"Heat map: `{png.name}`.", "",
             "## Decision time (ms per decision, in-process: wall and CPU, median and 95th "
             "percentile; earlier runs measured the wall median only)", ""]
    if times:
        def ms(t: dict, key: str) -> str:
            return "–" if t.get(key) in (None, "") else str(t[key])

        lines.append(markdown_table(["world", "task", "model", "structure", "planner", "decisions",
                                     "median ms", "p95 ms", "CPU median ms", "CPU p95 ms"],
                                    [[t["world"], t["task"], t["model"], t["structure"], t["planner"],
                                      t["decisions"], ms(t, "median_ms"), ms(t, "p95_ms"),
                                      ms(t, "cpu_median_ms"), ms(t, "cpu_p95_ms")] for t in times]))
    else:
        lines.append("Not measured (--timing-worlds 0).")
    lines += replication
    lines += ["", "## Means per cell, model and planner", "",
              summary_markdown(summary, columns + ("model", "planner"),
                               METRICS + ("clairvoyant_search_travel",)), ""]
    return atomic_write_text(out / f"{args.table}.md", "\n".join(lines))


#: Planners in the order their pairs are taken (the later one minus the earlier one).
PLANNER_ORDER = ("factorised_efe", "mi_efe", "efe", "nearest", "greedy", "lookahead")


def planner_pairs(args, out: Path, tagged: list[dict], sets: list[SeedSet], columns: tuple[str, ...],
                  rank: dict) -> list[str]:
    """Every pair of planners in every cell and belief: the later planner's search travel minus
    the earlier one's, judged on each seed set, adjusted over all the pairs and cells together;
    written to ``<table>_planner_replication.csv`` and returned as report lines."""
    present = sorted({r["planner"] for r in tagged},
                     key=lambda p: (PLANNER_ORDER.index(p) if p in PLANNER_ORDER else 99, p))
    cells: list[dict] = []
    for a, b in itertools.combinations(present, 2):
        for c in replication_cells(tagged, sets, vary="planner", baseline=a, other=b,
                                   by=columns + ("structure",)):
            c["planner"] = f"{GAIN_LABEL.get(b, b)} − {GAIN_LABEL.get(a, a)}"
            cells.append(c)
    if not cells:
        return []
    adjust(cells, sets)
    cells.sort(key=lambda c: tuple(rank[k].get(c[k], 99) for k in columns) + (c["structure"], c["planner"]))
    write_csv_atomic(out / f"{args.table}_planner_replication.csv",
                     replication_rows(cells, sets, columns + ("structure",)))
    return ["", "## Replication: one planner against another, per belief (search travel, m)", "",
            "Each cell is the paired difference of two planners' search travel on the same worlds "
            "and belief (negative: the first named searched less).", "",
            replication_markdown(cells, sets, columns + ("structure", "planner"), compared="planners")]


#: First world seed of the confirmation sets proposed below: no committed table has used it.
FRESH_FIRST_SEED = 30000


def resolve_commands(args, cells: list[dict], sets: list[SeedSet]) -> list[str]:
    """Report lines: for every cell not established whose confirmation set is smaller than the
    discovery set says it needs (``pairs_needed``), the command that runs a confirmation set of
    that size for that cell alone on a Ray cluster, the discovery rows copied from this table
    (``--reuse``). The cell's raw planner name is expected (before relabelling)."""
    table_csv = Path(args.out) / args.table / "episodes.csv"
    lines = []
    for c in cells:
        need, have = c.get("pairs_needed"), c[sets[-1].name]["pairs"]
        if c["verdict"] == ESTABLISHED or not need or need <= have:
            continue
        flags = ["--table", args.table] + (["--looks", args.looks] if args.looks != "glances" else [])
        flags += ["--models", *args.models] if getattr(args, "models", None) else []
        flags += ["--worlds", str(sets[0].count)] + (
            ["--first-seed", str(sets[0].first)] if sets[0].first else [])
        flags += ["--confirmation-first-seed", str(FRESH_FIRST_SEED), "--confirmation-worlds",
                  str(need), "--sizes", str(c["size"])]
        if args.table == "houses":
            flags += ["--tasks", str(c["task"])]
            tag = f"{c['size']}_{c['task']}_{c['planner']}"
        elif args.table == "related":
            flags += ["--related", str(c["related"])] + (
                ["--derive-worlds", str(args.derive_worlds)] if args.derive_worlds != DEFAULT_DERIVE_WORLDS else [])
            tag = f"{c['size']}_related_{c['related']}_{c['planner']}"
        else:
            flags += ["--half-pixels", f"{float(c['half_pixels']):g}", "--strengths",
                      f"{float(c['strength']):g}"]
            if args.small_categories != ["teabag"]:
                flags += ["--small-categories", *args.small_categories]
            tag = f"{c['size']}_n50_{float(c['half_pixels']):g}_c{float(c['strength']):g}_{c['planner']}"
        # The discovery rows are the new run's jobs: the detectability and related tables' files
        # are written again under the new --out, and rows match them by name and content.
        flags += ["--planners", str(c["planner"]), "--timing-worlds", "0", "--reuse", str(table_csv)]
        flags += ["--env", args.env] if args.env != "pybullet" else []
        flags += ["--gtsam-check"] if args.gtsam_check else []
        flags += ["--episode-seeds", episode_seed_scheme(args), "--executor", "ray", "--address",
                  "auto", "--out", f"runs/resolve/{Path(args.out).name}/{tag}"]
        lines.append(shlex.join(["python", "experiments/compare_at_scale.py", *flags]))
    if not lines:
        return []
    return ["", "## To resolve the rest on a Ray cluster", "",
            f"Each cell not established whose confirmation set is smaller than its \"pairs to "
            f"resolve\": a confirmation set of that many worlds, seeds from {FRESH_FIRST_SEED} "
            "(not used by any committed table; any range disjoint from the discovery set will do, "
            "declared before the run), this table's discovery rows copied (--reuse). "
            "One cell per folder: each report's Holm adjustment then covers its one cell, so "
            "claims from several of these runs are judged on their confirmation p values "
            "adjusted together (Holm over the cells run; docs/design.md §11.1). Ray set-up: "
            "docs/how-to/sweep-on-ray.md.", "", *[f"    {line}" for line in lines]]


def replication_rows(cells: list[dict], sets: list[SeedSet], columns: tuple[str, ...]) -> list[dict]:
    """The replication table as CSV rows: per cell and seed set, every statistic."""
    out = []
    for c in cells:
        row = {k: c[k] for k in columns + ("planner",)}
        for s in sets:
            e = c[s.name]
            row.update({f"{s.name}_first_seed": s.first, f"{s.name}_worlds": s.count,
                        f"{s.name}_pairs": e["pairs"], f"{s.name}_diff": e["difference"].mean,
                        f"{s.name}_low": e["difference"].low, f"{s.name}_high": e["difference"].high,
                        f"{s.name}_adjusted_low": e["adjusted"].low,
                        f"{s.name}_adjusted_high": e["adjusted"].high, f"{s.name}_p": e["p"],
                        f"{s.name}_p_holm": e["p_holm"], f"{s.name}_share_differ": e["share_differ"],
                        f"{s.name}_diff_if_differ": e["if_differ"].mean,
                        # the difference in per cent of the baseline's mean on the same worlds
                        f"{s.name}_baseline": e["baseline"],
                        **{f"{s.name}_{k}_pct": 100.0 * v / e["baseline"] if e["baseline"] else math.nan
                           for k, v in (("diff", e["difference"].mean), ("low", e["difference"].low),
                                        ("high", e["difference"].high))}})
        row.update(pairs_needed=c["pairs_needed"], resolve_m=c["resolve"], verdict=c["verdict"])
        out.append(row)
    return out


def main(argv=None) -> int:
    args = parse_args(argv)
    out = Path(args.out) / args.table
    sets = seed_sets(args)
    if args.table == "related":  # before any model is derived again
        check_derivation(out, args.derive_worlds)
    jobs = [replace(j, gtsam_check=args.gtsam_check) for s in (sets or [None])
            for j in plan(args if s is None else argparse.Namespace(
                **{**vars(args), "first_seed": s.first, "worlds": s.count}), out)[0]]
    csv_path = out / "episodes.csv"
    # One episode-seed scheme per table, checked before anything is declared, copied or run.
    check_resumable(jobs, csv_path, args.resume)
    found = None
    if args.reuse is not None:  # its rows as this run spells their keys, checked the same way
        found = match_reuse(args.reuse, jobs)
        check_episode_seeds(jobs, found.keys, args.reuse)
    if sets:  # declared before any episode runs; a folder keeps its declaration
        declare_seed_sets(out, sets)
    if args.table == "related":
        check_derivation(out, args.derive_worlds, declare=True)
    out.mkdir(parents=True, exist_ok=True)
    if found is not None:
        copy_rows(found, jobs, csv_path, args.resume)
    before = 0
    if args.resume and csv_path.exists():
        with csv_path.open(newline="", encoding="utf-8") as fh:
            before = max(sum(1 for _ in csv.reader(fh)) - 1, 0)
    t0 = time.perf_counter()
    run_sweep(jobs, csv_path, args.executor, workers=args.workers or None,
                     address=args.address, resume=args.resume, label=f"compare_at_scale {args.table}")
    seconds = time.perf_counter() - t0
    every = read_rows(csv_path)
    ran = max(len(every) - before, 0)  # rows this command added
    command = shlex.join(["python", "experiments/compare_at_scale.py",
                          *recorded_argv(sys.argv[1:] if argv is None else argv, args)])
    # One report for every cell in the CSV, whichever command ran it (see the module doc).
    models = model_names(tuple(args.models)) if args.models else LOOKS[args.looks]
    rows = [r for r in every if row_cell(r, args.table, models)]
    cell_map = {r["key"]: row_cell(r, args.table, models) for r in rows}
    log = out / "commands.txt"
    commands = log.read_text(encoding="utf-8").splitlines() if log.exists() else []
    if ran and command not in commands:
        commands.append(command)
        atomic_write_text(log, "\n".join(commands) + "\n")
    commands = commands or [command]
    times = decision_times(jobs, args.timing_worlds) if args.timing_worlds > 0 else []
    times = merged_times(out / "decision_times.csv", times)
    if times:
        write_csv_atomic(out / "decision_times.csv", times)
    path = report(args, out, rows, cell_map, times, "\n    ".join(commands), seconds, ran)
    print(f"episodes: {csv_path} ({len(rows)} rows); report: {path}")
    return 0


if __name__ == "__main__":
    run_script(main, "compare_at_scale.py")
