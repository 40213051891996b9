"""Build the agent's initial factor graph from a scenario and a model — a pure function.

``build_graph(scenario, model)`` builds the model's starting factors as a program and translates
it (:func:`graph_from_program`); it returns the variables (named, with cardinalities and gtsam
keys), the location priors [eq. 2], the relational factors of joint models, and the Bernoulli
state priors (eq. 21). Evidence and queries live in :mod:`fg_tea.beliefs.engine`; this module only
reads the scenario's priors (site affordances, state priors), never its hidden truth.

Relational factors are kept in their *structured* form — a capacity penalty per site and
pairwise same-site / same-room weights (:class:`PairRelation`) — because that is what the
structure-aware solver (:mod:`fg_tea.beliefs.structured`) needs and because the dense capacity
table has K^N entries. :attr:`BeliefGraph.relational` expands them into dense
:class:`~fg_tea.beliefs.factors.Factor` tables on demand (for gtsam and the dense solvers).
:func:`assemble_graph` builds a graph from plain arrays (synthetic houses in tests and benchmarks).

:func:`graph_from_program` turns a :class:`~fg_tea.model.program.Program` into the
:class:`BeliefGraph` the engine (:mod:`fg_tea.beliefs.engine`) answers
queries on, exactly — no factor is approximated:

- factors over one location multiply into that object's location prior;
- a bundled model's relational factors that are still as ``program_from_model`` made them
  (``ProgramFactor.form``) stay structured: pairwise same-site / same-room weights and the
  capacity penalty, which the subset dynamic program takes without any K^N table;
- any other factor over locations is an ``extra`` dense factor of its scope;
- factors touching variables the task never reads — the user's own variables and states the
  scenario does not declare — are summed out exactly, one connected group at a time, into one
  factor over the locations they touch, along the compiler's min-fill order and within its budget
  (:func:`fg_tea.beliefs.budget.sum_out_group`);
- a factor over one task state (a state the scenario declares, which the task observes or
  changes) multiplies into its Bernoulli prior; a factor coupling task states with objects'
  locations or with each other is a coupling the engine holds exactly (fg_tea/beliefs/coupling.py,
  docs/design.md §4.8), after the user's own variables in its group are summed out; couplings over
  more than three states, or whose table over states and locations exceeds the dense limit, are
  refused in one line.

Objects and task states the program does not declare keep the base model's priors (eq. 2 and
eq. 21). Every refusal is an :class:`~fg_tea.common.errors.InputError` naming the program's
source and the factor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Mapping, Sequence

import numpy as np

from fg_tea.beliefs.factors import (
    Factor,
    capacity_factor,
    location_prior,
    location_var,
    pair_factor,
    state_prior,
)
from fg_tea.beliefs.budget import sum_out_group
from fg_tea.beliefs.coupling import check_couplings, coupling_factor
from fg_tea.beliefs.structured import MAX_OBJECTS, PairWeights
from fg_tea.common.errors import InputError
from fg_tea.model.pairs import PairRelation, learned_pairs, model_relations
from fg_tea.model.program import Program, ProgramFactor
from fg_tea.model.spec import Model
from fg_tea.world.scenario import Scenario

DENSE_LIMIT = 1 << 22  # largest joint location table (K^N entries) ever held densely


@dataclass(frozen=True)
class BeliefGraph:
    """The initial graph: location priors, relational factors and state priors.

    Attributes:
        sites: site names, the order of every location vector.
        objects: object names, the order of location variables.
        rooms: room of each site (same order as `sites`).
        capacities: capacity of each site (None = unlimited).
        location_priors: one unary factor per object, eq. 2.
        state_priors: one Bernoulli factor per declared task state, ``object.state`` (eq. 21).
        structure: ``"factorised"`` or ``"joint"``.
        pairs: pairwise relational factors of joint models (empty for factorised models).
        capacity_penalty: weight per object beyond a site's capacity; None = no capacity factor.
        extra: further relational factors given as dense tables (not structure-aware).
    """

    sites: tuple[str, ...]
    objects: tuple[str, ...]
    rooms: tuple[str, ...]
    capacities: tuple[int | None, ...]
    location_priors: tuple[Factor, ...]
    state_priors: tuple[Factor, ...]
    structure: str
    pairs: tuple[PairRelation, ...] = ()
    capacity_penalty: float | None = None
    extra: tuple[Factor, ...] = ()
    #: factors over task states and objects' locations (docs/design.md §4.8), held by
    #: :mod:`fg_tea.beliefs.coupling` between the state block and the location block
    couplings: tuple[Factor, ...] = ()

    @property
    def joint_size(self) -> int:
        """K^N, the number of joint location states."""
        return len(self.sites) ** len(self.objects)

    @property
    def capacity_active(self) -> bool:
        """True when some site's capacity could be exceeded by the N objects."""
        n = len(self.objects)
        return self.capacity_penalty is not None and any(c is not None and c < n for c in self.capacities)

    @property
    def correlated(self) -> bool:
        """True when relational factors couple the location variables."""
        return bool(self.pairs) or self.capacity_active or bool(self.extra)

    @property
    def relational_labels(self) -> tuple[str, ...]:
        """Labels of the relational factors, without building any table."""
        return (("capacity",) if self.capacity_active else ()) + \
            tuple(p.label for p in self.pairs) + tuple(f.label for f in self.extra)

    @cached_property
    def relational(self) -> tuple[Factor, ...]:
        """The relational factors as dense tables (capacity: one K^N table over all objects).

        Raises:
            ValueError: the capacity table would exceed :data:`DENSE_LIMIT` entries.
        """
        out: list[Factor] = []
        if self.capacity_active:
            if self.joint_size > DENSE_LIMIT:
                raise ValueError(f"the capacity factor over {len(self.objects)} objects x "
                                 f"{len(self.sites)} sites has {self.joint_size:,} entries, more "
                                 f"than the dense limit {DENSE_LIMIT:,}; use the structured solver")
            assert self.capacity_penalty is not None  # capacity_active says so
            f = capacity_factor(list(self.objects), list(self.capacities), self.capacity_penalty)
            if f is not None:
                out.append(f)
        out += [pair_factor(p.a, p.b, p.same_site, p.same_room, list(self.rooms), p.label)
                for p in self.pairs]
        return tuple(out) + self.extra


