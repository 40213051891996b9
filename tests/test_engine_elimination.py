"""The engine's elimination method equals the dense joint and brute force (docs/design.md §4.8).

Random small houses (:func:`assemble_graph`) with extra relational factors of scope 2-3 over the
location variables, random miss / detection evidence: the elimination method
(:mod:`fg_tea.beliefs.eliminated`) gives the dense method's and an explicit enumeration's single
and pairwise marginals, joints of three, every hypothetical posterior, unseen probabilities, the
MAP arrangement and the K best arrangements to 1e-12; gtsam agrees; an EFE and a lookahead
decision on such a belief are the dense method's; a graph beyond the budget is refused in one
line; the EFE planner refuses a joint gain it cannot compute in one line.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import fg_tea.beliefs.eliminated as eliminated
from fg_tea.beliefs.eliminated import (ELIMINATION_FROM, EliminationPlan, EliminationRefused,
                                       EliminatedLocationModel)
from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.beliefs.factors import Factor
from fg_tea.beliefs.graph import assemble_graph
from fg_tea.common.errors import PlannerRefused
from fg_tea.model.spec import load_model
from fg_tea.planning.base import DistanceTable
from fg_tea.planning import eliminated_gain
from fg_tea.planning.efe import EFEPlanner, joint_information_gain, view_joint_information_gain
from fg_tea.planning.lookahead import LookaheadPlanner

ROOT = Path(__file__).resolve().parents[1]
JOINT = load_model(ROOT / "models" / "joint.toml")
LIKELIHOOD = JOINT.with_overrides(positive_update="likelihood")
TOL = 1e-12
CATEGORIES = ["kettle", "teabag", "mug", "thing0", "thing1"]


def random_graph(rng: np.random.Generator, model=LIKELIHOOD, n: int | None = None, k: int | None = None,
                 zeros: bool = False):
    n = int(rng.integers(2, 5)) if n is None else n
    k = int(rng.integers(2, 6)) if k is None else k
    objects = [f"o{i}" for i in range(n)]
    graph = assemble_graph(model, [f"s{j}" for j in range(k)], [f"r{int(rng.integers(0, 2))}" for _ in range(k)],
                           objects, CATEGORIES[:n], rng.gamma(1.0, 1.0, (n, k)) + 0.02,
                           capacities=[[None, 1, 2][int(rng.integers(0, 3))] for _ in range(k)])
    extra = []
    for t in range(int(rng.integers(1, 3))):
        scope = tuple(rng.choice(n, size=min(n, int(rng.integers(2, 4))), replace=False))
        table = rng.gamma(1.0, 1.0, (k,) * len(scope))
        if zeros:
            table[(0,) * len(scope)] = 0.0
        extra.append(Factor(tuple(objects[i] and f"L[{objects[i]}]" for i in scope), table, f"user{t}"))
    return replace(graph, extra=tuple(extra))


def evidence(rng: np.random.Generator, engines, graph, looks: int = 3) -> None:
    for _ in range(looks):
        site = graph.sites[int(rng.integers(0, len(graph.sites)))]
        outcome = {o: bool(rng.random() < 0.3) for o in graph.objects if rng.random() < 0.7}
        for e in engines:
            e.observe_site(site, outcome)


def brute_joint(graph, model, looks) -> np.ndarray:
    """P(L) by explicit loops over every arrangement: priors, each look's likelihood, pair,
    capacity and extra factors."""
    n, k = len(graph.objects), len(graph.sites)
    mu, fp = model.miss_likelihood, model.false_positive_rate
    index = {f"L[{o}]": i for i, o in enumerate(graph.objects)}
    table = np.zeros((k,) * n)
    for x in itertools.product(range(k), repeat=n):
        w = math.prod(float(f.table[x[i]] / f.table.sum()) for i, f in enumerate(graph.location_priors))
        for site, outcome in looks:
            j = graph.sites.index(site)
            for o, seen in outcome.items():
                at = x[graph.objects.index(o)] == j
                w *= ((1 - mu) if at else fp) if seen else (mu if at else 1.0)
        for p in graph.pairs:
            a, b = x[graph.objects.index(p.a)], x[graph.objects.index(p.b)]
            w *= p.same_site if a == b else (p.same_room if graph.rooms[a] == graph.rooms[b] else 1.0)
        if graph.capacity_active:
            for j, c in enumerate(graph.capacities):
                if c is not None:
                    w *= graph.capacity_penalty ** max(0, x.count(j) - c)
        for f in graph.extra:
            w *= float(f.table[tuple(x[index[v]] for v in f.variables)])
        table[x] = w
    return table / table.sum()


def marginal_of(joint: np.ndarray, axes) -> np.ndarray:
    other = tuple(a for a in range(joint.ndim) if a not in axes)
    reduced = joint.sum(axis=other)
    order = sorted(axes)
    return np.moveaxis(reduced, [order.index(a) for a in axes], list(range(len(axes))))


@pytest.mark.parametrize("space", ["linear", "log"])
@pytest.mark.parametrize("seed", range(14))
def test_elimination_equals_dense_and_brute_force(seed, space, monkeypatch):
    if space == "log":     # every query through log-space elimination (wide evidence ranges)
        monkeypatch.setattr(eliminated, "LINEAR_RANGE", -1.0)
    rng = np.random.default_rng(seed)
    graph = random_graph(rng, zeros=seed % 3 == 0)
    elim = BeliefEngine(graph, LIKELIHOOD, location_solver="elimination")
    dense = BeliefEngine(graph, LIKELIHOOD, location_solver="dense")
    assert (elim.location_method, dense.location_method) == ("elimination", "dense")
    looks = []
    for _ in range(3):
        site = graph.sites[int(rng.integers(0, len(graph.sites)))]
        outcome = {o: bool(rng.random() < 0.3) for o in graph.objects if rng.random() < 0.7}
        try:
            dense.observe_site(site, outcome)
        except Exception:   # a contradiction (a hard zero): both refuse it alike
            with pytest.raises(Exception):
                elim.observe_site(site, outcome)
            continue
        elim.observe_site(site, outcome)
        looks.append((site, outcome))
    truth = brute_joint(graph, LIKELIHOOD, looks)
    n = len(graph.objects)
    q = np.stack([marginal_of(truth, (i,)) for i in range(n)])
    assert np.abs(elim.location_matrix() - q).max() < TOL
    assert np.abs(elim.location_matrix() - dense.location_matrix()).max() < TOL
    pw = elim.pairwise()
    assert np.abs(pw - dense.pairwise()).max() < TOL
    for a in range(n):
        for b in range(n):
            if a != b:
                assert np.abs(pw[a, b] - marginal_of(truth, (a, b))).max() < TOL
    if n >= 3:
        names = [graph.objects[i] for i in (2, 0, 1)]
        assert np.abs(elim.joint(names) - marginal_of(truth, (2, 0, 1))).max() < TOL
    for got, want in zip(elim.hypothetical_all(), dense.hypothetical_all()):
        assert np.abs(got - want).max() < TOL
    for o in graph.objects:
        assert elim.unseen_probability(o) == dense.unseen_probability(o)
    best = np.unravel_index(int(np.argmax(truth)), truth.shape)
    assert elim.map_estimate() == {o: graph.sites[int(best[i])] for i, o in enumerate(graph.objects)}
    ranked = elim._eliminated().kbest(4)
    flat = truth.ravel()
    top = np.sort(flat)[::-1][:4]
    np.testing.assert_allclose([p for p, _ in ranked], top[:len(ranked)], rtol=0, atol=TOL)
    for p, x in ranked:
        assert abs(truth[x] - p) < TOL
    assert elim.check_against_gtsam() < 1e-9


@pytest.mark.parametrize("seed", range(4))
def test_collapse_updates_match_dense(seed):
    """eq. 4's collapse (the bundled default) moves correlated objects; both methods agree."""
    rng = np.random.default_rng(100 + seed)
    graph = random_graph(rng, model=JOINT, n=3, k=4)
    elim = BeliefEngine(graph, JOINT, location_solver="elimination")
    dense = BeliefEngine(graph, JOINT, location_solver="dense")
    evidence(rng, [elim, dense], graph)
    assert np.abs(elim.location_matrix() - dense.location_matrix()).max() < TOL
    for got, want in zip(elim.hypothetical_all(), dense.hypothetical_all()):
        assert np.abs(got - want).max() < TOL


