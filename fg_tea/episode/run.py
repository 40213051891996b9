"""One episode in one call, and the environment for it: the front door of :mod:`fg_tea`.

:func:`make_env` builds the PyBullet house or the fake house with a camera (by default the one the
model assumes);
:func:`run_episode` runs a whole episode as ``fg-tea run --no-video`` does (docs/design.md §9).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from fg_tea.env.base import EnvAdapter
from fg_tea.episode.log import EventLog
from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
from fg_tea.model.spec import Model
from fg_tea.world.scenario import Scenario

ENVIRONMENTS = ("pybullet", "fake")


def make_env(scenario: Scenario, model: Model, kind: str = "pybullet", *,
             camera: str | Path | None = None, **config: Any) -> EnvAdapter:
    """An environment for `scenario` with a camera (docs/design.md §1.3, §8).

    Args:
        scenario: the house (the environment reads its hidden truth; the agent never does).
        model: the agent's model. It does not configure the camera; it only picks the default
            one, the bundled camera of the detector it assumes (:func:`env_config_for`).
        camera: a camera file or bundled camera name (``"visibility"``, ``"threshold"``, ...);
            None: the model's default camera.
        kind: ``"pybullet"`` (the rendered house with a segmentation camera) or ``"fake"`` (the
            same geometry and truth without rendering: fast, for tests and sweeps).
        **config: :class:`~fg_tea.env.base.EnvConfig` fields to override (``failure_rates``,
            ``detection_miss_rate``, ``movement_step``...).

    Returns:
        An :class:`~fg_tea.env.base.EnvAdapter`; call ``close()`` when done (or use ``with``).
    """
    if kind not in ENVIRONMENTS:
        raise ValueError(f"unknown environment {kind!r} (known: {', '.join(ENVIRONMENTS)})")
    env_config = env_config_for(model, camera, **config)
    if kind == "fake":
        from fg_tea.env.fake import FakeHouse

        return FakeHouse(scenario, env_config)
    from fg_tea.env.house import PyBulletHouse

    return PyBulletHouse(scenario, env_config)


def run_episode(scenario: Scenario, model: Model, *, planner: str = "efe", task: str = "make_tea",
                seed: int = 0, env: str | EnvAdapter = "pybullet", log: str | Path | None = None,
                max_frames: int = 50_000) -> EpisodeRunner:
    """Run one whole episode, as ``fg-tea run --no-video`` does; return the finished runner.

    Args:
        scenario, model: the house and the agent's model (see :func:`fg_tea.load_scenario`,
            :func:`fg_tea.load_model`).
        planner, task, seed, max_frames: as the ``fg-tea run`` options of the same names.
        env: ``"pybullet"``, ``"fake"`` or an environment you built (not closed here).
        log: a JSONL file to write the events to, event by event (None keeps them in memory).

    Returns:
        The runner: ``.events`` (the log), ``.metrics()``, ``.agent`` (belief, planner, task).
    """
    own = isinstance(env, str)
    adapter = make_env(scenario, model, env) if isinstance(env, str) else env
    config = RunConfig(seed=seed, planner=planner, task=task, max_frames=max_frames)
    try:
        if log is None:
            runner = EpisodeRunner(scenario, model, adapter, config)
            runner.run()
        else:
            with EventLog(log) as file_log:
                runner = EpisodeRunner(scenario, model, adapter, config, file_log)
                runner.run()
    finally:
        if own:
            adapter.close()
    return runner
