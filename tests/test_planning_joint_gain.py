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


def _structured(*parts):
    """The structured model of drawn parts, or None where a hard capacity with too many objects
    leaves a zero partition function."""
    try:
        return StructuredLocationModel(*parts)
    except Exception:
        return None


def _model_and_look(data):
    """A drawn small model's parts, a look at it, and its structured model (or None)."""
    parts = data.draw(small_models())
    look = data.draw(looks_at(parts[1], parts[0].shape[0]))
    return parts, look, _structured(*parts)


@settings(max_examples=60, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_structured_gain_equals_enumeration_of_every_outcome(data):
    (unary, rooms, caps, penalty, pairs), (sites, observed, prob, fp), model = _model_and_look(data)
    if model is None:
        return
    n, k = unary.shape
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
    import fg_tea.planning.view_weights as jg

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


# ---------------------------------------------------------------------------------- pruning
# docs/design.md §6.2, eq. (56): I(C_o ; Y_o) <= I(L_o ; Y_v) <= min(H(L_o), sum_u I(C_u ; Y_u)),
# and the EFE planner skips the exact gain of every candidate whose score with the upper bound is
# above the best score with a lower bound.

@settings(max_examples=60, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_gain_bounds_hold_on_random_models(data):
    (unary, rooms, caps, penalty, pairs), (sites, observed, prob, fp), model = _model_and_look(data)
    if model is None:
        return
    n, _ = unary.shape
    solver = JointViewGain(model, observed, fp, outcome_limit=None)
    exact = solver.gains([(sites, prob)])
    lower, upper = solver.gain_bounds([(sites, prob)])
    assert np.all(lower <= exact) and np.all(exact <= upper)
    # The lower bound is o's own outcome: the exact gain of a look that reports o alone.
    for i, o in enumerate(observed):
        own = JointViewGain(model, [o], fp, outcome_limit=None).gain(sites, prob[i:i + 1])
        assert abs(own[0] - (lower[i, 0] + 1e-9)) < TOL


@settings(max_examples=60, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_objects_without_pair_factors_get_the_capacity_bound(data):
    # Free some objects of every pair factor: they then depend on the others only through
    # capacity, and B_o >= I(L_o ; L_{-o}) (checked on the enumerated joint) tightens the upper
    # bound, which must still hold.
    unary, rooms, caps, penalty, pairs = data.draw(small_models())
    n, _ = unary.shape
    free = data.draw(st.lists(st.integers(0, n - 1), min_size=1, unique=True))
    site, room = pairs.same_site.copy(), pairs.same_room.copy()
    for o in free:
        site[o, :] = site[:, o] = room[o, :] = room[:, o] = 1.0
    pairs = PairWeights(site, room)
    sites, observed, prob, fp = data.draw(looks_at(rooms, n))
    model = _structured(unary, rooms, caps, penalty, pairs)
    if model is None:
        return
    joint = dense_joint(unary, rooms, caps, penalty, pairs)
    solver = JointViewGain(model, observed, fp, outcome_limit=None)
    bound = solver._independence_bound()
    for o in range(n):
        others = np.arange(n) != o
        if np.any(site[o, others] != 1) or np.any(room[o, others] != 1):
            assert bound[o] == np.inf
            continue
        if n == 1:
            assert bound[o] == 0.0
            continue
        p_o = joint.sum(axis=tuple(a for a in range(n) if a != o))
        rest = joint.sum(axis=o)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = joint / (np.expand_dims(rest, o) * p_o.reshape([-1 if a == o else 1 for a in range(n)]))
            mi = float(np.sum(np.where(joint > 0, joint * np.log(ratio), 0.0)))
        assert mi <= bound[o] + 1e-12
    exact = solver.gains([(sites, prob)])
    lower, upper = solver.gain_bounds([(sites, prob)])
    assert np.all(lower <= exact) and np.all(exact <= upper)


def _glances_and_close_looks(n, seed, site, misses, rng_seed):
    """A joint n-object, 12-site belief (rooms of 4) after misses at `site`, its structured model,
    an RNG, and views: a glance at each room and a close look at each site, random p_o,j."""
    graph, model = joint_graph(n, 12, rooms_of=4, seed=seed)
    belief = BeliefEngine(graph, model)
    belief.observe_site(site, misses)
    rng = np.random.default_rng(rng_seed)
    views = [(list(range(r, r + 4)), rng.uniform(0.1, 0.9, (n, 4))) for r in (0, 4, 8)]
    views += [([j], rng.uniform(0.5, 0.9, (n, 1))) for j in range(12)]
    return belief, belief.structured_model(), rng, views


def test_gain_bounds_hold_for_restricted_gains():
    belief, sm, rng, views = _glances_and_close_looks(6, 3, "s5", {"o0": False, "o1": False}, 2)
    solver = JointViewGain(sm, range(6), 1e-4, outcome_limit=12 * 5 ** 2,
                           coupling=coupling_strength(belief))
    approx = solver.gains(views)
    assert solver.restricted > 0
    lower, upper = solver.gain_bounds(views)
    assert np.all(lower <= approx) and np.all(approx <= upper)


def test_gains_of_a_mask_equal_the_full_gains():
    belief, sm, rng, views = _glances_and_close_looks(5, 4, "s2", {"o0": False, "o3": False}, 3)
    for limit in (None, 12 * 5 ** 2):
        full = JointViewGain(sm, range(5), 1e-4, outcome_limit=limit,
                             coupling=coupling_strength(belief)).gains(views)
        need = rng.random(full.shape) < 0.2
        part = JointViewGain(sm, range(5), 1e-4, outcome_limit=limit,
                             coupling=coupling_strength(belief)).gains(views, need)
        assert np.all(np.isfinite(part[need]))
        done = np.isfinite(part)
        # The same numbers up to the last bit or two: a smaller batch may change the order of a
        # matrix product's sums inside BLAS, nothing else.
        np.testing.assert_allclose(part[done], full[done], rtol=1e-13, atol=1e-15)
        assert not np.any(np.isfinite(part[:, ~need.any(axis=0)]))


class _Views:
    """The part of a ViewModel the planner reads: the views, their names, p_max."""

    def __init__(self, views, max_probability):
        self.views = list(views)
        self.names = [v.name for v in self.views]
        self.max_probability = max_probability


def _views_of(belief, rng, twin: bool = False):
    """A close look at every site and a glance over every room, random p; with `twin`, a second
    glance identical to the first but for its name (so its candidates tie exactly)."""
    sites, n = list(belief.sites), len(belief.objects)
    sm = belief.structured_model()
    views = [View(s, "site", "", (j,), rng.uniform(0.6, 0.9, (n, 1)), np.full((n, 1), 0.2),
                  np.full((n, 1), np.nan)) for j, s in enumerate(sites)]
    for r, members in enumerate(sm.room_sites):
        m = len(members)
        prob = rng.uniform(0.05, 0.8, (n, m))
        views.append(View(f"room{r}_glance", "room", f"room{r}", tuple(int(j) for j in members),
                          prob, 1.0 - prob, np.full((n, m), np.nan)))
    if twin:
        first = views[len(sites)]
        views.insert(len(sites) + 1, View(first.name + "_twin", first.kind, first.room,
                                          first.sites, first.probability, first.miss, first.pixels))
    return _Views(views, 0.9)


def _distances(names, rng, twin_of=None):
    xy = {v: rng.uniform(0, 12, 2) for v in names}
    if twin_of is not None:
        xy[twin_of + "_twin"] = xy[twin_of]
    pts = np.array([xy[v] for v in names])
    agent = rng.uniform(0, 12, 2)
    return DistanceTable(tuple(names), tuple(float(x) for x in np.linalg.norm(pts - agent, axis=1)),
                         tuple(tuple(float(x) for x in row)
                               for row in np.linalg.norm(pts[:, None] - pts[None], axis=2)))


def _bundled_joint_graph(n: int, k: int, seed: int):
    """The bundled joint model's relations (capacity, teabag-kettle co-location): every object
    but the kettle and the teabag has no pair factor, so its gain's upper bound uses B_o."""
    from fg_tea.beliefs.graph import assemble_graph
    from test_beliefs_structured import JOINT

    rng = np.random.default_rng(seed)
    categories = ["kettle", "teabag"] + [f"thing{i}" for i in range(n - 2)]
    graph = assemble_graph(JOINT, [f"s{j}" for j in range(k)], [f"room{j // 4}" for j in range(k)],
                           [f"o{i}" for i in range(n)], categories[:n], rng.random((n, k)) + 0.05,
                           capacities=[1 if j % 3 == 0 else None for j in range(k)])
    return graph, JOINT


@pytest.mark.parametrize("n,k,seed,relations", [(4, 16, 0, "all pairs"), (4, 16, 1, "all pairs"),
                                                (5, 10, 2, "all pairs"), (5, 12, 3, "all pairs"),
                                                (6, 8, 4, "all pairs"), (4, 16, 5, "bundled"),
                                                (5, 12, 6, "bundled"), (6, 8, 7, "bundled")])
def test_pruned_choice_equals_the_unpruned_choice(n, k, seed, relations):
    if relations == "bundled":
        graph, model = _bundled_joint_graph(n, k, seed)
    else:
        graph, model = joint_graph(n, k, rooms_of=4, seed=seed)
    belief = BeliefEngine(graph, model)
    assert k ** n > DENSE_GAIN_LIMIT                       # the structured route
    rng = np.random.default_rng(seed)
    names = list(belief.objects)
    pruned_any = 0
    for step in range(4):
        site = belief.sites[int(rng.integers(k))]
        belief.observe_site(site, {o: False for o in names[:1 + step % n]})
        views = _views_of(belief, rng, twin=step % 2 == 1)
        first_glance = views.views[k].name
        dist = _distances(views.names, rng, first_glance if step % 2 == 1 else None)
        relevance = {o: float(rng.choice([1.0, 0.75, 0.5])) for o in names}
        inspected = {views.names[int(rng.integers(len(views.names)))]: 1}
        pruned = EFEPlanner(model.planning, information="joint").choose(
            belief, names, relevance, dist, inspected, views=views)
        full = EFEPlanner(model.planning, information="joint", prune=False).choose(
            belief, names, relevance, dist, inspected, views=views)
        assert (pruned.object, pruned.viewpoint) == (full.object, full.viewpoint)
        assert abs(pruned.total - full.total) < 1e-12
        assert pruned.info["gain_solver"] == "structured"
        bounded = [c.gain_bound for c in pruned.candidates]
        assert pruned.info["bounded_gains"] == sum(bounded) < len(bounded)
        pruned_any += sum(bounded)
        assert not any(c.gain_bound for c in full.candidates)
        for p, f in zip(pruned.candidates, full.candidates):
            assert (p.object, p.viewpoint) == (f.object, f.viewpoint)
            if p.gain_bound:
                assert p.information_gain >= f.information_gain
                assert p.total <= f.total and p.total > pruned.total
                assert p.to_json()["information_gain_bound"] == "upper"
            else:
                assert abs(p.information_gain - f.information_gain) < 1e-12
                assert abs(p.total - f.total) < 1e-12
                assert "information_gain_bound" not in p.to_json()
    assert pruned_any > 0                                  # the test exercises the pruning


def test_a_tie_goes_to_the_first_candidate_with_or_without_pruning():
    # Two viewpoints that are one look under two names, at the same place: every one of their
    # candidates ties exactly, and the agent stands there, so they are the best.
    graph, model = joint_graph(4, 16, rooms_of=4, seed=7)
    belief = BeliefEngine(graph, model)
    names = list(belief.objects)
    rng = np.random.default_rng(7)
    views = _views_of(belief, rng, twin=True)
    first = views.views[16].name
    xy = {v: rng.uniform(5, 12, 2) for v in views.names}
    xy[first] = xy[first + "_twin"] = np.zeros(2)
    pts = np.array([xy[v] for v in views.names])
    dist = DistanceTable(tuple(views.names), tuple(float(x) for x in np.linalg.norm(pts, axis=1)),
                         tuple(tuple(float(x) for x in row)
                               for row in np.linalg.norm(pts[:, None] - pts[None], axis=2)))
    relevance = {o: 1.0 for o in names}
    got = [EFEPlanner(model.planning, information="joint", prune=p).choose(
        belief, names, relevance, dist, {}, views=views) for p in (True, False)]
    assert got[0].viewpoint == got[1].viewpoint == first
    assert got[0].object == got[1].object and got[0].total == got[1].total
    twin = [c for c in got[0].candidates if c.viewpoint == first + "_twin" and c.object == got[0].object]
    assert not twin[0].gain_bound and twin[0].total == got[0].total     # a tie, kept and exact


def _by_view(decision):
    """Each viewpoint's score (its best object's total), in the lookahead's order."""
    best: dict[str, float] = {}
    for c in decision.candidates:
        best[c.viewpoint] = min(best.get(c.viewpoint, np.inf), c.total)
    return sorted(best.items(), key=lambda item: item[1])


@pytest.mark.parametrize("n,k,seed,relations", [(4, 16, 0, "all pairs"), (5, 12, 3, "all pairs"),
                                                (4, 16, 5, "bundled"), (6, 8, 7, "bundled")])
@pytest.mark.parametrize("rank", [2, 3, 5])
def test_ranked_pruning_keeps_the_best_viewpoints_exact_and_in_order(n, k, seed, relations, rank):
    """With ``rank``, every viewpoint that could make the `rank` best keeps exact gains: the
    `rank` best viewpoints, their scores and their order equal the unpruned ones (the lookahead's
    root candidates); a bounded score is at most the exact one, and above the rank-th best or
    its viewpoint's own score."""
    if relations == "bundled":
        graph, model = _bundled_joint_graph(n, k, seed)
    else:
        graph, model = joint_graph(n, k, rooms_of=4, seed=seed)
    belief = BeliefEngine(graph, model)
    rng = np.random.default_rng(seed)
    names = list(belief.objects)
    bounded_any = 0
    for step in range(3):
        belief.observe_site(belief.sites[int(rng.integers(k))], {o: False for o in names[:1 + step % n]})
        views = _views_of(belief, rng, twin=False)
        dist = _distances(views.names, rng, None)
        relevance = {o: float(rng.choice([1.0, 0.75, 0.5])) for o in names}
        ranked = EFEPlanner(model.planning, information="joint", rank=rank).choose(
            belief, names, relevance, dist, {}, views=views)
        full = EFEPlanner(model.planning, information="joint", prune=False).choose(
            belief, names, relevance, dist, {}, views=views)
        top, exact = _by_view(ranked)[:rank], _by_view(full)[:rank]
        assert [v for v, _ in top] == [v for v, _ in exact]
        np.testing.assert_allclose([s for _, s in top], [s for _, s in exact], atol=1e-12)
        view_score = dict(_by_view(full))
        for p, f in zip(ranked.candidates, full.candidates):
            if p.gain_bound:  # a viewpoint out of the running, or an object that is not its best
                bounded_any += 1
                assert p.total <= f.total + 1e-12
                assert p.total > min(exact[-1][1], view_score[p.viewpoint])
    assert bounded_any > 0
    with pytest.raises(ValueError, match="rank must be at least 1"):
        EFEPlanner(model.planning, rank=0)


@settings(max_examples=60, derandomize=True, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_one_object_gain_needs_only_its_marginal(data):
    """With one object reported, the closed form on its marginal is the exact gain: equal to the
    structured program and to the dense joint (other objects correlated and unreported)."""
    from fg_tea.planning.efe import one_object_information_gain

    (unary, rooms, caps, penalty, pairs), (sites, observed, prob, fp), model = _model_and_look(data)
    if model is None:
        return
    o = observed[0]
    joint = dense_joint(unary, rooms, caps, penalty, pairs)
    q = joint.sum(axis=tuple(a for a in range(joint.ndim) if a != o))
    prob = prob[:1]
    got = one_object_information_gain(q, [(sites, prob[0])], fp)
    np.testing.assert_allclose(got, view_joint_information_gain(joint, [o], sites, prob, fp),
                               rtol=0, atol=1e-12)
    if np.all(prob + (len(sites) - 1) * fp <= 1.0):   # outcome rows that are distributions
        np.testing.assert_allclose(got, JointViewGain(model, [o], fp, outcome_limit=None).gain(sites, prob),
                                   rtol=0, atol=TOL)


def test_one_object_gain_agrees_where_rows_are_clipped_and_refuses_bad_input():
    from fg_tea.planning.efe import one_object_information_gain

    q = np.array([0.5, 0.3, 0.2])
    looks = [([0, 1], np.array([1.0, 0.5])), ([2], np.array([0.9]))]   # 1 + fp > 1: clipped
    want = [view_joint_information_gain(q, [0], s, p[None], 0.01)[0] for s, p in looks]
    np.testing.assert_allclose(one_object_information_gain(q, looks, 0.01), want, rtol=0, atol=1e-15)
    for bad in ([], [([0, 1], np.array([0.5]))]):
        with pytest.raises(ValueError):
            one_object_information_gain(q, bad, 0.0)
    with pytest.raises(ValueError, match="sums to"):
        one_object_information_gain(np.zeros(3), looks, 0.0)


def test_the_one_object_closed_form_is_the_structured_gain_after_evidence():
    """With one object left, the closed form on the engine's marginal equals the structured
    solver's gain on a belief beyond the dense-gain switch, for close looks and a glance (the
    planner's own use is tested in test_planning_lookahead.py)."""
    graph, model = joint_graph(5, 10, rooms_of=5, seed=5)
    belief = BeliefEngine(graph, model)
    belief.observe_site("s1", {"o0": False, "o2": False})
    belief.observe_site("s2", {"o1": True})
    rng = np.random.default_rng(0)
    looks = [([j], rng.uniform(0.05, 0.95, 1)) for j in range(10)] + [(list(range(5)), rng.uniform(0.05, 0.95, 5))]
    from fg_tea.planning.efe import one_object_information_gain
    for o in (0, 3):
        solver = structured_gain(belief, [o])
        assert solver is not None
        want = solver.gains([(s, p[None]) for s, p in looks])[0]
        got = one_object_information_gain(belief.location_matrix()[o], looks, model.false_positive_rate)
        np.testing.assert_allclose(got, want, rtol=0, atol=TOL)