def test_site_weights_of_coupled_looks_enter_exactly():
    """Occlusion's site-local W[j, S] (eq. 59) and capacity, as counts over coarse copies."""
    rng = np.random.default_rng(5)
    n, k = 3, 4
    rooms = ["a", "a", "b", "b"]
    unary = rng.gamma(1.0, 1.0, (n, k))
    weights = np.ones((k, 1 << n))
    weights[1] = rng.gamma(1.0, 1.0, 1 << n)
    extra = [((0, 2), np.log(rng.gamma(1.0, 1.0, (k, k))))]
    plan = EliminationPlan(["a", "b", "c"], k, rooms, np.ones((n, n)), np.ones((n, n)), extra,
                           [1, None, None, 1], 0.2, weights)
    got = EliminatedLocationModel(plan, unary).pairwise()
    table = np.zeros((k,) * n)
    for x in itertools.product(range(k), repeat=n):
        w = math.prod(unary[o, x[o]] for o in range(n)) * math.exp(extra[0][1][x[0], x[2]])
        for j in range(k):
            mask = sum(1 << o for o in range(n) if x[o] == j)
            w *= weights[j, mask] * (0.2 ** max(0, x.count(j) - 1) if j in (0, 3) else 1.0)
        table[x] = w
    table /= table.sum()
    for a in range(n):
        for b in range(n):
            if a != b:
                assert np.abs(got[a, b] - marginal_of(table, (a, b))).max() < TOL


