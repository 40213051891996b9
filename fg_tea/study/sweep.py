"""Sweeps: many seeded episodes over sampled worlds, models and planners, one CSV row each.

This module answers the experiment question ("which model searches better, and why?",
docs/design.md §11) at the level of single episodes; :mod:`fg_tea.study.analysis`
turns the rows into tables and plots.

- A :class:`Job` names one episode completely: world distribution and its knobs, world seed,
  model (and overrides), planner, episode seed, environment (and overrides). Its :attr:`Job.key`
  is a stable string, so a CSV row can always be traced back to the job that made it.
- :func:`plan_sweep` builds **paired** job lists: every configuration solves the same world seeds
  (and the same episode seeds), so differences between configurations can be taken world by world.
- :func:`run_job` runs one headless episode and returns its row: every scalar metric of the log
  (:func:`fg_tea.episode.metrics.score`) flattened, plus the configuration, the world's parameters
  and its hidden truth. Rows never hold wall-clock time, so a sweep's CSV is a pure function of
  its jobs. Episodes refused by a planner's size limit (the optimal planner's sites and truths,
  the lookahead planner's correlated joint) are recorded with reason
  ``"refused: ..."`` instead of stopping the sweep, and episodes still running after
  ``Job.max_steps`` runner steps (a planner that re-inspects, in place, a site it has already
  ruled out never reaches the frame limit) with reason ``"step_limit: ..."``.
- :func:`run_sweep` runs a job list on a backend (``"serial"``, ``"process"``: a process pool
  over all cores, the default, or ``"ray"``: Ray tasks on a local instance or a cluster), appends
  each row to the CSV as it arrives (flushed), skips jobs whose key is already in the CSV
  (resume; a truncated last line left by a crash is dropped), reports progress on stderr, and
  finally rewrites the CSV sorted by key, so every backend writes the same bytes.

The ``ray`` backend ships each job as a Ray task calling :func:`run_job` by reference, so on a
cluster (``address="auto"`` or ``"ray://head:10001"``) every worker node needs the same fg_tea
installed (the ``ray`` extra); without an address a local instance is started with one
CPU per worker and shut down afterwards. Nothing in a row depends on where it ran.

Per-step belief entropy is kept as a list column, ``entropy_trace``: the summed location entropy
(nats, eq. 7) of the searched objects at the start and after each inspection, joined by ``;``.
When :mod:`fg_tea.episode.quality` is importable, the scalars of its ``quality_summary(events, world)``
(KL of the factorised from the joint posterior on the same evidence, Brier scores, expected
calibration error) are added as ``quality_*`` columns.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

from fg_tea.common.errors import InputError, PlannerRefused
from fg_tea.study.cost import ESTIMATE_ABOVE, CostEstimate
from fg_tea.study.executors import _BACKENDS
from fg_tea.study.program_jobs import check_program_graphs
from fg_tea.study.rows import CsvSink, read_rows, sweep_progress
from fg_tea.study.seeds import EPISODE_SEEDS, check_episode_seeds, episode_seed

BACKENDS = ("serial", "process", "ray")
ENVIRONMENTS = ("pybullet", "fake")
WORLD_KNOBS = ("prior_violation", "same_site", "same_room")
#: Reason prefix of episodes the optimal planner declined (too many open sites for its DP).
REFUSED = "refused: "
#: Reason prefix of episodes stopped by the sweep's step limit (see :class:`Job`).
STEP_LIMIT = "step_limit: "
#: Columns of a row that describe the configuration (everything else is an outcome).
CONFIG_COLUMNS = ("key", "world", "world_seed", "seed", "knobs", "model", "model_ref", "structure",
                  "planner", "env", "task", "model_overrides", "env_overrides")
_CLI = "<sweep>"


def _scalar(value: Any, what: str) -> Any:
    if isinstance(value, bool) or isinstance(value, (int, float, str)):
        return value
    raise InputError(_CLI, what, f"expected a number, string or boolean, got {type(value).__name__}")


def _pairs(value: Mapping[str, Any] | Iterable[tuple[str, Any]] | None, what: str
           ) -> tuple[tuple[str, Any], ...]:
    items = value.items() if isinstance(value, Mapping) else (value or ())
    return tuple(sorted((str(k), _scalar(v, f"{what}.{k}")) for k, v in items))


def _fmt(value: Any) -> str:
    return repr(value) if isinstance(value, float) else str(value)


def _joined(pairs: Sequence[tuple[str, Any]]) -> str:
    return ",".join(f"{k}={_fmt(v)}" for k, v in pairs)


@dataclass(frozen=True)
class Job:
    """One episode of a sweep, named completely.

    Args:
        world: a world distribution (bundled name such as ``"correlated"``, or a JSON path).
        world_seed: the seed of the sampled world (``WorldDistribution.sample``).
        model: a model (bundled name, bundled ablation name such as ``"no_epistemic"``, or a path).
        planner: a planner name: built-in (:func:`fg_tea.planning.planner_names`), an entry point
            of the group ``fg_tea.planners``, or ``module:attribute``
            (:mod:`fg_tea.planning.plugins`). Only this string travels to worker processes;
            each builds its own planner from it.
        seed: the episode seed (environment RNG, random planner); defaults to `world_seed`.
        knobs: world knobs (``prior_violation``, ``same_site``, ``same_room``), values in [0, 1].
        model_overrides: ``Model`` fields to replace, e.g. ``{"miss_likelihood": 0.2}``.
        env_overrides: ``EnvConfig`` fields to replace, e.g. ``{"detection_miss_rate": 0.2}``.
        env: ``"pybullet"`` (the PyBullet house, headless) or ``"fake"`` (oracle perception).
        max_frames: the episode's frame limit.
        max_steps: the sweep's own limit on runner steps. The frame limit cannot end an episode
            whose planner re-inspects the site it stands at (zero travel, zero frames) forever;
            such an episode is stopped here and recorded with reason ``"step_limit: ..."``.
        task: the task graph (bundled name or path), ``make_tea`` by default.
        gtsam_check: cross-check the final belief against gtsam (``RunConfig.gtsam_check``). It
            changes only the log's ``gtsam_agreement``, never a row, so it is not part of the key.
        camera: the environment's camera (bundled name such as ``"threshold"``, or a path;
            ``fg_tea.env.camera``); empty: the bundled camera of the detector the model assumes.

    Mappings are stored as sorted tuples of pairs, so jobs are hashable and keys are stable.
    """

    world: str
    world_seed: int
    model: str = "factorised"
    planner: str = "efe"
    seed: int | None = None
    knobs: tuple[tuple[str, float], ...] = ()
    model_overrides: tuple[tuple[str, Any], ...] = ()
    env_overrides: tuple[tuple[str, Any], ...] = ()
    env: str = "pybullet"
    max_frames: int = 50_000
    max_steps: int = 2_000
    task: str = "make_tea"
    gtsam_check: bool = True
    camera: str = ""

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "world", str(self.world))
        set_(self, "model", str(self.model))
        set_(self, "camera", str(self.camera or ""))
        set_(self, "world_seed", int(self.world_seed))
        set_(self, "seed", int(self.world_seed if self.seed is None else self.seed))
        knobs = _pairs(self.knobs, "knobs")
        for name, value in knobs:
            if name not in WORLD_KNOBS:
                raise InputError(_CLI, f"knobs.{name}", f"unknown world knob (known: {', '.join(WORLD_KNOBS)})")
            if isinstance(value, (bool, str)) or not 0.0 <= float(value) <= 1.0:
                raise InputError(_CLI, f"knobs.{name}", f"expected a probability in [0, 1], got {value!r}")
        set_(self, "knobs", tuple((k, float(v)) for k, v in knobs))
        set_(self, "model_overrides", _pairs(self.model_overrides, "model_overrides"))
        set_(self, "env_overrides", _pairs(self.env_overrides, "env_overrides"))

    @property
    def key(self) -> str:
        """A stable, human-readable identifier: equal keys mean equal jobs (and equal rows)."""
        parts = [f"world={self.world}", f"ws={self.world_seed:06d}"]
        if self.knobs:
            parts.append(f"knobs={_joined(self.knobs)}")
        parts.append(f"model={self.model}")
        if self.model_overrides:
            parts.append(f"mo={_joined(self.model_overrides)}")
        parts += [f"planner={self.planner}", f"seed={self.seed:06d}"]
        if self.env != "pybullet":
            parts.append(f"env={self.env}")
        if self.camera:
            parts.append(f"camera={self.camera}")
        if self.env_overrides:
            parts.append(f"eo={_joined(self.env_overrides)}")
        if self.max_frames != 50_000:
            parts.append(f"frames={self.max_frames}")
        if self.max_steps != 2_000:
            parts.append(f"steps={self.max_steps}")
        if self.task != "make_tea":
            parts.append(f"task={self.task}")
        return "|".join(parts)


# ---------------------------------------------------------------------------------- resolving
def ablation_names() -> tuple[str, ...]:
    """Names of the bundled ablation models (``models/ablations/*.toml``), sorted."""
    from fg_tea.common.resources import bundled_names

    return tuple(bundled_names("ablations"))


def model_names() -> tuple[str, ...]:
    """Names of the bundled models (``models/*.toml``), sorted."""
    from fg_tea.common.resources import bundled_names

    return tuple(bundled_names("models"))


def world_names() -> tuple[str, ...]:
    """Names of the bundled world distributions (``scenarios/worlds/*.json``), sorted."""
    from fg_tea.common.resources import bundled_names

    return tuple(bundled_names("worlds"))


def _unknown(option: str, what: str, ref: str, exc: InputError) -> InputError:
    file = "<command line>" if option.startswith("--") else _CLI
    return InputError(file, option, f"unknown {what} {ref!r}: {exc.fault}")


def world_path(ref: str, option: str = "world") -> Path:
    """The file of a world reference: a bundled world distribution or a path.

    Raises:
        InputError: naming `option`, for a bare name that is no file and no bundled world.
    """
    from fg_tea.common.resources import resolve_world

    try:
        return resolve_world(ref)
    except InputError as exc:
        raise _unknown(option, "world", ref, exc) from None


def model_path(ref: str, option: str = "model") -> Path:
    """The file of a model reference: a bundled model, a bundled ablation, or a path.

    Raises:
        InputError: naming `option`, for a bare name that is no file, model or ablation.
    """
    from fg_tea.common.resources import resolve_model

    try:
        return resolve_model(ref)
    except InputError as exc:
        raise _unknown(option, "model", ref, exc) from None


@lru_cache(maxsize=64)
def job_world(ref: str, knobs: tuple[tuple[str, float], ...]):
    """The world distribution a job names (bundled name or path), with its knobs set (cached)."""
    from fg_tea.world.distributions import load_world

    return load_world(ref).with_knobs(**dict(knobs))


@lru_cache(maxsize=64)
def job_model(ref: str, overrides: tuple[tuple[str, Any], ...]):
    """The model a job names (bundled name, path or program), with its overrides applied (cached)."""
    from fg_tea.model.spec import load_model

    model = load_model(model_path(ref))
    return model.with_overrides(**dict(overrides)) if overrides else model


def check_jobs(jobs: Sequence[Job]) -> None:
    """Check every world, model, planner, environment and override a job list names.

    Raises:
        InputError: naming the first unknown world or model (file not found or invalid), unknown
            planner or environment, unknown override field, or invalid knob combination.
    """
    from fg_tea.env.base import EnvConfig
    from fg_tea.model.spec import Model
    from fg_tea.common.resources import is_program_ref
    from fg_tea.planning import check_planner

    env_fields = {f.name for f in dataclasses.fields(EnvConfig)}
    model_fields = {f.name for f in dataclasses.fields(Model)} - {"name", "source"}
    seen: set = set()
    for job in jobs:
        if ("planner", job.planner) not in seen:  # built-in, entry point or module:attribute
            seen.add(("planner", job.planner))
            check_planner(job.planner)
        if job.env not in ENVIRONMENTS:
            raise InputError(_CLI, "env", f"unknown environment {job.env!r} (known: {', '.join(ENVIRONMENTS)})")
        for name, _ in job.env_overrides:
            if name not in env_fields:
                raise InputError(_CLI, f"env_overrides.{name}", "not a field of EnvConfig")
        for name, _ in job.model_overrides:
            if name not in model_fields:
                raise InputError(_CLI, f"model_overrides.{name}", "not an overridable field of Model")
        if (job.world, job.knobs) not in seen:
            seen.add((job.world, job.knobs))
            if not world_path(job.world).exists():
                raise InputError(_CLI, "world", f"unknown world {job.world!r}: not a file or a bundled "
                                 f"world distribution ({', '.join(world_names())})")
            world = job_world(job.world, job.knobs)
            for rule in world.co_location:
                if rule.same_site + rule.same_room > 1.0 + 1e-12:
                    raise InputError(world.source, "knobs", f"same_site + same_room of {rule.object!r} "
                                     f"exceeds 1 ({rule.same_site} + {rule.same_room})")
        if (job.model, job.model_overrides) not in seen:
            seen.add((job.model, job.model_overrides))
            if not (is_program_ref(job.model) or model_path(job.model).exists()):
                raise InputError(_CLI, "model", f"unknown model {job.model!r}: not a file, a bundled model "
                                 f"({', '.join(model_names())}) or a bundled ablation "
                                 f"({', '.join(ablation_names())})")
            job_model(job.model, job.model_overrides)
        if job.camera and ("camera", job.camera) not in seen:
            from fg_tea.env.camera import load_camera

            seen.add(("camera", job.camera))
            load_camera(job.camera).env_config(**dict(job.env_overrides))
    check_program_graphs(jobs, job_world, job_model)  # a program's faults and budget, before any episode


def plan_sweep(worlds: Sequence[str], n_worlds: int, models: Sequence[str], planners: Sequence[str], *,
               first_seed: int = 0, knobs: Mapping[str, float] | None = None,
               model_overrides: Mapping[str, Any] | None = None,
               env_overrides: Mapping[str, Any] | None = None, env: str = "pybullet",
               max_frames: int = 50_000, max_steps: int = 2_000, task: str = "make_tea",
               camera: str = "", episode_seeds: str = "independent") -> list[Job]:
    """The paired job list: every (world, model, planner) solves world seeds first_seed.. first_seed+n-1.

    Paired configurations share the episode seed, so they also share sensor noise draws as far
    as their action sequences agree. With ``episode_seeds = "independent"`` (the default) the
    episode seed comes from :func:`episode_seed`, a stream of its own per world distribution;
    ``"world"`` (the scheme of the tables committed before it was the default) uses the world
    seed itself, so world seed w draws the same detector noise in every distribution, from the
    same numbers that placed its objects. For grids over knobs or overrides, call once per grid
    point and concatenate (keys stay distinct).

    Args:
        worlds: world distributions (names or paths).
        n_worlds: worlds per distribution (>= 1).
        models: model references.
        planners: planner names.
        first_seed: the first world seed.
        knobs: world knobs applied to every job.
        model_overrides: model fields replaced in every job.
        env_overrides: environment fields replaced in every job.
        env: ``"pybullet"`` or ``"fake"``.
        max_frames: the frame limit of each episode.
        max_steps: the sweep's step limit of each episode (see :class:`Job`).
        task: the task graph every job runs.
        camera: the camera of every job (see :class:`Job`); empty: each model's default.
        episode_seeds: ``"world"`` or ``"independent"`` (above).

    Returns:
        Jobs ordered by world, world seed, model, planner.

    Raises:
        InputError: n_worlds < 1, an empty list of worlds, models or planners, or an unknown
            episode-seed scheme.
    """
    if episode_seeds not in EPISODE_SEEDS:
        raise InputError(_CLI, "episode_seeds", f"expected one of {', '.join(EPISODE_SEEDS)}, "
                         f"got {episode_seeds!r}")
    if n_worlds < 1:
        raise InputError(_CLI, "n_worlds", f"expected at least 1 world, got {n_worlds}")
    for name, values in (("worlds", worlds), ("models", models), ("planners", planners)):
        if not values:
            raise InputError(_CLI, name, "expected at least one")
    return [Job(world=w, world_seed=s, model=m, planner=p, knobs=_pairs(knobs, "knobs"),
                model_overrides=_pairs(model_overrides, "model_overrides"),
                env_overrides=_pairs(env_overrides, "env_overrides"),
                env=env, max_frames=max_frames, max_steps=max_steps, task=task, camera=camera,
                seed=episode_seed(w, s) if episode_seeds == "independent" else None)
            for w in worlds for s in range(first_seed, first_seed + n_worlds)
            for m in models for p in planners]


# ---------------------------------------------------------------------------------- one episode
def entropy_trace(events: Sequence[Mapping]) -> list[float]:
    """Summed location entropy (nats) of the searched objects at the start and after each inspection.

    An object's entropy is updated by each observation that considered it (``entropy_after``);
    objects resolved earlier keep their last value.
    """
    start = next((e for e in events if e.get("event") == "episode_start"), None)
    if start is None:
        return []
    searched = list(start.get("searched") or start.get("objects", []))
    current = {o: float(start["belief"]["entropy"][o]) for o in searched}
    trace = [sum(current.values())]
    for e in events:
        if e.get("event") == "observation":
            for o, h in e.get("entropy_after", {}).items():
                if o in current:
                    current[o] = float(h)
            trace.append(sum(current.values()))
    return trace


def flatten_metrics(metrics: Mapping[str, Any]) -> dict[str, Any]:
    """Scalar metrics as they are; dicts of scalars as ``name_key`` columns; lists joined by ``;``.

    Nested structures (such as ``goal_conditions``) are left out: they are in the log.
    """
    def is_scalar(v: Any) -> bool:
        return v is None or isinstance(v, (bool, int, float, str))

    out: dict[str, Any] = {}
    for name, value in metrics.items():
        if is_scalar(value):
            out[name] = value
        elif isinstance(value, (list, tuple)) and all(is_scalar(v) for v in value):
            out[name] = ";".join(_fmt(v) for v in value)
        elif isinstance(value, Mapping) and all(is_scalar(v) for v in value.values()):
            for sub, v in sorted(value.items()):
                out[f"{name}_{sub}"] = v
    return out


def _quality_columns(events: Sequence[Mapping], scenario, overrides: tuple[tuple[str, Any], ...]
                     ) -> dict[str, Any]:
    """``quality_*`` columns from :func:`fg_tea.episode.quality.quality_summary`, when that module exists.

    The KL references (the bundled factorised and joint models) get the job's model overrides, so
    they assume the same detector as the agent.
    """
    try:
        from fg_tea.episode import quality
    except ImportError:
        return {}
    hook = getattr(quality, "quality_summary", None)
    if hook is None:
        return {}
    values = hook(events, scenario, factorised_model=job_model("factorised", overrides),
                  joint_model=job_model("joint", overrides))
    return {f"quality_{k}": v for k, v in flatten_metrics(values).items()}


def job_env(kind: str, scenario, config):
    """A fresh environment of `kind` (``"fake"`` or ``"pybullet"``) over `scenario`."""
    if kind == "fake":
        from fg_tea.env.fake import FakeHouse

        return FakeHouse(scenario, config)
    from fg_tea.env.house import PyBulletHouse

    return PyBulletHouse(scenario, config)


def run_job(job: Job, log_path: str | Path | None = None) -> dict[str, Any]:
    """Run one headless episode; return its CSV row (configuration, world, truth, metrics).

    With `log_path`, the episode's log is also written there, event by event (the explorer's
    pages of a comparison; a sweep keeps its logs in memory only).

    Raises:
        InputError: the job names an unknown world or model.
        ValueError: a fault other than a planner's size limit (a bug, not a result).
    """
    from fg_tea.episode.metrics import score
    from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for

    world = job_world(job.world, job.knobs)
    model = job_model(job.model, job.model_overrides)
    scenario = world.sample(job.world_seed)
    config = env_config_for(model, job.camera or None, **dict(job.env_overrides))
    env = job_env(job.env, scenario, config)
    seed = job.world_seed if job.seed is None else job.seed  # Job fills it in; for the type checker
    runner = None
    stopped = None
    from fg_tea.episode.log import EventLog

    log = EventLog(log_path) if log_path is not None else None
    try:
        runner = EpisodeRunner(scenario, model, env, RunConfig(seed=seed, planner=job.planner,
                                                                max_frames=job.max_frames,
                                                                task=job.task,
                                                                gtsam_check=job.gtsam_check),
                               log, world=job.world)
        runner.start()  # the prior; max_steps counts the steps that carry out actions
        for _ in range(job.max_steps):
            runner.step()
            if runner.done:
                break
        else:
            stopped = (f"{STEP_LIMIT}not finished after {job.max_steps} steps "
                       f"(frame {runner.state.frame})")
    except PlannerRefused as exc:  # a row that says so, and the sweep goes on
        stopped = f"{REFUSED}{exc.kind}: " + " ".join(str(exc).split())
    finally:
        env.close()
        if log is not None:
            log.close()
    events = runner.events if runner is not None else []
    metrics = score(events)
    if stopped is not None:
        metrics.update(success=False, reason=stopped)
    row: dict[str, Any] = {
        "key": job.key, "world": world.name, "world_seed": job.world_seed, "seed": job.seed,
        "knobs": _joined(job.knobs), "model": model.name, "model_ref": job.model,
        "structure": model.structure, "planner": job.planner, "env": job.env, "task": job.task,
        "model_overrides": _joined(job.model_overrides), "env_overrides": _joined(job.env_overrides),
        "prior_violation": world.prior_violation, "violation": world.violation,
    }
    row.update(world.house_columns(job.world_seed))  # generated worlds: which house (none otherwise)
    for rule in world.co_location:
        row[f"same_site_{rule.object}_{rule.anchor}"] = rule.same_site
        row[f"same_room_{rule.object}_{rule.anchor}"] = rule.same_room
    row["miss_likelihood"] = model.miss_likelihood
    row["detection_miss_rate"] = float(getattr(config, "detection_miss_rate", 0.0))
    for spec in scenario.objects:
        row[f"true_site_{spec.name}"] = spec.true_site
    for spec in scenario.objects:
        for state, value in sorted(spec.hidden_state_truth.items()):
            row[f"truth_{spec.name}.{state}"] = bool(value)
    row.update(flatten_metrics(metrics))
    row["entropy_trace"] = ";".join(repr(round(h, 6)) for h in entropy_trace(events))
    if events:  # a planner that refused at construction leaves no log to re-score
        row.update(_quality_columns(events, scenario, job.model_overrides))
    return row


def run_job_timed(job: Job) -> tuple[dict[str, Any], float]:
    """:func:`run_job` and the CPU seconds it took in this process (for the cost estimate,
    :mod:`fg_tea.study.cost`). A module-level function, so process pools (pickle) and Ray (by
    reference) ship it as they ship ``run_job``."""
    start = time.process_time()
    row = run_job(job)
    return row, time.process_time() - start


def add_execution_arguments(parser, csv_name: str) -> None:
    """Add the options every sweep shares to an argparse parser: where and how jobs run.

    ``--executor`` (``--backend``, its deprecated alias), ``--address``, ``--workers``, ``--env``
    and ``--resume/--no-resume``, with `csv_name` (e.g. ``episodes.csv``) named in the resume help.
    The executor lands in ``args.executor``.
    """
    from fg_tea.common.options import DeprecatedAlias

    parser.add_argument("--executor", choices=BACKENDS, default="process",
                        help="job runner: serial, a process pool over every core, or Ray "
                        "(default: %(default)s)")
    parser.add_argument("--backend", dest="executor", choices=BACKENDS, action=DeprecatedAlias,
                        new="--executor")
    parser.add_argument("--address", default=None,
                        help="Ray cluster address: HOST:PORT, ray://HOST:PORT, or auto on a node of a "
                        "running cluster (default: a local Ray instance); a cluster, one machine or "
                        "several: docs/how-to/sweep-on-ray.md")
    parser.add_argument("--workers", type=int, default=0,
                        help="processes or local Ray CPUs, 0 for every core (default: %(default)s)")
    parser.add_argument("--env", choices=ENVIRONMENTS, default="pybullet",
                        help="PyBullet house or the fake oracle house (default: %(default)s)")
    parser.add_argument("--resume", action=argparse.BooleanOptionalAction, default=True,
                        help=f"skip episodes already in OUT/{csv_name} (default: on; --no-resume "
                        "starts afresh)")
    estimate = (f"A run of more than {ESTIMATE_ABOVE:,} episodes first says on stderr how many it will run, "
                "then, once its first few are back, its estimated CPU time (from their timing); Ctrl-C "
                "stops it and the same command resumes it.")
    parser.epilog = " ".join(filter(None, [parser.epilog, estimate]))


def run_sweep(jobs: Sequence[Job], csv_path: str | Path, backend: str = "process", *,
              workers: int | None = None, address: str | None = None, resume: bool = True,
              progress: bool = True, label: str = "sweep") -> list[dict[str, Any]]:
    """Run a job list, appending rows to `csv_path`; return the planned jobs' rows, sorted by key.

    Args:
        jobs: the episodes (duplicates by key are run once).
        csv_path: the sweep CSV; rows are appended as they finish and the file is finally
            rewritten sorted by key.
        backend: ``"serial"``, ``"process"`` (a spawn-context process pool) or ``"ray"``.
        workers: processes (or Ray CPUs for a local instance); None or 0 = every core.
        address: a Ray cluster address (``ray`` backend; None starts a local instance).
        resume: skip jobs whose key is already in the CSV; False discards the existing CSV.
        progress: report progress on stderr; with more than :data:`ESTIMATE_ABOVE` jobs to run,
            their number first and then their estimated CPU time (:mod:`fg_tea.study.cost`).
        label: the progress line's prefix.

    Returns:
        The rows of the planned jobs as read back from the CSV (typed by :func:`parse_cell`).
        Rows of other jobs already in the CSV stay in the file but are not returned.

    Raises:
        InputError: unknown backend, world, model, planner or override (checked before any run).
        SweepError: a job failed; the rows finished before it are kept for a resume.
    """
    if backend not in _BACKENDS:
        raise InputError("<command line>", "--executor", f"unknown executor {backend!r} "
                         f"(known: {', '.join(BACKENDS)})")
    unique = list({job.key: job for job in jobs}.values())
    check_jobs(unique)
    sink = CsvSink(csv_path, resume=resume)
    check_episode_seeds(unique, sink.rows, csv_path)
    todo = [job for job in unique if not sink.done(job.key)]
    meter = sweep_progress(len(unique), len(unique) - len(todo), label=label) if progress else None
    cost = CostEstimate([job.key for job in todo], label) if progress else None
    try:
        if cost is not None and cost.active:  # a large sweep: its size now, its CPU time soon
            cost.start()
            for row, cpu_seconds in _BACKENDS[backend](run_job_timed, todo, workers, address):
                sink.write(row)
                cost.record(row["key"], cpu_seconds)
                if meter is not None:
                    meter.update()
        elif todo:
            for row in _BACKENDS[backend](run_job, todo, workers, address):
                sink.write(row)
                if meter is not None:
                    meter.update()
    finally:
        if meter is not None:
            meter.close()
        sink.finalize()
    planned = {job.key for job in unique}
    return [r for r in read_rows(csv_path) if r["key"] in planned]


__all__ = ["add_execution_arguments", "BACKENDS", "ENVIRONMENTS", "WORLD_KNOBS", "REFUSED",
           "STEP_LIMIT", "CONFIG_COLUMNS", "Job", "ablation_names", "model_names", "world_names",
           "model_path", "world_path", "check_jobs", "plan_sweep", "entropy_trace",
           "flatten_metrics", "run_job", "run_sweep"]