def prior_weights(scenario: Scenario, category: str) -> np.ndarray:
    """The affordance weights a_ic of one category over the scenario's sites."""
    return np.array([site.affordances.get(category, 0.0) for site in scenario.sites], dtype=float)


def assemble_graph(model: Model, sites: Sequence[str], rooms: Sequence[str],
                   objects: Sequence[str], categories: Sequence[str], weights: np.ndarray,
                   capacities: Sequence[int | None] | None = None,
                   state_priors: Mapping[str, float] | None = None) -> BeliefGraph:
    """A belief graph from plain arrays: the model's priors and relations over a given house.

    Args:
        model: supplies the prior floor [eq. 2], the structure and the relations.
        sites: site names (K).
        rooms: room of each site (K).
        objects: object names (N).
        categories: category of each object (N), matched against co-location relations.
        weights: (N, K) non-negative affordance weights a_ic, one row per object.
        capacities: capacity per site (None = unlimited); default all unlimited.
        state_priors: ``object.state`` -> q(true) (eq. 21).
    """
    weights = np.asarray(weights, dtype=float)
    if weights.shape != (len(objects), len(sites)):
        raise ValueError(f"weights have shape {weights.shape}, expected {(len(objects), len(sites))}")
    capacities = tuple(capacities) if capacities is not None else (None,) * len(sites)
    priors = tuple(location_prior(o, w, model.prior_floor) for o, w in zip(objects, weights))
    pairs: list[PairRelation] = []
    penalty: float | None = None
    if model.structure == "joint":
        pairs, penalty = model_relations(model, objects, categories)
        if model.learning is not None and model.learning.counts.relations_active:
            pairs = learned_pairs(model, pairs, objects, categories, [f.table for f in priors], rooms)
    states = tuple(state_prior(name, p) for name, p in (state_priors or {}).items())
    return BeliefGraph(sites=tuple(sites), objects=tuple(objects), rooms=tuple(rooms),
                       capacities=capacities, location_priors=priors, state_priors=states,
                       structure=model.structure, pairs=tuple(pairs), capacity_penalty=penalty)


def build_graph(scenario: Scenario, model: Model) -> BeliefGraph:
    """The initial factor graph of `model` over the house of `scenario`.

    There is one construction path (docs/design.md §4.8): the model's starting factors as a
    program — the program of a program file (:mod:`fg_tea.model.program_file`), or a TOML model's
    via :func:`~fg_tea.model.program_bundled.program_from_model` — turned into the engine's graph
    by :func:`graph_from_program`.
    """
    from fg_tea.model.program_bundled import model_program

    return graph_from_program(model_program(scenario, model), scenario, model)