def test_auto_dispatch_keeps_old_methods_and_takes_elimination_for_big_extra():
    rng = np.random.default_rng(3)
    small = random_graph(rng, n=3, k=5)
    assert BeliefEngine(small, LIKELIHOOD).location_method == "dense"
    assert BeliefEngine(replace(small, extra=()), LIKELIHOOD).location_method == "dense"
    big = random_graph(rng, n=5, k=14)
    assert big.joint_size > ELIMINATION_FROM
    assert BeliefEngine(big, LIKELIHOOD).location_method == "elimination"
    assert BeliefEngine(replace(big, extra=()), LIKELIHOOD).location_method == "structured"


def decision_inputs(graph):
    k = len(graph.sites)
    xs = np.linspace(0.0, 6.0, k)
    distances = DistanceTable(graph.sites, tuple(float(abs(x - 1.0)) for x in xs),
                              tuple(tuple(float(abs(a - b)) for b in xs) for a in xs))
    relevance = {o: 1.0 for o in graph.objects}
    return distances, relevance


@pytest.mark.parametrize("seed", range(3))
def test_planner_decisions_equal_the_dense_methods(seed):
    rng = np.random.default_rng(200 + seed)
    graph = random_graph(rng, n=3, k=5)
    elim = BeliefEngine(graph, LIKELIHOOD, location_solver="elimination")
    dense = BeliefEngine(graph, LIKELIHOOD, location_solver="dense")
    evidence(rng, [elim, dense], graph, looks=2)
    distances, relevance = decision_inputs(graph)
    objects = list(graph.objects)
    for planner in (EFEPlanner(LIKELIHOOD.planning), LookaheadPlanner(LIKELIHOOD.planning)):
        planner.check(elim, objects)
        got = planner.choose(elim, objects, relevance, distances, {})
        want = planner.choose(dense, objects, relevance, distances, {})
        assert (got.object, got.viewpoint) == (want.object, want.viewpoint)
        assert got.total == pytest.approx(want.total, abs=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_joint_gain_by_elimination_equals_the_dense_joints(seed):
    """The EFE planner's exact joint gain from the elimination method (close looks and looks over
    several sites) equals the dense joint's, to 1e-12."""
    rng = np.random.default_rng(300 + seed)
    graph = random_graph(rng, n=3, k=5)
    elim = BeliefEngine(graph, LIKELIHOOD, location_solver="elimination")
    dense = BeliefEngine(graph, LIKELIHOOD, location_solver="dense")
    evidence(rng, [elim, dense], graph, looks=2)
    mu, fp = LIKELIHOOD.miss_likelihood, LIKELIHOOD.false_positive_rate
    model = elim.eliminated_model()
    for unresolved in ([0, 1, 2], [2, 0], [1]):
        want = joint_information_gain(dense.location_joint(), unresolved, mu, fp)
        got = eliminated_gain.site_information_gain(model, unresolved, mu, fp)
        assert np.abs(got - want).max() < TOL
        sites = [1, 3]
        prob = rng.uniform(0.2, 0.9, (len(unresolved), 2))
        want = view_joint_information_gain(dense.location_joint(), unresolved, sites, prob, 0.01)
        got = eliminated_gain.view_information_gain(model, unresolved, sites, prob, 0.01)
        assert np.abs(got - want).max() < TOL


def test_efe_decides_by_the_elimination_gain_beyond_the_dense_limit(monkeypatch):
    """Beyond the dense limit (here lowered to 0 so that the dense decision can be compared) the
    EFE planner takes its joint gain from the elimination method and decides as on the dense joint."""
    rng = np.random.default_rng(400)
    graph = random_graph(rng, n=3, k=5)
    elim = BeliefEngine(graph, LIKELIHOOD, location_solver="elimination")
    dense = BeliefEngine(graph, LIKELIHOOD, location_solver="dense")
    evidence(rng, [elim, dense], graph, looks=2)
    distances, relevance = decision_inputs(graph)
    want = EFEPlanner(LIKELIHOOD.planning).choose(dense, list(graph.objects), relevance, distances, {})
    monkeypatch.setattr(eliminated_gain, "DENSE_LIMIT", 0)
    assert eliminated_gain.eliminated_gain_model(dense) is None
    got = EFEPlanner(LIKELIHOOD.planning).choose(elim, list(graph.objects), relevance, distances, {})
    assert (got.object, got.viewpoint) == (want.object, want.viewpoint)
    for a, b in zip(got.candidates, want.candidates):
        assert a.information_gain == pytest.approx(b.information_gain, abs=TOL)


def big_graph():
    """45 sites, 5 objects, a factor over three: beyond the dense joint (184,528,125 states)."""
    rng = np.random.default_rng(11)
    model = LIKELIHOOD.with_overrides(relations=tuple(r for r in LIKELIHOOD.relations
                                                      if r.kind != "capacity"))
    graph = assemble_graph(model, [f"s{j}" for j in range(45)], [f"r{j // 4}" for j in range(45)],
                           [f"o{i}" for i in range(5)], CATEGORIES, rng.gamma(1.0, 1.0, (5, 45)) + 0.02)
    user = Factor(("L[o0]", "L[o2]", "L[o3]"), rng.gamma(1.0, 1.0, (45, 45, 45)), "user")
    return model, replace(graph, extra=(user,))


def test_beyond_the_dense_joint_elimination_answers_and_efe_plans_on_it():
    model, graph = big_graph()
    belief = BeliefEngine(graph, model)
    assert belief.location_method == "elimination"
    belief.observe_site("s3", {o: False for o in graph.objects})
    q = belief.location_matrix()
    np.testing.assert_allclose(q.sum(axis=1), 1.0, atol=1e-12)
    pw = belief.pairwise()
    np.testing.assert_allclose(pw[0, 2].sum(axis=1), q[0], atol=1e-12)
    miss, seen = belief.hypothetical_all()
    assert miss.shape == seen.shape == (5, 45, 5, 45)
    planner = EFEPlanner(model.planning)
    planner.check(belief, list(graph.objects))
    distances, relevance = decision_inputs(graph)
    objects = ["o0", "o2"]
    decision = planner.choose(belief, objects, {o: 1.0 for o in objects}, distances, {})
    gains = planner.information_gain(belief, objects)[0]
    assert gains.shape == (2, 45) and np.all(gains >= -1e-12)
    assert decision.object in objects and decision.viewpoint in graph.sites


def test_efe_refuses_in_one_line_a_joint_gain_it_cannot_compute():
    """A factorised belief asked for the joint gain beyond the dense limit with more objects than
    the subset program takes: no exact route, one line."""
    objects = [f"o{i}" for i in range(12)]
    model = LIKELIHOOD.with_overrides(structure="factorised", relations=())
    graph = assemble_graph(model, ["s0", "s1", "s2", "s3"], ["r0"] * 4, objects, ["x"] * 12, np.ones((12, 4)))
    belief = BeliefEngine(graph, model)
    with pytest.raises(PlannerRefused) as err:
        EFEPlanner(model.planning, information="joint").check(belief, objects)
    text = str(err.value)
    assert "\n" not in text and text.startswith("efe planner: the exact joint information gain")
    assert "16,777,216 states" in text


def test_over_budget_is_refused_in_one_line():
    rng = np.random.default_rng(1)
    objects = [f"o{i}" for i in range(5)]
    graph = assemble_graph(LIKELIHOOD, [f"s{j}" for j in range(45)], [f"r{j // 4}" for j in range(45)],
                           objects, CATEGORIES, rng.gamma(1.0, 1.0, (5, 45)) + 0.02,
                           capacities=[1 if j % 3 == 0 else None for j in range(45)])
    user = Factor(("L[o0]", "L[o2]", "L[o3]"), rng.gamma(1.0, 1.0, (45, 45, 45)), "user")
    with pytest.raises(EliminationRefused) as err:
        BeliefEngine(replace(graph, extra=(user,)), LIKELIHOOD)
    text = str(err.value)
    assert "\n" not in text
    assert text.startswith("exact inference over L[o0], L[o1], L[o2], L[o3], L[o4] by ")
    assert "elimination width" in text and "entries" in text and "refused (no approximation" in text


def test_misses_too_wide_for_scaled_tables_run_in_log_space_and_stay_exact():
    """Evidence of about 1e-200 at one site for every object (hundreds of misses): the products of
    such tables could leave float range, so the linear route's guard (LINEAR_RANGE) sends every
    query to log-space elimination, which still equals the dense joint."""
    rng = np.random.default_rng(21)
    graph = random_graph(rng, n=3, k=4)
    elim = BeliefEngine(graph, LIKELIHOOD, location_solver="elimination")
    dense = BeliefEngine(graph, LIKELIHOOD, location_solver="dense")
    looks = int(200 / -math.log10(LIKELIHOOD.miss_likelihood))
    for e in (elim, dense):
        for _ in range(looks):
            e.observe_site(graph.sites[0], {o: False for o in graph.objects})
    model = elim._eliminated()
    spread = sum(eliminated._log_range(model._log_unary[o]) for o in range(3))
    assert spread > eliminated.LINEAR_RANGE
    assert np.abs(elim.location_matrix() - dense.location_matrix()).max() < TOL
    assert np.abs(elim.pairwise() - dense.pairwise()).max() < TOL


def test_efe_refuses_before_the_search_a_gain_whose_elimination_is_over_budget():
    """Capacity on three of 45 sites: the belief is answered (update, hypotheticals), but the
    joint gain would need a 32,805,000-entry table; the planner says so in one line in check()."""
    rng = np.random.default_rng(2)
    graph = assemble_graph(LIKELIHOOD, [f"s{j}" for j in range(45)], [f"r{j // 4}" for j in range(45)],
                           [f"o{i}" for i in range(5)], CATEGORIES, rng.gamma(1.0, 1.0, (5, 45)) + 0.02,
                           capacities=[1 if j % 15 == 0 else None for j in range(45)])
    user = Factor(("L[o0]", "L[o2]", "L[o3]"), rng.gamma(1.0, 1.0, (45, 45, 45)), "user")
    belief = BeliefEngine(replace(graph, extra=(user,)), LIKELIHOOD)
    assert belief.location_method == "elimination"
    belief.hypothetical_all()
    with pytest.raises(PlannerRefused) as err:
        EFEPlanner(LIKELIHOOD.planning).check(belief, list(graph.objects))
    text = str(err.value)
    assert "\n" not in text and text.startswith("efe planner: no exact joint information gain: exact inference")
    assert "elimination width" in text and text.endswith("use information = 'factorised'")
