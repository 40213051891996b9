"""Planning: which object-site inspection is worth doing next? (blueprint section 5, eqs. 8-17)

All planners share one interface (:class:`~fg_tea.planning.base.Planner`) and are built by name
from a model file, so every ablation of section 15.4 is a switch in the TOML, not a code edit:

- ``information_weight = 0`` (w_e), ``relevance_weight = 0`` (lambda) and ``repeat_penalty = 0``
  (w_a) reach the EFE score through :class:`~fg_tea.model.PlanningWeights`;
- ``miss_likelihood`` near 1 weakens negative evidence in the belief and in I(o, j), which the
  planners read from ``belief.model``;
- ``distance = "euclidean"`` selects the distances the caller builds (the planners take any
  :class:`~fg_tea.planning.base.DistanceModel`; :func:`distances_for` picks the right one).

Registry names: ``efe``, ``factorised_efe``, ``nearest``, ``greedy``, ``random``, ``optimal``.
Planners of your own plug in by name without editing the package: an entry point in the group
``fg_tea.planners``, or ``module:attribute`` (:mod:`fg_tea.planning.plugins`); they satisfy the
:class:`~fg_tea.planning.base.Planner` protocol.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from fg_tea.model import Model
from fg_tea.planning.base import (Candidate, Decision, DistanceModel, DistanceTable, Planner,
                                  euclidean_distances)
from fg_tea.planning.baselines import GreedyProbabilityPlanner, NearestPlanner, RandomPlanner
from fg_tea.planning.efe import EFEPlanner, FactorisedEFEPlanner
from fg_tea.planning.optimal import OptimalPlanner
from fg_tea.scenario import Scenario


def _random(model: Model, rng: np.random.Generator | None) -> Planner:
    if rng is None:
        raise ValueError("planner 'random' needs a numpy.random.Generator (pass rng=...)")
    return RandomPlanner(rng)


_REGISTRY: dict[str, Callable[[Model, np.random.Generator | None], Planner]] = {
    "efe": lambda model, rng: EFEPlanner(model.planning),
    "factorised_efe": lambda model, rng: FactorisedEFEPlanner(model.planning),
    "nearest": lambda model, rng: NearestPlanner(),
    "greedy": lambda model, rng: GreedyProbabilityPlanner(),
    "random": _random,
    "optimal": lambda model, rng: OptimalPlanner(),
}


def planner_names() -> tuple[str, ...]:
    """The registered planner names, in registry order."""
    return tuple(_REGISTRY)


def make_planner(name: str, model: Model, rng: np.random.Generator | None = None) -> Planner:
    """Build a planner by name, configured from the model file.

    Args:
        name: one of :func:`planner_names`, the name of an entry point in the group
            ``fg_tea.planners``, or ``module:attribute`` (see :mod:`fg_tea.planning.plugins`).
        model: the agent's model; its ``planning`` weights configure the EFE planners.
        rng: the Generator for ``random`` (required there), handed to plug-in factories that
            ask for ``rng``; ignored elsewhere.

    Raises:
        ValueError: ``random`` without a Generator.
        fg_tea.planning.plugins.PlannerSpecError: (a ``ValueError``) an unknown name, or a
            plug-in that cannot be imported or does not satisfy the :class:`Planner` protocol.
    """
    factory = _REGISTRY.get(name)
    if factory is None:
        from fg_tea.planning import plugins

        return plugins.build(name, model, rng)
    return factory(model, rng)


def distances_for(model: Model, scenario: Scenario, agent_xy: Sequence[float],
                  geodesic: DistanceModel | None = None) -> DistanceModel:
    """The distance model the model file asks for (``planning.distance``).

    Args:
        model: the agent's model.
        scenario: the house (vantage points for Euclidean distances).
        agent_xy: the agent's floor position (x, y), metres.
        geodesic: the environment's geodesic distances, required when the model asks for them.

    Raises:
        ValueError: the model asks for geodesic distances and none were supplied.
    """
    if model.planning.distance == "euclidean":
        return euclidean_distances(scenario, agent_xy)
    if geodesic is None:
        raise ValueError(f"model {model.name!r} plans with geodesic distances; pass the "
                         "environment's distance model (or use the euclidean ablation)")
    return geodesic


__all__ = ["Candidate", "Decision", "DistanceModel", "DistanceTable", "Planner", "EFEPlanner",
           "FactorisedEFEPlanner", "NearestPlanner", "GreedyProbabilityPlanner", "RandomPlanner",
           "OptimalPlanner", "euclidean_distances", "distances_for", "make_planner",
           "planner_names"]