def pair_weight_matrices(graph: BeliefGraph) -> PairWeights:
    """Same-site and same-room weights between objects (eq. 35), in the graph's object order."""
    n = len(graph.objects)
    index = {o: i for i, o in enumerate(graph.objects)}
    same_site, same_room = np.ones((n, n)), np.ones((n, n))
    for p in graph.pairs:
        a, b = index[p.a], index[p.b]
        for x, y in ((a, b), (b, a)):
            same_site[x, y] *= p.same_site
            same_room[x, y] *= p.same_room
    return PairWeights(same_site, same_room)


def check_exact_method(graph: BeliefGraph, structurable: bool, location_solver: str) -> None:
    """Raise ValueError when no exact method can hold the graph's joint (or the requested one
    cannot): the dense table above :data:`DENSE_LIMIT` states with relational factors the subset
    program cannot take."""
    n, k = len(graph.objects), len(graph.sites)
    dense_ok = graph.joint_size <= DENSE_LIMIT
    if graph.correlated and not (structurable or dense_ok):
        raise ValueError(f"joint model with {n} objects over {k} sites has "
                         f"{graph.joint_size:,} joint states, more than the dense limit "
                         f"{DENSE_LIMIT:,}, and relational factors the structured solver "
                         "cannot take (it needs site/room-local factors and at most "
                         f"{MAX_OBJECTS} objects)")
    if location_solver == "dense" and graph.correlated and not dense_ok:
        raise ValueError(f"the dense joint of {graph.joint_size:,} states exceeds the dense "
                         f"limit {DENSE_LIMIT:,}")
    if location_solver == "structured" and graph.correlated and not structurable:
        raise ValueError("this model's relational factors are not site/room-local")


__all__ = ["BeliefGraph", "DENSE_LIMIT", "PairRelation", "assemble_graph", "build_graph",
           "check_exact_method", "pair_weight_matrices",
           "prior_weights", "location_var"]


def graph_from_program(program: Program, scenario: Any, model: Any) -> BeliefGraph:
    """The engine's initial graph for `program` over the house of `scenario`.

    Args:
        program: the model program (locations over the scenario's sites).
        scenario: the loaded scenario the episode runs in.
        model: the base model: its structure names the graph, and its priors stand in for
            objects and task states the program does not declare.

    Returns:
        A :class:`BeliefGraph` with the program's factors, exactly.

    Raises:
        InputError: the program's sites are not the scenario's, a factor couples task states in
            a way the engine cannot hold exactly (:func:`~fg_tea.beliefs.coupling.coupling_factor`),
            summing a group out would build a table above the budget of exact inference
            (:mod:`fg_tea.beliefs.budget`, checked before any table is built), or a prior is all zero.
    """
    source = program.source
    sites = tuple(scenario.site_names)
    if tuple(s.name for s in program.sites) != sites:
        raise InputError(source, "sites", f"the program's sites are not scenario {scenario.name!r}'s "
                         "(build it with fg.Program.from_scenario(scenario) or fg.program_from_model)")
    objects = tuple(scenario.object_names)
    tracked = [f"{o.name}.{s}" for o in scenario.objects for s in o.state_priors]
    kinds = {v.name: v.kind for v in program.variables}
    for v in program.variables:
        if v.kind == "location" and v.name not in objects:
            raise InputError(source, f"location {v.name!r}", f"unknown object in scenario {scenario.name!r}")
    unary: dict[str, list[np.ndarray]] = {}
    pairs: list[PairRelation] = []
    penalty: float | None = None
    extra: list[Factor] = []
    hidden: list[ProgramFactor] = []
    couplings: list[Factor] = []
    for f in program.factors:
        touched = [s for s in f.scope if s in tracked]
        own = [s for s in f.scope if s not in tracked and kinds[s] != "location"]
        if touched and not own:
            if len(f.scope) > 1:
                couplings.append(coupling_factor(source, f, set(tracked), kinds))
                continue
            unary.setdefault(f.scope[0], []).append(f.table)
        elif own:
            hidden.append(f)
        elif f.form is not None and f.form[0] == "capacity":
            penalty = f.form[1] if penalty is None else penalty * f.form[1]
        elif f.form is not None and f.form[0] == "pair":
            _, a, b, same_site, same_room = f.form
            pairs.append(PairRelation(a, b, same_site, same_room, f.name))
        elif len(f.scope) == 1:
            unary.setdefault(f.scope[0], []).append(f.table)
        else:
            extra.append(Factor(tuple(location_var(s) for s in f.scope), f.table, f.name))
    for name, scope, table in _summed_out(program, hidden, kinds, set(tracked)):
        if any(s in tracked for s in scope) and len(scope) > 1:  # own variables between a state and more
            couplings.append(coupling_factor(source, _Summed(name, scope, table), set(tracked), kinds))
        elif len(scope) == 1:
            unary.setdefault(scope[0], []).append(table)
        elif scope:
            extra.append(Factor(tuple(location_var(s) for s in scope), table, name))
    if couplings:
        check_couplings(source, couplings)
    base = _BasePriors(scenario, model)
    priors = tuple(Factor((location_var(o),), _product(source, f"location {o!r}", unary[o]) if o in unary
                          else base.location(o), f"prior {location_var(o)}") for o in objects)
    states = []
    for name in tracked:
        if name in unary:
            table = _product(source, f"state {name!r}", unary[name])
            states.append(state_prior(name, float(table[1])))
        elif name in kinds:
            states.append(state_prior(name, 0.5))  # declared, no factor: uniform
        else:
            states.append(state_prior(name, base.state(name)))
    return BeliefGraph(sites=sites, objects=objects, rooms=tuple(s.room for s in scenario.sites),
                       capacities=tuple(s.capacity for s in scenario.sites), location_priors=priors,
                       state_priors=tuple(states), structure=getattr(model, "structure", "joint"),
                       pairs=tuple(pairs), capacity_penalty=penalty, extra=tuple(extra),
                       couplings=tuple(couplings))


