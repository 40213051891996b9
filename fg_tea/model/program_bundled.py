"""A bundled (TOML) model's initial factors over a scenario, as an editable :class:`Program`.

``program_from_model(scenario, model)`` declares one location per object and one state per
declared task state, and the factors the belief engine starts from (docs/design.md §3.1, §3.7):

- ``prior <object>`` — eq. 2's location prior (eq. 50's learned one when the model has site
  counts), learnable;
- ``prior <object>.<state>`` — each state's Bernoulli prior (eq. 21), learnable;
- joint models only: ``capacity`` (one factor over every location: each object beyond a site's
  capacity multiplies by the penalty), ``co_location a~b`` and ``exclusivity a|b`` (pairwise
  same-site / same-room weights), with the same names and values as the engine's factors.

Evidence and transitions are not part of a model file; they enter the compiled model
(:meth:`fg_tea.beliefs.compiled.CompiledModel.observe` and ``transition``). Learned relation
weights (eq. 55) are not a program front end yet and are refused in one line.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from fg_tea.common.errors import InputError
from fg_tea.model.learning import location_weights
from fg_tea.model.program import Program
from fg_tea.model.spec import Model

#: Largest capacity table (K^N entries) built for a program.
CAPACITY_LIMIT = 1 << 24


def program_from_model(scenario: Any, model: Model) -> Program:
    """The program of `model`'s initial factors over the house of `scenario`.

    Args:
        scenario: a loaded scenario (``fg.load_scenario``).
        model: a loaded model (``fg.load_model``).

    Returns:
        A :class:`Program` to extend, edit (``remove``, ``replace``) and compile.

    Raises:
        InputError: the model has learned relation weights, or its capacity table would exceed
            :data:`CAPACITY_LIMIT` entries.
    """
    m = Program.from_scenario(scenario, source=model.source or f"<model {model.name}>")
    sites = scenario.site_names
    for o in scenario.objects:
        m.location(o.name)
    for o in scenario.objects:
        for state in o.state_priors:
            m.state(f"{o.name}.{state}")
    for o in scenario.objects:
        declared = np.array([s.affordances.get(o.category, 0.0) for s in scenario.sites], dtype=float)
        weights = np.maximum(location_weights(model.learning, o.category, sites, declared,
                                              model.prior_floor, model.source), model.prior_floor)
        m.table(o.name, weights / weights.sum(), name=f"prior {o.name}", learnable=True)
    for o in scenario.objects:
        for state, p in o.state_priors.items():
            m.table(f"{o.name}.{state}", [1.0 - p, p], name=f"prior {o.name}.{state}", learnable=True)
    if model.structure == "joint":
        _relations(m, scenario, model)
    return m


def _relations(m: Program, scenario: Any, model: Model) -> None:
    if model.learning is not None and model.learning.counts.relations_active:
        raise InputError(m.source, "$.learning.co_location",
                         "learned relation weights (eq. 55) are not yet built as a program; "
                         "use the model file directly")
    objects = scenario.object_names
    categories = [o.category for o in scenario.objects]
    penalty = None
    for rel in model.relations:
        if rel.kind == "capacity":
            penalty = rel.penalty if penalty is None else penalty * rel.penalty
    if penalty is not None:
        _capacity(m, scenario, penalty)
    for rel in model.relations:
        if rel.kind == "co_location":
            a_cat, b_cat = rel.categories
            for a, ca in zip(objects, categories):
                for b, cb in zip(objects, categories):
                    if ca == a_cat and cb == b_cat and a != b:
                        _pair(m, a, b, rel.same_site, rel.same_room, f"co_location {a}~{b}")
        elif rel.kind == "exclusivity":
            for i, a in enumerate(objects):
                for b in objects[i + 1:]:
                    _pair(m, a, b, rel.weight, 1.0, f"exclusivity {a}|{b}")


def _pair(m: Program, a: str, b: str, same_site: float, same_room: float, name: str) -> None:
    def weight(la, lb):  # a site's value carries its room
        if la.name == lb.name:
            return same_site
        return same_room if la.room == lb.room else 1.0
    m.function((a, b), weight, name=name)


def _capacity(m: Program, scenario: Any, penalty: float) -> None:
    n, k = len(scenario.objects), len(scenario.sites)
    limited = [(j, s.capacity) for j, s in enumerate(scenario.sites) if s.capacity is not None and s.capacity < n]
    if not limited:
        return
    if k ** n > CAPACITY_LIMIT:
        raise InputError(m.source, "relations.capacity",
                         f"the capacity factor over {n} objects x {k} sites has {k ** n:,} entries, "
                         f"above {CAPACITY_LIMIT:,}")
    grids = np.indices((k,) * n, sparse=True)
    table = np.ones((k,) * n)
    for j, c in limited:
        count = sum((g == j).astype(int) for g in grids)
        table = table * float(penalty) ** np.maximum(count - c, 0)
    m.table(scenario.object_names, table, name="capacity")
