"""``fg-tea validate``: check scenario, model, task and world files with every check a run makes.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from fg_tea.cli.common import check_scenario, command
from fg_tea.common.errors import InputError
from fg_tea.common.resources import DEFAULT_MODEL, DEFAULT_SCENARIO

#: What `fg-tea run` uses when not told otherwise; a model file is checked against them.
DEFAULT_TASK = "make_tea"
DEFAULT_PLANNER = "efe"


def file_kind(path: Path, data: object | None) -> str:
    """Which kind of input file this is: ``model``, ``camera``, ``scenario``, ``task`` or ``world``.

    A TOML file with a ``[camera]`` table is a camera file; other TOML files are models. A JSON
    file is recognised by its content: a world distribution has ``placement`` or
    ``base_scenario``, a task has ``actions``, a scenario has ``schema_version`` or ``house``;
    otherwise a file under a ``tasks`` folder is a task, else a scenario.
    """
    if path.suffix == ".toml":
        return "camera" if isinstance(data, dict) and "camera" in data else "model"
    if isinstance(data, dict):
        if "placement" in data or "base_scenario" in data:
            return "world"
        if "actions" in data or "declares_states" in data:
            return "task"
        if "schema_version" in data or "house" in data:
            return "scenario"
    if "tasks" in path.parts:
        return "task"
    if "worlds" in path.parts:
        return "world"
    return "scenario"


@command("validate")
def cmd_validate(args: argparse.Namespace) -> int:
    """Check scenario (.json), model and camera (.toml), task and world files; print one line
    per file.

    Each file gets every check a run would make: a scenario is also laid out on the occupancy
    grid with the navigator and given an exact belief under ``--model``; a task is checked
    against ``--scenario`` (itself given the scenario checks) and ``--model``; a model is checked
    as ``fg-tea run --model`` would check it, against ``--scenario`` (default: the default
    apartment) and ``--task`` (default: make_tea), with the default camera of its detector and the
    default planner (:func:`check_model_runs`); a world distribution's base scenario is checked
    and one world is drawn.
    """
    from fg_tea.common.inputs import read_json, read_toml
    from fg_tea.env.camera import parse_camera
    from fg_tea.model.spec import load_model
    from fg_tea.world.scenario import load_scenario, parse_scenario

    from fg_tea.common.resources import is_program_ref

    for path in [p for name in args.files for p in _validate_targets(name)]:
        if is_program_ref(path):
            print(check_program(str(path), args.scenario or DEFAULT_SCENARIO, args.task), end="")
            continue
        data = read_toml(path) if path.suffix == ".toml" else read_json(path)
        kind = file_kind(path, data)
        if kind == "camera":
            parse_camera(data, path)
        elif kind == "model":
            check_model_runs(load_model(path), args.scenario or DEFAULT_SCENARIO, args.task)
        elif kind == "task":
            from fg_tea.tasks.load import parse_task

            scenario = load_scenario(args.scenario or _scenario_for_task(data))
            model = load_model(args.model)
            check_scenario(scenario, model)  # as `run` does before loading its task
            parse_task(data, model, scenario, file=path)
        elif kind == "world":
            from fg_tea.world.distributions import parse_world

            world = parse_world(data, path)
            check_scenario(world.base if world.base is not None else world.house(0),
                           load_model(args.model))
            try:  # a sample moves objects and truths only: the checks above still hold for it
                world.sample(0)
            except ValueError as exc:
                raise InputError(path, "$.placement", f"drawing world 0 failed: {exc}") from None
        else:
            scenario = parse_scenario(data, path)
            check_scenario(scenario, load_model(args.model))
        print(f"{path}: ok ({kind})")
    return 0


def check_model_runs(model, scenario_ref: str, task_ref: str) -> None:
    """The checks ``fg-tea run --model MODEL SCENARIO --task TASK`` makes before its first step:
    the default camera of the model's detector, the scenario under the model (grid, navigator,
    exact belief), the task under both, and the default planner's size limits.

    Raises:
        InputError: a fault of the scenario or task file as such, as is; a task the model cannot
            run, naming the model file, the task and the task's own one-line fault.
    """
    from fg_tea.cli.common import planner_size_fault
    from fg_tea.episode.runner import env_config_for
    from fg_tea.tasks.load import load_task
    from fg_tea.world.scenario import load_scenario

    scenario = load_scenario(scenario_ref)
    env_config_for(model, None)
    check_scenario(scenario, model)
    try:
        graph = load_task(task_ref, model, scenario)
    except InputError as exc:
        raise InputError(model.source, "$", f"fg-tea run --model with task {task_ref!r} in scenario "
                         f"{scenario.name!r} would refuse it (validate --task/--scenario check "
                         f"another pair): {exc}") from None
    fault = planner_size_fault(DEFAULT_PLANNER, scenario, graph, model)
    if fault is not None:
        raise InputError(model.source, "$", f"with task {task_ref!r} in scenario "
                         f"{scenario.name!r}: {fault}")


def check_program(ref: str, scenario_ref: str, task_ref: str) -> str:
    """Check a model program as ``fg-tea run --model REF`` would (:func:`check_model_runs`) and
    return its report: the ok line, how the belief engine answers location queries, and the
    compiled plan (variables, factors, the exact method of each query, elimination width,
    largest table; :meth:`fg_tea.beliefs.compiled.CompiledModel.plan`)."""
    from fg_tea.beliefs.compiled import compile_program
    from fg_tea.beliefs.engine import BeliefEngine
    from fg_tea.model.program_file import program_for
    from fg_tea.model.spec import load_model
    from fg_tea.world.scenario import load_scenario

    model = load_model(ref)
    scenario = load_scenario(scenario_ref)
    # compiled first: a program over the budget is refused before any large table is built
    plan = compile_program(program_for(scenario, model)).plan()
    check_model_runs(model, scenario_ref, task_ref)
    engine = BeliefEngine(scenario, model)
    labels = engine.graph.relational_labels
    return (f"{ref}: ok (model program, base {model.program.base}, sha256 {model.program.sha256[:12]}; "
            f"scenario {scenario.name}, task {task_ref})\n"
            f"episode beliefs: location queries by the {engine.location_method} method; "
            f"relational factors: {', '.join(labels) or 'none'}\n"
            + plan)


def _scenario_for_task(data: object) -> str:
    """The bundled scenario a task file is checked against when none is named: the default
    apartment, or the first bundled scenario holding every object the task's actions name."""
    from fg_tea.common.resources import bundled
    from fg_tea.world.scenario import load_scenario

    names = set()
    if isinstance(data, dict) and isinstance(data.get("actions"), list):
        for action in data["actions"]:
            if isinstance(action, dict):
                names |= {v for k, v in action.items() if k in ("object", "destination")
                          and isinstance(v, str)}
    for candidate in [DEFAULT_SCENARIO] + [p.stem for p in bundled("scenarios", ".json")]:
        try:
            if names <= set(load_scenario(candidate).object_names):
                return candidate
        except InputError:
            continue
    return DEFAULT_SCENARIO


