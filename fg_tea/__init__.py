"""fg_tea: a tea-making agent that reasons with exact factor-graph beliefs.

The public API: everything a script needs is a name of this package (``import fg_tea as fg``).

Inputs (docs/design.md §2):

- `load_scenario`, `load_model`, `load_task`, `load_world`: read and check a file or bundled name.

The agent (docs/design.md §1):

- `Agent`: belief, planner and task executor; decide, observe, act. Its belief, ``agent.belief``,
  is a `BeliefEngine` (fg_tea.beliefs.engine: `location_map`, `entropy`, `joint`, ...).
- `Decision`, `Candidate`, `Planner`, `register_planner`, `planner_names`: planning (§6).

The world and the loop (docs/design.md §8-§9):

- `make_env`: a PyBullet house or the fake house, its camera set by the model.
- `run_episode`: one whole episode, as ``fg-tea run --no-video``.
- `EpisodeRunner`, `RunConfig`, `EventLog`, `read_log`: stepping an episode; its JSONL log.

Models as programs (docs/design.md §4.8):

- `Program`: declare variables (locations, states, your own) and factors over them.
- `program_from_model`: a bundled model's factors over a scenario, as a program to edit.
- `model_program`: the program of any loaded model (TOML, or a model program file) over a scenario.
- `compile_program`, `CompiledModel`, `plan_text`: exact inference over a program; its plan.

Studies (docs/design.md §11-§12):

- `compare`: models x planners over sampled worlds, paired, with a report.
- `learn`: a learned model from episode logs (``fg-tea learn``).

Errors: `InputError` (bad input: file, field, fault), `PlannerRefused`, `ContradictionError`.

The objects these return (a `Scenario`, a `Model`, a `WorldDistribution`, the belief and its
update records `LookUpdate` and `StateUpdate`) are documented in docs/reference/api.md.

Layers, in the order data flows (docs/design.md §1): common -> world -> model -> beliefs ->
planning, tasks -> agent -> env -> episode -> render, study -> cli. The agent side never imports
the simulator. Names load on first use, so ``import fg_tea`` stays light.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from fg_tea.episode.gym_id import install as _register_gym_id
from fg_tea._version import __version__

_register_gym_id()  # gymnasium.make("fg_tea/TeaMaking-v0") after import fg_tea (fg_tea/episode/gym_id.py)

#: Public name -> the module that defines it.
_API = {
    "load_scenario": "fg_tea.world.scenario",
    "load_model": "fg_tea.model.spec",
    "load_task": "fg_tea.tasks.load",
    "load_world": "fg_tea.world.distributions",
    "Agent": "fg_tea.agent.agent",
    "Decision": "fg_tea.planning.base",
    "Candidate": "fg_tea.planning.base",
    "Planner": "fg_tea.planning.base",
    "register_planner": "fg_tea.planning",
    "planner_names": "fg_tea.planning",
    "make_env": "fg_tea.episode.run",
    "run_episode": "fg_tea.episode.run",
    "EpisodeRunner": "fg_tea.episode.runner",
    "RunConfig": "fg_tea.episode.runner",
    "EventLog": "fg_tea.episode.log",
    "read_log": "fg_tea.episode.log",
    "Program": "fg_tea.model.program",
    "program_from_model": "fg_tea.model.program_bundled",
    "model_program": "fg_tea.model.program_bundled",
    "compile_program": "fg_tea.beliefs.compiled",
    "CompiledModel": "fg_tea.beliefs.compiled",
    "plan_text": "fg_tea.beliefs.compiled",
    "compare": "fg_tea.study.compare",
    "learn": "fg_tea.study.learn",
    "InputError": "fg_tea.common.errors",
    "ContradictionError": "fg_tea.common.errors",
    "PlannerRefused": "fg_tea.common.errors",
}
_RENAMED = {"learn": "learn_files"}

__all__ = ["__version__", *_API]


def __getattr__(name: str) -> Any:
    if name in _API:
        value = getattr(importlib.import_module(_API[name]), _RENAMED.get(name, name))
        globals()[name] = value
        return value
    raise AttributeError(f"module 'fg_tea' has no attribute {name!r}")


def __dir__() -> list[str]:
    """The public API, the module's own dunder names and its loaded subpackages: no helper
    (``importlib``, ``Any``, ``annotations``) of this file."""
    import types

    own = {n for n, v in globals().items() if (n.startswith("__") and n.endswith("__"))
           or (isinstance(v, types.ModuleType) and not n.startswith("_") and v.__name__ == f"{__name__}.{n}")}
    return sorted(own | set(__all__))


if TYPE_CHECKING:  # for type checkers and editors; at run time the names load on first use
    from fg_tea.agent.agent import Agent
    from fg_tea.beliefs.compiled import CompiledModel, compile_program, plan_text
    from fg_tea.common.errors import ContradictionError, InputError, PlannerRefused
    from fg_tea.episode.log import EventLog, read_log
    from fg_tea.episode.run import make_env, run_episode
    from fg_tea.episode.runner import EpisodeRunner, RunConfig
    from fg_tea.model.program import Program
    from fg_tea.model.program_bundled import program_from_model
    from fg_tea.model.program_bundled import model_program
    from fg_tea.model.spec import load_model
    from fg_tea.planning import planner_names, register_planner
    from fg_tea.planning.base import Candidate, Decision, Planner
    from fg_tea.study.compare import compare
    from fg_tea.study.learn import learn_files as learn
    from fg_tea.tasks.load import load_task
    from fg_tea.world.distributions import load_world
    from fg_tea.world.scenario import load_scenario
