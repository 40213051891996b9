"""Joint beliefs agree with brute-force enumeration to 1e-9 on randomised small models.

Hypothesis draws houses (2-5 sites in 1-3 rooms, random capacities), 2-4 objects with random
affordance weights and categories, random relational factors (capacity, co-location,
exclusivity), and a random chain of evidence: misses and detections (both positive-update modes,
eqs. 4-6), noisy state readings (eqs. 23-24) and action transitions (eq. 27). The reference is
built here, independently of the engine: every factor table is filled by explicit loops, the
state block keeps *every* time slice (nothing summed out), and marginals come from
:func:`fg_tea.beliefs.solvers.brute_force_marginals`. Both backends are checked, and
``hypothetical_all()`` is checked against ``copy()`` + ``observe_site`` for every (object, site).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.beliefs.factors import Factor
from fg_tea.beliefs.graph import assemble_graph
from fg_tea.beliefs.solvers import brute_force_marginals
from fg_tea.model.spec import Effect, Relation, Sensor, load_model

ROOT = Path(__file__).resolve().parents[1]
BASE = load_model(ROOT / "models" / "joint.toml")
TOL = 1e-9
CATEGORIES = ("cup", "pot", "bag")
SETTINGS = settings(max_examples=25, derandomize=True, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


@dataclass
class Problem:
    """A random house, model and evidence chain."""

    sites: tuple[str, ...]
    rooms: tuple[str, ...]
    capacities: tuple[int | None, ...]
    objects: tuple[str, ...]
    categories: tuple[str, ...]
    weights: np.ndarray
    relations: tuple[Relation, ...]
    positive_update: str
    fp: float
    states: dict[str, float]
    ops: list = field(default_factory=list)


@st.composite
def problems(draw, max_objects: int = 4, max_sites: int = 5) -> Problem:
    n = draw(st.integers(2, max_objects))
    k = draw(st.integers(2, max_sites))
    rooms = tuple(f"room{draw(st.integers(0, 2))}" for _ in range(k))
    capacities = tuple(draw(st.sampled_from([None, None, 1, 2])) for _ in range(k))
    weight = st.floats(0.0, 3.0, allow_nan=False)
    weights = np.array([[draw(weight) for _ in range(k)] for _ in range(n)])
    for row in weights:
        if row.sum() == 0:
            row[0] = 1.0
    categories = tuple(draw(st.sampled_from(CATEGORIES)) for _ in range(n))
    relations = []
    if draw(st.booleans()):
        relations.append(Relation("capacity", penalty=draw(st.floats(0.01, 1.0))))
    for _ in range(draw(st.integers(0, 2))):
        a, b = draw(st.permutations(CATEGORIES))[:2]
        relations.append(Relation("co_location", categories=(a, b),
                                  same_site=draw(st.floats(0.1, 5.0)),
                                  same_room=draw(st.floats(0.2, 3.0))))
    if draw(st.booleans()):
        relations.append(Relation("exclusivity", weight=draw(st.floats(0.02, 1.0))))
    states = {f"o{i}.s{t}": draw(st.floats(0.0, 1.0)) for i in range(2) for t in range(2)}
    problem = Problem(
        sites=tuple(f"site{j}" for j in range(k)), rooms=rooms, capacities=capacities,
        objects=tuple(f"obj{i}" for i in range(n)), categories=categories, weights=weights,
        relations=tuple(relations), positive_update=draw(st.sampled_from(["collapse", "likelihood"])),
        fp=draw(st.floats(1e-3, 0.2)), states=states)
    names = sorted(states)
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["site", "site", "read", "act"]))
        if kind == "site":
            site = draw(st.sampled_from(problem.sites))
            det = {}
            for o in problem.objects:
                outcome = draw(st.sampled_from(["miss", "miss", "none", "seen"]))
                if outcome != "none":
                    det[o] = outcome == "seen"
            problem.ops.append(("site", site, det))
        elif kind == "read":
            problem.ops.append(("read", draw(st.sampled_from(names)), draw(st.booleans()),
                                Sensor(draw(st.floats(0.6, 0.99)), draw(st.floats(0.6, 0.99)))))
        else:
            targets = draw(st.lists(st.sampled_from(names), min_size=1, max_size=2, unique=True))
            effects = []
            for t in targets:
                requires = tuple(r for r in names if r != t and draw(st.booleans()) and draw(st.booleans()))
                effects.append(Effect(t, draw(st.booleans()), draw(st.floats(0.5, 1.0)), requires))
            problem.ops.append(("act", effects, draw(st.booleans())))
    return problem


# ------------------------------------------------------------------ the independent reference
class Reference:
    """Brute-force beliefs for a :class:`Problem`; every table written out with loops."""

    def __init__(self, p: Problem, model) -> None:
        self.p, self.model = p, model
        n, k = len(p.objects), len(p.sites)
        self.loc_cards = {self.var(o): k for o in p.objects}
        self.loc_factors: list[Factor] = []
        for o, w in zip(p.objects, p.weights):
            table = np.array([max(x, model.prior_floor) for x in w])
            self.loc_factors.append(Factor((self.var(o),), table / table.sum()))
        self._relational(n, k)
        self.slice = {s: f"{s}@0" for s in p.states}
        self.state_cards = {v: 2 for v in self.slice.values()}
        self.state_factors = [Factor((self.slice[s],), np.array([1 - q, q])) for s, q in p.states.items()]
        self.serial = 1

    @staticmethod
    def var(o: str) -> str:
        return f"L[{o}]"

    def _relational(self, n: int, k: int) -> None:
        p = self.p
        for rel in p.relations:
            if rel.kind == "capacity":
                table = np.ones((k,) * n)
                for x in itertools.product(range(k), repeat=n):
                    for j, c in enumerate(p.capacities):
                        if c is not None:
                            table[x] *= rel.penalty ** max(0, sum(1 for xi in x if xi == j) - c)
                self.loc_factors.append(Factor(tuple(self.var(o) for o in p.objects), table))
                continue
            for a in range(n):
                for b in range(n):
                    if rel.kind == "co_location":
                        on = (p.categories[a], p.categories[b]) == rel.categories
                        same_site, same_room = rel.same_site, rel.same_room
                    else:
                        on = a < b
                        same_site, same_room = rel.weight, 1.0
                    if not on or a == b:
                        continue
                    table = np.ones((k, k))
                    for i in range(k):
                        for j in range(k):
                            if i == j:
                                table[i, j] = same_site
                            elif p.rooms[i] == p.rooms[j]:
                                table[i, j] = same_room
                    self.loc_factors.append(Factor((self.var(p.objects[a]), self.var(p.objects[b])), table))

    def locations(self) -> np.ndarray:
        marg = brute_force_marginals(self.loc_factors, self.loc_cards)
        return np.stack([marg[self.var(o)] for o in self.p.objects])

    def states(self) -> dict[str, float]:
        marg = brute_force_marginals(self.state_factors, self.state_cards)
        return {s: float(marg[v][1]) for s, v in self.slice.items()}

    def observe_site(self, site: str, det: dict[str, bool]) -> None:
        j, k, mu = self.p.sites.index(site), len(self.p.sites), self.model.miss_likelihood
        for o in self.p.objects:                          # misses first, eq. 5
            if det.get(o) is False:
                self.loc_factors.append(Factor((self.var(o),), np.array([mu if i == j else 1.0 for i in range(k)])))
        seen = [o for o in self.p.objects if det.get(o) is True]
        if not seen:
            return
        if self.model.positive_update != "collapse":
            for o in seen:
                table = np.array([1 - mu if i == j else self.model.false_positive_rate for i in range(k)])
                self.loc_factors.append(Factor((self.var(o),), table))
            return
        # Eq. 4 for every seen object at once (eq. 32a): Jeffrey's rule t(i) / q(L_o = i) in
        # sweeps until every seen marginal is its target (iterative proportional fitting).
        eps = self.model.prior_floor
        t = np.array([1.0 if i == j else eps for i in range(k)])
        t = t / t.sum()
        for _ in range(500):
            for o in seen:
                q = self.locations()[self.p.objects.index(o)]
                self.loc_factors.append(Factor((self.var(o),), t / q))
            locs = self.locations()
            if max(np.abs(locs[self.p.objects.index(o)] - t).max() for o in seen) <= 1e-13:
                break

    def read(self, state: str, value: bool, sensor: Sensor) -> None:
        a, b = sensor.sensitivity, sensor.specificity
        table = np.array([1 - b, a]) if value else np.array([b, 1 - a])     # P(o | z = 0), P(o | z = 1)
        self.state_factors.append(Factor((self.slice[state],), table))

    def act(self, effects: list[Effect], direct: bool) -> None:
        new = {}
        for e in effects:
            name = f"{e.state}@{self.serial}"
            self.serial += 1
            self.state_cards[name] = 2
            new[e.state] = name
            v = int(e.value)
            if direct:                                   # eqs. 25, 26: q'(z = value) = rho
                table = np.zeros(2)
                table[v], table[1 - v] = e.success, 1 - e.success
                self.state_factors.append(Factor((name,), table))
                continue
            parents = [self.slice[e.state]] + [self.slice[r] for r in e.requires]
            table = np.zeros((2,) * (len(parents) + 1))
            for x in itertools.product((0, 1), repeat=len(parents)):
                if all(x[1:]):                           # eq. 27: requirements hold
                    table[x + (v,)] += e.success
                    table[x + (x[0],)] += 1 - e.success
                else:
                    table[x + (x[0],)] = 1.0
            self.state_factors.append(Factor(tuple(parents) + (name,), table))
        self.slice.update(new)


def model_for(p: Problem):
    return BASE.with_overrides(relations=p.relations, positive_update=p.positive_update,
                               false_positive_rate=p.fp)


def engine_for(p: Problem, model, backend: str, solver: str = "auto") -> BeliefEngine:
    graph = assemble_graph(model, p.sites, p.rooms, p.objects, p.categories, p.weights,
                           p.capacities, p.states)
    return BeliefEngine(graph, model, backend=backend, location_solver=solver)


def run_chain(p: Problem, engine: BeliefEngine, ref: Reference, check_every: bool) -> None:
    for op in p.ops:
        if op[0] == "site":
            engine.observe_site(op[1], op[2])
            ref.observe_site(op[1], op[2])
        elif op[0] == "read":
            engine.observe_state(op[1], op[2], op[3])
            ref.read(op[1], op[2], op[3])
        else:
            engine.apply_effects(op[1], direct=op[2])
            ref.act(op[1], op[2])
        if check_every:
            assert_agrees(engine, ref)


def assert_agrees(engine: BeliefEngine, ref: Reference) -> None:
    np.testing.assert_allclose(engine.location_matrix(), ref.locations(), rtol=0, atol=TOL)
    want = ref.states()
    got = engine.states()
    assert set(got) == set(want)
    for s in want:
        assert abs(got[s] - want[s]) <= TOL, s


# ------------------------------------------------------------------ the tests
@pytest.mark.parametrize("backend, solver", [("numpy", "auto"), ("numpy", "structured"),
                                             ("gtsam", "auto")])
@SETTINGS
@given(p=problems())
def test_joint_engine_matches_brute_force_after_a_chain_of_evidence(p, backend, solver):
    model = model_for(p)
    engine = engine_for(p, model, backend, solver)
    ref = Reference(p, model)
    assert_agrees(engine, ref)
    run_chain(p, engine, ref, check_every=backend == "numpy")
    assert_agrees(engine, ref)
    for m in (engine.location_matrix(), *engine.hypothetical_all()):
        assert np.all(np.isfinite(m))


@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
@settings(max_examples=10, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(p=problems(max_objects=3, max_sites=4))
def test_hypothetical_all_equals_copy_and_observe(p, backend):
    model = model_for(p)
    engine = engine_for(p, model, backend)
    run_chain(p, engine, Reference(p, model), check_every=False)
    before = engine.location_matrix()
    miss, seen = engine.hypothetical_all()
    np.testing.assert_array_equal(engine.location_matrix(), before)   # nothing was mutated
    for o, obj in enumerate(p.objects):
        for j, site in enumerate(p.sites):
            for outcome, table in ((False, miss), (True, seen)):
                other = engine.copy()
                other.observe_site(site, {obj: outcome})
                np.testing.assert_allclose(table[o, j], other.location_matrix(), rtol=0, atol=TOL)
    np.testing.assert_array_equal(engine.location_matrix(), before)


@SETTINGS
@given(p=problems())
def test_numpy_fast_path_equals_gtsam(p):
    model = model_for(p)
    fast, ref = engine_for(p, model, "numpy"), engine_for(p, model, "gtsam")
    for e in (fast, ref):
        run_chain(p, e, Reference(p, model), check_every=False)
    np.testing.assert_allclose(fast.location_matrix(), ref.location_matrix(), rtol=0, atol=TOL)
    np.testing.assert_allclose(fast.pairwise(), ref.pairwise(), rtol=0, atol=TOL)
    assert fast.check_against_gtsam() <= TOL
    for a, b in zip(fast.hypothetical_all(), ref.hypothetical_all()):
        np.testing.assert_allclose(a, b, rtol=0, atol=TOL)