class _BasePriors:
    """The base model's priors for what the program leaves undeclared (built only if needed)."""

    def __init__(self, scenario: Any, model: Any) -> None:
        self.scenario, self.model = scenario, model
        self._program: Program | None = None

    def _factor(self, name: str) -> np.ndarray:
        if self._program is None:
            from fg_tea.model.program_bundled import program_from_model

            self._program = program_from_model(self.scenario, self.model)
        return self._program.factor_named(f"prior {name}").table

    def location(self, obj: str) -> np.ndarray:
        return self._factor(obj)

    def state(self, name: str) -> float:
        return float(self._factor(name)[1])


def _product(source: str, what: str, tables: Sequence[np.ndarray]) -> np.ndarray:
    """The normalised product of one variable's tables (a table already normalised to 1e-12 is kept
    as it is, so a bundled model's priors reach the engine bit for bit)."""
    table = np.array(tables[0], dtype=float)
    for t in tables[1:]:
        table = table * t
    total = float(table.sum())
    if not total > 0:
        raise InputError(source, what, "its factors multiply to zero everywhere (the program is impossible)")
    return table if abs(total - 1.0) <= 1e-12 else table / total


@dataclass(frozen=True)
class _Summed:
    """A group of factors with the program's own variables summed out, as a factor over the task
    states and locations it touches (what :func:`~fg_tea.beliefs.coupling.coupling_factor` reads)."""

    name: str
    scope: tuple[str, ...]
    table: np.ndarray


def _summed_out(program: Program, hidden: Sequence[ProgramFactor], kinds: dict[str, str],
                tracked: set[str]) -> list[tuple[str, tuple[str, ...], np.ndarray]]:
    """Each connected group of factors over variables the task never reads, with those variables
    summed out exactly: (label, scope of the locations and task states it touches, table)."""
    parent: dict[str, str] = {}

    def root(v: str) -> str:
        while parent.setdefault(v, v) != v:
            v = parent[v]
        return v

    def summed(v: str) -> bool:
        return kinds[v] != "location" and v not in tracked

    for f in hidden:
        own = [s for s in f.scope if summed(s)]
        for s in own[1:]:
            parent[root(s)] = root(own[0])
    groups: dict[str, list[ProgramFactor]] = {}
    for f in hidden:
        groups.setdefault(root(next(s for s in f.scope if summed(s))), []).append(f)
    sizes = {v.name: len(v.values) for v in program.variables}
    out = []
    for members in groups.values():
        names = list(dict.fromkeys(s for f in members for s in f.scope))
        keep = tuple(s for s in names if not summed(s))
        label = " * ".join(f.name for f in members) + " (summed out: " + \
            ", ".join(s for s in names if summed(s)) + ")"
        size = math.prod(sizes[s] for s in keep)
        if size > DENSE_LIMIT:
            raise InputError(program.source, f"factor {members[0].name!r}",
                             f"summing out {label} leaves a table of {size:,} entries (limit {DENSE_LIMIT:,})")
        table = sum_out_group(program.source, f"factor {members[0].name!r}", label,
                              [(f.scope, f.table) for f in members],
                              [s for s in names if summed(s)], keep, sizes)
        out.append((label, keep, table))
    return out


__all__ = ["graph_from_program"]
