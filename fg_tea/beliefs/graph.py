"""Build the agent's initial factor graph from a scenario and a model — a pure function.

``build_graph(scenario, model)`` builds the model's starting factors as a program and translates
it (:mod:`fg_tea.beliefs.from_program`); it returns the variables (named, with cardinalities and gtsam keys),
the location priors [eq. 2], the relational factors of joint models, and the Bernoulli state
priors (eq. 21). Evidence and queries live in :mod:`fg_tea.beliefs.engine`; this module only
reads the scenario's priors (site affordances, state priors), never its hidden truth.

Relational factors are kept in their *structured* form — a capacity penalty per site and
pairwise same-site / same-room weights (:class:`PairRelation`) — because that is what the
structure-aware solver (:mod:`fg_tea.beliefs.structured`) needs and because the dense capacity
table has K^N entries. :attr:`BeliefGraph.relational` expands them into dense
:class:`~fg_tea.beliefs.factors.Factor` tables on demand (for gtsam and the dense solvers).
:func:`assemble_graph` builds a graph from plain arrays (synthetic houses in tests and benchmarks).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Mapping, Sequence

import numpy as np

from fg_tea.beliefs.factors import (
    Factor,
    capacity_factor,
    location_prior,
    location_var,
    pair_factor,
    state_prior,
)
from fg_tea.beliefs.structured import MAX_OBJECTS, PairWeights
from fg_tea.model.learning import learned_relation_weights, location_weights
from fg_tea.model.spec import Model
from fg_tea.world.scenario import Scenario

DENSE_LIMIT = 1 << 22  # largest joint location table (K^N entries) ever held densely


@dataclass(frozen=True)
class PairRelation:
    """psi(L_a, L_b): `same_site` when a and b share a site, `same_room` when they share a room
    on two different sites, 1 otherwise (exclusivity and co-location factors)."""

    a: str
    b: str
    same_site: float
    same_room: float
    label: str


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
        for rel in model.relations:
            if rel.kind == "capacity":
                penalty = rel.penalty if penalty is None else penalty * rel.penalty
            elif rel.kind == "co_location":
                a_cat, b_cat = rel.categories
                for a, ca in zip(objects, categories):
                    for b, cb in zip(objects, categories):
                        if ca == a_cat and cb == b_cat and a != b:
                            pairs.append(PairRelation(a, b, rel.same_site, rel.same_room,
                                                      f"co_location {a}~{b}"))
            elif rel.kind == "exclusivity":
                for i, a in enumerate(objects):
                    for b in objects[i + 1:]:
                        pairs.append(PairRelation(a, b, rel.weight, 1.0, f"exclusivity {a}|{b}"))
        if model.learning is not None and model.learning.counts.relations_active:
            pairs = learned_pairs(model, pairs, objects, categories, [f.table for f in priors], rooms)
    states = tuple(state_prior(name, p) for name, p in (state_priors or {}).items())
    return BeliefGraph(sites=tuple(sites), objects=tuple(objects), rooms=tuple(rooms),
                       capacities=capacities, location_priors=priors, state_priors=states,
                       structure=model.structure, pairs=tuple(pairs), capacity_penalty=penalty)


def learned_pairs(model: Model, pairs: list[PairRelation], objects: Sequence[str],
                  categories: Sequence[str], priors: Sequence[np.ndarray],
                  rooms: Sequence[str]) -> list[PairRelation]:
    """The pair factors with eq. (55)'s learned co-location weights (docs/design.md §12.1).

    For every two objects related by a co-location relation whose categories have counts, the
    hand-set weights are the product of every pair factor between the two (co-location and
    exclusivity alike); eq. (55) gives the learned (s, r) over the two objects' location priors,
    and the first co-location factor of the pair is scaled so that the product is (s, r).
    Pairs without counts keep their factors unchanged.
    """
    assert model.learning is not None
    learning = model.learning
    cat = dict(zip(objects, categories))
    prior = dict(zip(objects, priors))
    groups: dict[frozenset, list[int]] = {}
    for i, p in enumerate(pairs):
        groups.setdefault(frozenset((p.a, p.b)), []).append(i)
    out = list(pairs)
    for members in groups.values():
        co = [i for i in members if pairs[i].label.startswith("co_location")]
        if not co:
            continue
        a, b = pairs[co[0]].a, pairs[co[0]].b
        counts = learning.counts.relation(cat[a], cat[b])
        if counts is None:
            continue
        s0 = float(np.prod([pairs[i].same_site for i in members]))
        r0 = float(np.prod([pairs[i].same_room for i in members]))
        s, r = learned_relation_weights(prior[a], prior[b], rooms, s0, r0, counts,
                                        learning.relation_strength)
        first = pairs[co[0]]
        out[co[0]] = PairRelation(first.a, first.b,
                                  first.same_site * s / s0 if s0 > 0 else s,
                                  first.same_room * r / r0 if r0 > 0 else r,
                                  first.label + " (learned)")
    return out


def build_graph(scenario: Scenario, model: Model) -> BeliefGraph:
    """The initial factor graph of `model` over the house of `scenario`.

    There is one construction path (docs/design.md §4.8): the model's starting factors as a
    program — the program of a program file (:mod:`fg_tea.model.program_file`), or a TOML model's
    via :func:`~fg_tea.model.program_bundled.program_from_model` — turned into the engine's graph
    by :func:`~fg_tea.beliefs.from_program.graph_from_program`.
    """
    from fg_tea.beliefs.from_program import graph_from_program
    from fg_tea.model.program_file import model_program

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