def _validate_targets(name: str) -> list[Path]:
    """The files `name` stands for in ``fg-tea validate``: itself when it exists or looks like a
    path, else every bundled file of that name (a scenario and a world may share one)."""
    from fg_tea.common.resources import KINDS, bundled

    path = Path(name)
    try:
        exists = path.exists()
    except (OSError, ValueError):
        exists = False
    if exists or path.suffix or len(path.parts) != 1:
        return [path]
    found = [p for folder, suffix, _ in KINDS.values() for p in bundled(folder, suffix)
             if p.name == f"{name}{suffix}"]
    return found or [path]


def add_parser(sub) -> None:
    p = sub.add_parser("validate", help="check scenario, model, camera, task and world files",
                       description="Check each file with every check a run makes before its first "
                       "step; print one line per file. The kind is recognised by content. A model "
                       "is checked as fg-tea run --model checks it, with --task in --scenario (by "
                       "default make_tea in the default apartment); a task with --model in "
                       "--scenario; a scenario or world with --model. A model program (a .py file, "
                       "module:attr or fg_tea.models entry point) is checked as a model, then its "
                       "compiled plan is printed: variables, factors, the exact method of each query, "
                       "the elimination width and the largest table; importing and building it are "
                       "limited to FG_TEA_MODEL_SECONDS seconds each (default 60). A bundled name "
                       "(see fg-tea list) checks every bundled file of that name.")
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="scenario (.json), model or camera (.toml), task or world file, a model "
                   "program (.py, module:attr, entry point: also prints its compiled plan), or a "
                   "bundled name")
    p.add_argument("--scenario", default=None,
                   help="scenario to check task and model files against (default: the default "
                   "apartment; for a task file, the first bundled scenario holding every object "
                   "the task names if the default apartment lacks one)")
    p.add_argument("--task", default=DEFAULT_TASK,
                   help="task to check model files against, in --scenario, with the default camera "
                   "of the model's detector and the default planner, as fg-tea run does "
                   "(default: %(default)s)")
    p.add_argument("--model", default=DEFAULT_MODEL,
                   help="model to check scenario, task and world files against (default: %(default)s)")
