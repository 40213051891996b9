"""The structure-aware subset dynamic program equals dense enumeration and gtsam.

:mod:`fg_tea.beliefs.structured` computes the partition function, single and pairwise location
marginals and the MAP arrangement of joint models with site-local (capacity) and room-local
(co-location, exclusivity) factors by subset convolutions. Checked here against a dense joint
table filled by explicit loops (1e-9), against gtsam through the engine, on a model far beyond
the dense limit (internal consistency), and through its numerical guard and dense fallback.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import fg_tea.beliefs.structured as structured
from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.beliefs.graph import DENSE_LIMIT, assemble_graph
from fg_tea.common.errors import ContradictionError
from fg_tea.beliefs.structured import (NumericalGuardError, PairWeights, StructuredLocationModel,
    SubsetAlgebra)
from fg_tea.model.spec import Relation, load_model

ROOT = Path(__file__).resolve().parents[1]
JOINT = load_model(ROOT / "models" / "joint.toml")
TOL = 1e-9


@st.composite
def small_models(draw):
    n = draw(st.integers(1, 4))
    k = draw(st.integers(2, 5))
    pos = st.floats(0.01, 3.0)
    unary = np.array([[draw(pos) for _ in range(k)] for _ in range(n)])
    rooms = [f"r{draw(st.integers(0, 2))}" for _ in range(k)]
    caps = [draw(st.sampled_from([None, 1, 2])) for _ in range(k)]
    penalty = draw(st.sampled_from([None, 0.0, 0.05, 0.5]))
    site = np.array([[draw(st.floats(0.05, 4.0)) for _ in range(n)] for _ in range(n)])
    room = np.array([[draw(st.floats(0.2, 3.0)) for _ in range(n)] for _ in range(n)])
    return unary, rooms, caps, penalty, PairWeights((site + site.T) / 2, (room + room.T) / 2)


def dense_joint(unary, rooms, caps, penalty, pairs):
    """P(L) by explicit enumeration of every arrangement."""
    n, k = unary.shape
    table = np.zeros((k,) * n)
    for x in itertools.product(range(k), repeat=n):
        w = np.prod([unary[o, x[o]] for o in range(n)])
        if penalty is not None:
            for j, c in enumerate(caps):
                if c is not None:
                    w *= penalty ** max(0, x.count(j) - c)
        for a in range(n):
            for b in range(a + 1, n):
                if x[a] == x[b]:
                    w *= pairs.same_site[a, b]
                elif rooms[x[a]] == rooms[x[b]]:
                    w *= pairs.same_room[a, b]
        table[x] = w
    return table / table.sum()


def dense_pairwise(joint):
    n, k = joint.ndim, joint.shape[0]
    out = np.zeros((n, n, k, k))
    for o in range(n):
        for p in range(n):
            if o == p:
                out[o, o] = np.diag(joint.sum(axis=tuple(a for a in range(n) if a != o)))
            else:
                block = joint.sum(axis=tuple(a for a in range(n) if a not in (o, p)))
                out[o, p] = block if o < p else block.T
    return out


@settings(max_examples=40, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(spec=small_models())
def test_dynamic_program_equals_dense_enumeration(spec):
    unary, rooms, caps, penalty, pairs = spec
    with np.errstate(invalid="ignore"):
        joint = dense_joint(*spec)
    if not np.all(np.isfinite(joint)):      # every arrangement breaks a hard capacity: Z = 0
        with pytest.raises(ContradictionError):
            StructuredLocationModel(*spec)
        return
    dp = StructuredLocationModel(*spec)
    n = unary.shape[0]
    singles = np.stack([joint.sum(axis=tuple(a for a in range(n) if a != o)) for o in range(n)])
    np.testing.assert_allclose(dp.singles(), singles, rtol=0, atol=TOL)
    np.testing.assert_allclose(dp.pairwise(), dense_pairwise(joint), rtol=0, atol=TOL)
    best = dp.map_assignment()
    assert joint[tuple(best)] == pytest.approx(joint.max(), rel=1e-12)


def test_subset_convolution_basics():
    alg = SubsetAlgebra(3)
    f = np.arange(1.0, 9.0)
    np.testing.assert_array_equal(alg.conv(f, alg.delta()), f)      # delta is the unit
    # (f * g)({0, 1}) = f({}) g({0,1}) + f({0}) g({1}) + f({1}) g({0}) + f({0,1}) g({})
    g = np.arange(10.0, 18.0)
    assert alg.conv(f, g)[0b011] == f[0] * g[3] + f[1] * g[2] + f[2] * g[1] + f[3] * g[0]


def joint_graph(n: int, k: int, rooms_of: int = 4, seed: int = 0, penalty: float = 0.05):
    """n objects over k sites, `rooms_of` sites per room, all-pairs exclusivity, capacity and
    co-location (the benchmark's model family)."""
    rng = np.random.default_rng(seed)
    model = JOINT.with_overrides(relations=(
        Relation("capacity", penalty=penalty),
        Relation("co_location", categories=("teabag", "kettle"), same_site=3.0, same_room=2.0),
        Relation("exclusivity", weight=0.05)))
    categories = ["kettle", "teabag"] + [f"thing{i}" for i in range(n - 2)]
    graph = assemble_graph(model, [f"s{j}" for j in range(k)], [f"room{j // rooms_of}" for j in range(k)],
                           [f"o{i}" for i in range(n)], categories[:n], rng.random((n, k)) + 0.05,
                           capacities=[1 if j % 3 == 0 else None for j in range(k)])
    return graph, model


@pytest.mark.parametrize("positive_update", ["collapse", "likelihood"])
def test_engine_structured_equals_gtsam_and_dense(positive_update):
    graph, model = joint_graph(3, 7, rooms_of=3, seed=1)
    model = model.with_overrides(positive_update=positive_update)
    engines = {name: BeliefEngine(graph, model, backend=b, location_solver=s)
               for name, b, s in (("structured", "numpy", "structured"), ("dense", "numpy", "dense"),
                                  ("gtsam", "gtsam", "auto"))}
    for e in engines.values():
        e.observe_site("s1", {"o0": False, "o2": False})
        e.observe_site("s4", {"o1": True})
        e.observe_site("s1", {"o0": False})
    ref = engines["gtsam"]
    for name in ("structured", "dense"):
        e = engines[name]
        assert e.location_method == name
        np.testing.assert_allclose(e.location_matrix(), ref.location_matrix(), rtol=0, atol=TOL)
        np.testing.assert_allclose(e.pairwise(), ref.pairwise(), rtol=0, atol=TOL)
        for a, b in zip(e.hypothetical_all(), ref.hypothetical_all()):
            np.testing.assert_allclose(a, b, rtol=0, atol=TOL)
        assert e.check_against_gtsam() < TOL
        assert e.map_estimate() == ref.map_estimate()


def test_beyond_the_dense_limit_the_engine_stays_exact_and_consistent():
    graph, model = joint_graph(8, 24)
    assert graph.joint_size > DENSE_LIMIT
    belief = BeliefEngine(graph, model)
    assert belief.location_method == "structured"
    belief.observe_site("s0", {"o0": False, "o3": True})
    belief.observe_site("s5", {"o1": False})
    q = belief.location_matrix()
    np.testing.assert_allclose(q.sum(axis=1), 1.0, atol=1e-12)
    pw = belief.pairwise()
    # every pairwise block marginalises to the single marginals on both sides
    np.testing.assert_allclose(pw.sum(axis=3), np.broadcast_to(q[:, None, :], pw.shape[:3]), atol=1e-12)
    np.testing.assert_allclose(pw.sum(axis=2), np.broadcast_to(q[None, :, :], pw.shape[:3]).transpose(0, 1, 2),
                               atol=1e-12)
    # hypotheses equal copy + observe for a sample of (object, site)
    miss, seen = belief.hypothetical_all()
    for o, j in ((0, 3), (5, 17), (7, 0)):
        for outcome, table in ((False, miss), (True, seen)):
            other = belief.copy()
            other.observe_site(f"s{j}", {f"o{o}": outcome})
            np.testing.assert_allclose(table[o, j], other.location_matrix(), rtol=0, atol=TOL)
    assert belief.joint(["L[o2]", "L[o6]"]).shape == (24, 24)
    with pytest.raises(ValueError, match="dense limit"):
        belief.location_joint()
    arrangement = belief.map_estimate()
    assert arrangement["o3"] == "s0"                    # seen there
    assert len(set(arrangement.values())) == 8          # exclusivity 0.05 keeps them apart


def test_guard_falls_back_to_dense_or_refuses(monkeypatch):
    small, model = joint_graph(3, 6)
    big, _ = joint_graph(8, 24)
    reference = BeliefEngine(small, model, location_solver="dense").location_matrix()
    monkeypatch.setattr(structured, "GUARD_TOLERANCE", -1.0)   # every check now fails
    belief = BeliefEngine(small, model, location_solver="structured")
    with pytest.raises(NumericalGuardError):
        belief._structured().singles()
    auto = BeliefEngine(small, model)
    monkeypatch.setattr(BeliefEngine, "_method", lambda self: "structured")
    np.testing.assert_allclose(auto.location_matrix(), reference, atol=1e-15)  # dense fallback
    with pytest.raises(NumericalGuardError):
        BeliefEngine(big, model).location_matrix()


def test_reusing_unchanged_rooms_of_the_previous_model_is_exact():
    """A model built from the previous one (rooms whose unaries are rescaled copies reused)
    equals a fresh one: marginals, pairwise, partition function up to its scale."""
    from fg_tea.beliefs.structured import PairWeights, StructuredLocationModel

    rng = np.random.default_rng(3)
    n, k = 5, 12
    rooms = [f"r{j % 4}" for j in range(k)]
    caps = [1 if j % 5 == 0 else None for j in range(k)]
    same_site = np.full((n, n), 0.3)
    same_room = np.full((n, n), 1.7)
    pairs = PairWeights(same_site, same_room)
    unary = rng.uniform(0.05, 1.0, (n, k))
    unary /= unary.sum(axis=1, keepdims=True)
    old = StructuredLocationModel(unary, rooms, caps, 0.1, pairs)
    old.singles()
    new_unary = unary.copy()
    in_r1 = [j for j in range(k) if rooms[j] == "r1"]
    new_unary[:, in_r1] *= rng.uniform(0.05, 0.5, len(in_r1))   # a missed glance at room r1
    new_unary[2, 4] = 0.0                                # a zero appears in room r0
    new_unary /= new_unary.sum(axis=1, keepdims=True)    # every row rescaled
    reused = StructuredLocationModel(new_unary, rooms, caps, 0.1, pairs, previous=old)
    assert reused._same_rooms[2] is not None and reused._same_rooms[3] is not None
    assert reused._same_rooms[0] is None and reused._same_rooms[1] is None
    fresh = StructuredLocationModel(new_unary, rooms, caps, 0.1, pairs)
    np.testing.assert_allclose(reused.singles(), fresh.singles(), rtol=0, atol=1e-12)
    np.testing.assert_allclose(reused.pairwise(), fresh.pairwise(), rtol=0, atol=1e-12)
    assert reused.z == pytest.approx(fresh.z, rel=1e-12)
    # different pair weights: nothing is reused
    other = StructuredLocationModel(new_unary, rooms, caps, 0.1, PairWeights(same_site, same_room * 2),
                                    previous=old)
    assert all(x is None for x in other._same_rooms)
