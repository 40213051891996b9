"""An episode's parameters (docs/design.md §8.6): :class:`RunConfig`, and how the log records it."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Callable

from fg_tea.tasks.executor import MAX_REOPENINGS


@dataclass(frozen=True)
class RunConfig:
    """Episode parameters (defaults: docs/design.md §8.6 where it applies)."""

    seed: int = 0
    planner: str = "efe"
    task: str = "make_tea"
    preparation_site: str | None = None
    max_frames: int = 50_000
    #: The exact belief solver, ``"numpy"``, ``"gtsam"`` or ``"compiled"``: ``Agent(solver=)``, ``--solver``.
    #: (``belief_backend=``, its former name, still works with a DeprecationWarning.)
    solver: str = "numpy"
    snapshot_every_event: bool = True
    #: Task-level reopenings allowed per episode (``fg_tea.tasks.executor.MAX_REOPENINGS``).
    max_reopenings: int = MAX_REOPENINGS
    #: Cross-check the final belief against gtsam at the episode's end (docs/design.md §4.7). It
    #: is the costliest step of a many-object episode; sweeps that keep only metrics may skip it,
    #: and the log then records ``"gtsam_agreement": null``.
    gtsam_check: bool = True

    @property
    def belief_backend(self) -> str:
        """Deprecated: :attr:`solver`."""
        _renamed()
        return self.solver


def logged_run(config: RunConfig) -> dict[str, Any]:
    """`config` as the log's ``parameters.run``: the solver keeps the key logs have always given
    it, ``belief_backend``, so that a log stays byte for byte what it was (tests/golden)."""
    return {("belief_backend" if k == "solver" else k): v for k, v in asdict(config).items()}


def _renamed() -> None:
    import warnings

    warnings.warn("RunConfig's belief_backend is now called solver (as Agent(solver=) and --solver)",
                  DeprecationWarning, stacklevel=3)


def _accept_former_name(init: Callable) -> Callable:
    """`init` that also takes ``belief_backend=`` (the former name of ``solver=``), with a warning."""
    import functools

    @functools.wraps(init)
    def __init__(self, *args, belief_backend: str | None = None, **kwargs) -> None:
        if belief_backend is not None:
            _renamed()
            if kwargs.setdefault("solver", belief_backend) != belief_backend:
                raise TypeError("RunConfig: give solver= or belief_backend= (its former name), not both")
        init(self, *args, **kwargs)

    return __init__


RunConfig.__init__ = _accept_former_name(RunConfig.__init__)  # type: ignore[method-assign]
