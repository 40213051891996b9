"""A bundled (TOML) model's initial factors over a scenario, as an editable :class:`Program`.

``program_from_model(scenario, model)`` declares one location per object and one state per
declared task state, and the factors the belief engine starts from (docs/design.md §3.1, §3.7):

- ``prior <object>`` — eq. 2's location prior (eq. 50's learned one when the model has site
  counts), learnable;
- ``prior <object>.<state>`` — each state's Bernoulli prior (eq. 21), learnable;
- joint models only: ``capacity`` (one factor over every location: each object beyond a site's
  capacity multiplies by the penalty), ``co_location a~b`` and ``exclusivity a|b`` (pairwise
  same-site / same-room weights), with the same names and values as the engine's factors.

Learned relation weights (eq. 55) scale the first co-location factor of a pair, as the engine
always did. The relational factors carry their structured form (``ProgramFactor.form``) and build
their tables only when asked (the capacity table has K^N entries), so the belief engine keeps
them structured while they stay unedited (:func:`fg_tea.beliefs.graph.graph_from_program`). The program
remembers `model` (``program.model``): planning, detection, sensors and transitions come from it.

Evidence and transitions are not part of a model file; they enter the compiled model
(:meth:`fg_tea.beliefs.compiled.CompiledModel.observe` and ``transition``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from fg_tea.common.errors import InputError
from fg_tea.model.learning import location_weights
from fg_tea.model.pairs import learned_pairs, model_relations
from fg_tea.model.program import Program, ProgramFactor
from fg_tea.model.program_file import program_for
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
        InputError: (when its table is asked for) the capacity table would exceed
            :data:`CAPACITY_LIMIT` entries.
    """
    m = Program.from_scenario(scenario, source=model.source or f"<model {model.name}>")
    m.model = model
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
    objects = scenario.object_names
    categories = [o.category for o in scenario.objects]
    pairs, penalty = model_relations(model, objects, categories)
    if model.learning is not None and model.learning.counts.relations_active:
        priors = [m.factor_named(f"prior {o}").table for o in objects]
        pairs = learned_pairs(model, pairs, objects, categories, priors, [s.room for s in scenario.sites])
    if penalty is not None:
        _capacity(m, scenario, penalty)
    rooms = np.array([s.room for s in scenario.sites])
    for p in pairs:
        m._put(ProgramFactor(p.label, (p.a, p.b), None, False, "function",
                             ("pair", p.a, p.b, float(p.same_site), float(p.same_room)),
                             build=_pair_table(rooms, p.same_site, p.same_room)))


def _pair_table(rooms: np.ndarray, same_site: float, same_room: float):
    def build() -> np.ndarray:  # x same_site on one site, x same_room on two sites of one room
        table = np.where(rooms[:, None] == rooms[None, :], float(same_room), 1.0)
        np.fill_diagonal(table, float(same_site))
        table.setflags(write=False)
        return table
    return build


def _capacity(m: Program, scenario: Any, penalty: float) -> None:
    n, k = len(scenario.objects), len(scenario.sites)
    limited = [(j, s.capacity) for j, s in enumerate(scenario.sites) if s.capacity is not None and s.capacity < n]
    if not limited:
        return

    def build() -> np.ndarray:
        if k ** n > CAPACITY_LIMIT:
            raise InputError(m.source, "relations.capacity",
                             f"the capacity factor over {n} objects x {k} sites has {k ** n:,} entries, "
                             f"above {CAPACITY_LIMIT:,}")
        grids = np.indices((k,) * n, sparse=True)
        table = np.ones((k,) * n)
        for j, c in limited:
            count = sum((g == j).astype(int) for g in grids)
            table = table * float(penalty) ** np.maximum(count - c, 0)
        table.setflags(write=False)
        return table
    m._put(ProgramFactor("capacity", tuple(scenario.object_names), None, False, "table",
                         ("capacity", float(penalty)), build=build))


def model_program(scenario: Any, model: Any) -> Any:
    """The program of any model over `scenario`: a program model's own, or a TOML model's factors
    as :func:`program_from_model` builds them."""
    program = program_for(scenario, model)
    return program_from_model(scenario, model) if program is None else program
