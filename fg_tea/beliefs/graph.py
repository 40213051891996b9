"""Build the agent's initial factor graph from a scenario and a model — a pure function.

``build_graph(scenario, model)`` returns the variables (named, with cardinalities and gtsam keys),
the location priors [eq. 2], the relational factors of joint models, and the Bernoulli state priors.
Evidence and queries live in :mod:`fg_tea.beliefs.engine`; this module only reads the scenario's
priors (site affordances, state priors), never its hidden truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fg_tea.beliefs.factors import (Factor, capacity_factor, location_prior, location_var,
                                    pair_factor, state_prior)
from fg_tea.model import Model
from fg_tea.scenario import Scenario


@dataclass(frozen=True)
class BeliefGraph:
    """The initial graph: location priors, relational factors and state priors.

    Attributes:
        sites: site names, the order of every location vector.
        objects: object names, the order of location variables.
        rooms: room of each site (same order as `sites`).
        capacities: capacity of each site (None = unlimited).
        location_priors: one unary factor per object, eq. 2.
        relational: factors between location variables (empty for factorised models).
        state_priors: one Bernoulli factor per declared task state, ``object.state``.
    """

    sites: tuple[str, ...]
    objects: tuple[str, ...]
    rooms: tuple[str, ...]
    capacities: tuple[int | None, ...]
    location_priors: tuple[Factor, ...]
    relational: tuple[Factor, ...]
    state_priors: tuple[Factor, ...]
    structure: str


def prior_weights(scenario: Scenario, category: str) -> np.ndarray:
    """The affordance weights a_ic of one category over the scenario's sites."""
    return np.array([site.affordances.get(category, 0.0) for site in scenario.sites], dtype=float)


def build_graph(scenario: Scenario, model: Model) -> BeliefGraph:
    """The initial factor graph of `model` over the house of `scenario`."""
    objects = scenario.object_names
    rooms = [s.room for s in scenario.sites]
    priors = tuple(location_prior(o.name, prior_weights(scenario, o.category), model.prior_floor)
                   for o in scenario.objects)
    relational: list[Factor] = []
    if model.structure == "joint":
        by_category: dict[str, list[str]] = {}
        for o in scenario.objects:
            by_category.setdefault(o.category, []).append(o.name)
        for rel in model.relations:
            if rel.kind == "capacity":
                f = capacity_factor(list(objects), [s.capacity for s in scenario.sites], rel.penalty)
                if f is not None:
                    relational.append(f)
            elif rel.kind == "co_location":
                a_cat, b_cat = rel.categories
                for a in by_category.get(a_cat, []):
                    for b in by_category.get(b_cat, []):
                        relational.append(pair_factor(a, b, rel.same_site, rel.same_room, rooms,
                                                      f"co_location {a}~{b}"))
            elif rel.kind == "exclusivity":
                for i, a in enumerate(objects):
                    for b in objects[i + 1:]:
                        relational.append(pair_factor(a, b, rel.weight, 1.0, rooms,
                                                      f"exclusivity {a}|{b}"))
    states = tuple(state_prior(f"{o.name}.{name}", p)
                   for o in scenario.objects for name, p in o.state_priors.items())
    return BeliefGraph(
        sites=scenario.site_names,
        objects=objects,
        rooms=tuple(rooms),
        capacities=tuple(s.capacity for s in scenario.sites),
        location_priors=priors,
        relational=tuple(relational),
        state_priors=states,
        structure=model.structure,
    )


__all__ = ["BeliefGraph", "build_graph", "prior_weights", "location_var"]
