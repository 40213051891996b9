"""The structured joint information gain equals brute force and the dense joint, without the joint.

:class:`fg_tea.planning.joint_gain.JointViewGain` computes I(L_o ; Y_v) for every unresolved
object and viewpoint from the subset dynamic program (docs/design.md §6.2, eqs. 44-45). Checked here:
against enumeration of every arrangement and every outcome (close looks, glances, sub-room views,
capacity, same-site and same-room factors, untracked objects, false positives) to 1e-9; against
the dense implementation through the planner on beliefs after evidence, at sizes where the dense
joint still fits; that the restricted outcome set above the outcome limit is a lower bound and
how far it falls; and that the planner runs beyond the dense limit.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fg_tea.beliefs.detection import View
from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.beliefs.graph import DENSE_LIMIT
from fg_tea.beliefs.structured import PairWeights, StructuredLocationModel
from fg_tea.planning import DistanceTable, EFEPlanner
from fg_tea.planning.efe import (DENSE_GAIN_LIMIT, coupling_strength, joint_information_gain,
                                 structured_gain, view_joint_information_gain)
from fg_tea.planning.joint_gain import JointViewGain
from test_beliefs_structured import dense_joint, joint_graph, small_models
from test_views_exact import brute_force_view_gain

TOL = 1e-9


@st.composite
def looks_at(draw, rooms, n):
    """A viewpoint inside one room (one site, the whole room, or part of it), who is observed,
    p_{u,c} and the false-positive rate."""
    k = len(rooms)
    room = rooms[draw(st.integers(0, k - 1))]
    in_room = [j for j in range(k) if rooms[j] == room]
    kind = draw(st.sampled_from(["close", "glance", "part"]))
    if kind == "close":
        sites = [draw(st.sampled_from(in_room))]
    elif kind == "glance":
        sites = in_room
    else:
        sites = sorted(draw(st.lists(st.sampled_from(in_room), min_size=1, unique=True)))
    observed = draw(st.permutations(range(n)))[:draw(st.integers(1, n))]
    prob = np.array([[draw(st.floats(0.0, 0.99)) for _ in sites] for _ in observed])
    fp = draw(st.sampled_from([0.0, 1e-4, 0.01]))
    return sites, list(observed), prob, fp


@settings(max_examples=60, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_structured_gain_equals_enumeration_of_every_outcome(data):
    unary, rooms, caps, penalty, pairs = data.draw(small_models())
    n, k = unary.shape
    sites, observed, prob, fp = data.draw(looks_at(rooms, n))
    try:
        model = StructuredLocationModel(unary, rooms, caps, penalty, pairs)
    except Exception:  # zero partition function (hard capacity with too many objects)
        return
    joint = dense_joint(unary, rooms, caps, penalty, pairs)
    got = JointViewGain(model, observed, fp, outcome_limit=None).gain(sites, prob)
    if len(observed) <= 2 and len(sites) <= 3:
        want = brute_force_view_gain(joint, observed, sites, prob, fp)
    else:  # the dense implementation, itself checked against enumeration in test_views_exact
        want = view_joint_information_gain(joint, observed, sites, prob, fp)
    np.testing.assert_allclose(got, want, rtol=0, atol=TOL)
    assert np.all(got >= -TOL)


@pytest.mark.parametrize("n,k,rooms_of", [(4, 16, 4), (5, 10, 5), (6, 7, 4)])
def test_planner_gain_equals_dense_after_evidence(n, k, rooms_of):
    # Capacity, co-location and all-pairs exclusivity; sizes above the dense-gain switch but
    # inside the dense limit, so both routes run on the same belief.
    graph, model = joint_graph(n, k, rooms_of=rooms_of, seed=n)
    assert DENSE_GAIN_LIMIT < k ** n <= DENSE_LIMIT
    belief = BeliefEngine(graph, model)
    belief.observe_site("s1", {"o0": False, "o2": False})
    belief.observe_site("s2", {"o1": True})
    unresolved = [0, 2, 3] + list(range(4, n))
    names = [belief.objects[i] for i in unresolved]
    solver = structured_gain(belief, unresolved)
    assert solver is not None
    joint = belief.location_joint()
    mu, fp = model.miss_likelihood, model.false_positive_rate
    # Close looks with the threshold detector (every site).
    gain, mode = EFEPlanner(model.planning, information="joint").information_gain(belief, names)
    np.testing.assert_allclose(gain, joint_information_gain(joint, unresolved, mu, fp),
                               rtol=0, atol=TOL)
    # Glances over every room and one sub-room view, random p.
    rng = np.random.default_rng(n)
    views = []
    for r in range(0, k, rooms_of):
        sites = list(range(r, min(k, r + rooms_of)))
        views.append((sites, rng.uniform(0.05, 0.95, (len(unresolved), len(sites)))))
    views.append(([0, 1], rng.uniform(0.05, 0.95, (len(unresolved), 2))))
    got = structured_gain(belief, unresolved).gains(views)
    for c, (sites, prob) in enumerate(views):
        want = view_joint_information_gain(joint, unresolved, sites, prob, fp)
        np.testing.assert_allclose(got[:, c], want, rtol=0, atol=TOL)


def test_restricted_outcomes_are_a_lower_bound_and_exact_when_unrestricted():
    graph, model = joint_graph(6, 12, rooms_of=4, seed=3)
    belief = BeliefEngine(graph, model)
    belief.observe_site("s5", {"o0": False, "o1": False})
    sm = belief.structured_model()
    observed = list(range(6))
    rng = np.random.default_rng(0)
    views = [(list(range(r, r + 4)), rng.uniform(0.1, 0.9, (6, 4))) for r in (0, 4, 8)]
    exact = JointViewGain(sm, observed, 1e-4, outcome_limit=None).gains(views)
    solver = JointViewGain(sm, observed, 1e-4, outcome_limit=12 * 5 ** 2,
                           coupling=coupling_strength(belief))
    approx = solver.gains(views)
    assert solver.restricted == 6 * len(views)
    assert np.all(approx <= exact + 1e-12)
    assert np.max(exact - approx) > 0       # dropping outcomes loses something here...
    # ...but the coupled objects (kettle, teabag: co-location) are kept, so not much.
    assert np.max((exact - approx) / exact) < 0.5
    dense = JointViewGain(sm, observed, 1e-4, outcome_limit=1 << 30).gains(views)
    np.testing.assert_allclose(dense, exact, rtol=0, atol=1e-12)


def test_joint_planner_runs_beyond_the_dense_limit():
    graph, model = joint_graph(6, 24, rooms_of=4, seed=5)
    assert 24 ** 6 > DENSE_LIMIT
    belief = BeliefEngine(graph, model)
    with pytest.raises(ValueError, match="dense limit"):
        belief.location_joint()
    names = list(belief.objects)
    sites = list(belief.sites)
    rng = np.random.default_rng(1)
    xy = rng.uniform(0, 10, (len(sites), 2))
    dist = DistanceTable(tuple(sites), tuple(float(x) for x in np.linalg.norm(xy, axis=1)),
                         tuple(tuple(float(x) for x in np.linalg.norm(xy[:, None] - xy[None], axis=2)[i])
                               for i in range(len(sites))))
    relevance = {o: 1.0 for o in names}
    decision = EFEPlanner(model.planning, information="joint").choose(
        belief, names, relevance, dist, {})
    gains = np.array([c.information_gain for c in decision.candidates])
    assert np.all(np.isfinite(gains)) and np.all(gains >= 0)
    # A glance's exact gain over 6 objects, checked against its own consistency: it is at least
    # the gain of o's own outcome alone (observing more never tells less).
    sm = belief.structured_model()
    prob = rng.uniform(0.2, 0.9, (6, 4))
    full = JointViewGain(sm, range(6), 1e-4, outcome_limit=None).gain([0, 1, 2, 3], prob)
    for o in range(6):
        own = JointViewGain(sm, [o], 1e-4, outcome_limit=None).gain([0, 1, 2, 3], prob[o:o + 1])
        assert full[o] >= own[0] - 1e-12


def test_matrix_and_gathered_subset_convolutions_agree(monkeypatch):
    """The dense-matrix route (up to MATRIX_OBJECTS objects) and the gathered subset
    convolutions (beyond) give the same gains."""
    import fg_tea.planning.joint_gain as jg

    rng = np.random.default_rng(5)
    n, k = 4, 9
    rooms = [f"r{j % 3}" for j in range(k)]
    pairs = PairWeights(np.full((n, n), 0.4), np.full((n, n), 1.5))
    unary = rng.uniform(0.05, 1.0, (n, k))
    sm = StructuredLocationModel(unary, rooms, [1] * k, 0.2, pairs)
    looks = [([j], rng.uniform(0.3, 0.9, (n, 1))) for j in range(k)]
    looks += [([j for j in range(k) if rooms[j] == r], rng.uniform(0.1, 0.9, (n, 3)))
              for r in ("r0", "r1", "r2")]
    with_matrix = JointViewGain(sm, range(n), 0.01, outcome_limit=None).gains(looks)
    monkeypatch.setattr(jg, "MATRIX_OBJECTS", 0)
    gathered = JointViewGain(sm, range(n), 0.01, outcome_limit=None).gains(looks)
    np.testing.assert_allclose(with_matrix, gathered, rtol=0, atol=TOL)
    assert np.all(with_matrix > 0)
