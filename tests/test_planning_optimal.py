"""The Bayes-optimal search limit: exact DP checked by hand, by a naive recursion and by
exhaustive simulation of every planner on every hidden truth of small seeded worlds."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from fg_tea.common.errors import PlannerRefused

from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.model.spec import Relation, load_model
from fg_tea.planning import OptimalPlanner, euclidean_distances, make_planner, planner_names
from fg_tea.planning.optimal import expected_travel_table, truth_table
from houses import make_scenario


def perfect_sensor(model):
    """Near-deterministic detection: exact conditioning in the engine (the DP's model)."""
    return model.with_overrides(miss_likelihood=1e-12, false_positive_rate=0.0,
                                positive_update="likelihood")


def random_world(seed, n_sites, joint):
    rng = np.random.default_rng(seed)
    rooms = ["kitchen", "lounge"]
    sites = [(f"s{i}", rooms[int(rng.integers(2))], tuple(rng.uniform(-4, 4, 2)),
              {"mug": float(rng.uniform(0.05, 1)), "teabag": float(rng.uniform(0.05, 1))},
              1 if i == 0 else None)
             for i in range(n_sites)]
    scenario = make_scenario(sites, [("mug", "mug", "s0"), ("teabag", "teabag", "s1")])
    model = load_model("joint" if joint else "factorised")
    if joint:
        model = model.with_overrides(relations=(
            Relation("capacity", penalty=0.05),
            Relation("co_location", categories=("teabag", "mug"), same_site=6.0, same_room=2.0)))
    return scenario, perfect_sensor(model)


def reference_value(start, between, truths):
    """Naive recursion over the belief tree (no vectorisation, no subset table).

    truths: list of (sites per object, probability). Returns min over first sites of expected travel.
    """
    k = len(start)

    def value(visited, current, group):
        total = sum(p for _, p in group)
        if all(all(s in visited for s in t) for t, _ in group):
            return 0.0
        best = np.inf
        for j in range(k):
            if j in visited:
                continue
            step = start[j] if current is None else between[current][j]
            outcomes: dict[tuple, list] = {}
            for t, p in group:
                outcomes.setdefault(tuple(s == j for s in t), []).append((t, p))
            rest = sum(sum(p for _, p in g) / total * value(visited | {j}, j, g)
                       for g in outcomes.values())
            best = min(best, step + rest)
        return best

    return value(frozenset(), None, truths)


def simulate(planner, belief, truth, distances, objects, max_steps=40):
    """Run a planner to completion on one hidden truth (object -> site); return metres travelled."""
    belief = belief.copy()
    unresolved = list(objects)
    inspected: dict[str, int] = {}
    travel = 0.0
    for _ in range(max_steps):
        decision = planner.choose(belief, unresolved, {o: 1.0 for o in unresolved}, distances,
                                  inspected)
        site = decision.viewpoint
        travel += distances.from_agent(site)
        distances = distances.moved_to(site)
        seen = {o: truth[o] == site for o in unresolved}
        belief.observe_site(site, seen)
        if not all(seen.values()):
            inspected[site] = inspected.get(site, 0) + 1
        unresolved = [o for o in unresolved if not seen[o]]
        if not unresolved:
            return travel
    raise AssertionError(f"{planner.name} did not finish within {max_steps} inspections")


# ----------------------------------------------------------------------------------- by hand
def test_hand_worked_two_sites_one_object():
    # q(mug) = [0.6, 0.4]; agent at x = 0, A at x = 1, B at x = 3 (all on one line).
    scenario = make_scenario([("A", "r", (1.0, 0.0), {"mug": 0.6}),
                              ("B", "r", (3.0, 0.0), {"mug": 0.4})], [("mug", "mug", "A")])
    model = perfect_sensor(load_model("factorised"))
    belief = BeliefEngine(scenario, model)
    dist = euclidean_distances(scenario, (0.0, 0.0))  # agent->A 1, agent->B 3, A<->B 2
    d = OptimalPlanner().choose(belief, ["mug"], {"mug": 1.0}, dist, {})
    # First A: 1 + P(mug at B) * d(A, B) = 1 + 0.4 * 2 = 1.8
    # First B: 3 + P(mug at A) * d(B, A) = 3 + 0.6 * 2 = 4.2
    assert [(c.viewpoint, round(c.total, 12)) for c in d.candidates] == [("A", 1.8), ("B", 4.2)]
    assert (d.object, d.viewpoint, d.total) == ("mug", "A", pytest.approx(1.8))
    assert d.info["expected_travel"] == pytest.approx(1.8)


def test_hand_worked_two_objects_adaptive():
    # Two objects, three sites on a line: C at x = -3, agent at 0, A at x = 1, B at x = 2.
    # q(mug) = [0.5, ~0, 0.5] and q(teabag) = [~0, ~1, ~0] (weights 1e-9): the teabag is at B.
    # Best plan: A, then B, then C only if the mug was not at A:
    #   mug at A: 1 + 1 = 2;  mug at C: 1 + 1 + 5 = 7;  expectation 0.5 * 2 + 0.5 * 7 = 4.5.
    # Alternatives: B, A, (C): 0.5 * 3 + 0.5 * (3 + 4) = 5.0;  C first: >= 3 + 5 = 8;
    # A, then C before B when the mug is missing: 0.5 * 2 + 0.5 * (1 + 4 + 5) = 6.0.
    scenario = make_scenario([("A", "r", (1.0, 0.0), {"mug": 1.0, "teabag": 1e-9}),
                              ("B", "r", (2.0, 0.0), {"mug": 1e-9, "teabag": 1.0}),
                              ("C", "r", (-3.0, 0.0), {"mug": 1.0, "teabag": 1e-9})],
                             [("mug", "mug", "A"), ("teabag", "teabag", "B")])
    model = perfect_sensor(load_model("factorised")).with_overrides(prior_floor=1e-12)
    belief = BeliefEngine(scenario, model)
    dist = euclidean_distances(scenario, (0.0, 0.0))
    d = OptimalPlanner().choose(belief, ["mug", "teabag"], {"mug": 1.0, "teabag": 1.0}, dist, {})
    # A first: 1 (to A) + 1 (to B) + 0.5 * 5 (B to C if the mug was not at A) = 4.5
    assert d.viewpoint == "A"
    assert d.total == pytest.approx(4.5, abs=1e-6)


# ----------------------------------------------------------------------------------- exactness
@pytest.mark.parametrize("seed,n_sites,joint", [(0, 3, False), (1, 4, False), (2, 3, True),
                                                (3, 4, True), (4, 5, True)])
def test_dp_equals_naive_recursion(seed, n_sites, joint):
    scenario, model = random_world(seed, n_sites, joint)
    belief = BeliefEngine(scenario, model)
    assert belief.correlated == joint
    objects = ["mug", "teabag"]
    eligible = list(range(n_sites))
    loc, p = truth_table(belief, objects, eligible)
    dist = euclidean_distances(scenario, scenario.start_position)
    start = np.array([dist.from_agent(s) for s in scenario.site_names])
    between = np.array([[dist.between(a, b) for b in scenario.site_names] for a in scenario.site_names])
    table = expected_travel_table(start, between, loc, p)
    truths = [(tuple(int(x) for x in t), float(w)) for t, w in zip(loc, p)]
    assert table.min() == pytest.approx(reference_value(start, between, truths), abs=1e-9)
    d = OptimalPlanner().choose(belief, objects, {"mug": 1.0, "teabag": 1.0}, dist, {})
    assert d.total == pytest.approx(table.min(), abs=1e-12)
    np.testing.assert_allclose([c.total for c in d.candidates], table, atol=1e-12)


@pytest.mark.parametrize("seed,n_sites,joint", [(10, 4, False), (11, 5, False), (12, 4, True),
                                                (13, 5, True), (14, 5, True)])
def test_optimal_is_never_worse_over_all_hidden_truths(seed, n_sites, joint):
    scenario, model = random_world(seed, n_sites, joint)
    belief = BeliefEngine(scenario, model)
    objects = ["mug", "teabag"]
    dist = euclidean_distances(scenario, scenario.start_position)
    joint_table = belief.location_joint()
    expected = {}
    # Every registered planner; the tree-search peers at their smallest budget (pouct:1000 and
    # pomcp:1000 follow the same code at ten times the cost).
    names = [n for n in planner_names() if not n.startswith(("pouct:", "pomcp:"))]
    if any(n.startswith("pouct:") for n in planner_names()):
        names.append("pouct:100")
    for name in names:
        try:  # a planner that cannot plan for this belief says so before the episode
            make_planner(name, model, np.random.default_rng(seed)).check(belief, objects)
        except PlannerRefused:
            continue
        total = 0.0
        for a, b in itertools.product(range(n_sites), repeat=2):
            # A fresh planner with the same seed for every truth: a stochastic planner (random,
            # POUCT) then follows one policy, a function of what it has observed. Sharing one
            # generator across truths would let its draws differ per truth, a different policy
            # for each, whose weighted sum can fall below the optimum by luck.
            planner = make_planner(name, model, np.random.default_rng(seed))
            weight = joint_table[a, b]
            truth = {"mug": scenario.site_names[a], "teabag": scenario.site_names[b]}
            total += weight * simulate(planner, belief, truth, dist, objects)
        expected[name] = total
    root = OptimalPlanner().choose(belief, objects, {"mug": 1.0, "teabag": 1.0}, dist, {}).total
    # Re-planning after every observation follows the DP's policy: the simulated expectation is
    # the DP's value (up to the 1e-12 miss likelihood of the simulated sensor).
    assert expected["optimal"] == pytest.approx(root, abs=1e-6)
    for name, value in expected.items():
        assert expected["optimal"] <= value + 1e-9, (name, expected)
    # The comparison is not vacuous: some planner pays more.
    assert max(expected.values()) > expected["optimal"] + 1e-3


# ----------------------------------------------------------------------------------- assumptions
def test_real_misses_start_a_new_sweep_and_never_loop():
    # mu = 0.5, q(mug) = [0.9, 0.1]; A is 1 m from the agent, B 10 m, A <-> B 9 m.
    scenario = make_scenario([("A", "r", (1.0, 0.0), {"mug": 0.9}),
                              ("B", "r", (10.0, 0.0), {"mug": 0.1})], [("mug", "mug", "A")])
    model = load_model("factorised").with_overrides(miss_likelihood=0.5)
    belief = BeliefEngine(scenario, model)
    dist = euclidean_distances(scenario, (0.0, 0.0))
    planner = OptimalPlanner()
    rel = {"mug": 1.0}
    # A first: 1 + 0.1 * 9 = 1.9; B first: 10 + 0.9 * 9 = 18.1.
    first = planner.choose(belief, ["mug"], rel, dist, {})
    assert (first.viewpoint, first.total) == ("A", pytest.approx(1.9))
    belief.observe_site("A", {"mug": False})  # q = [0.45, 0.1] / 0.55 = [0.818, 0.182]
    # A counts as searched in this sweep although it still holds 0.818: only B is open (9 m).
    second = planner.choose(belief, ["mug"], rel, dist.moved_to("A"), {"A": 1})
    assert (second.viewpoint, second.total) == ("B", pytest.approx(9.0))
    assert [c.viewpoint for c in second.candidates] == ["B"]
    belief.observe_site("B", {"mug": False})  # q = [0.45, 0.05] / 0.5 = [0.9, 0.1]
    # Both searched once: a new sweep over both, from B. B first: 0 + 0.9 * 9 = 8.1;
    # A first: 9 + 0.1 * 9 = 9.9. Looking again where the agent stands is free, once per sweep.
    third = planner.choose(belief, ["mug"], rel, dist.moved_to("B"), {"A": 1, "B": 1})
    assert [(c.viewpoint, round(c.total, 9)) for c in third.candidates] == [("A", 9.9), ("B", 8.1)]
    assert third.viewpoint == "B"
    belief.observe_site("B", {"mug": False})
    fourth = planner.choose(belief, ["mug"], rel, dist.moved_to("B"), {"A": 1, "B": 2})
    assert fourth.viewpoint == "A"


def test_excluded_sites_are_conditioned_away():
    scenario = make_scenario([("A", "r", (1.0, 0.0), {"mug": 0.5}),
                              ("B", "r", (2.0, 0.0), {"mug": 0.25}),
                              ("C", "r", (-1.0, 0.0), {"mug": 0.25})], [("mug", "mug", "A")])
    belief = BeliefEngine(scenario, perfect_sensor(load_model("factorised")))
    dist = euclidean_distances(scenario, (0.0, 0.0))
    d = OptimalPlanner().choose(belief, ["mug"], {"mug": 1.0}, dist, {}, frozenset({"A"}))
    # Given "not at A": q = [0.5, 0.5] over B, C. First C: 1 + 0.5 * 3 = 2.5; first B: 2 + 0.5 * 3 = 3.5
    assert [(c.viewpoint, c.total) for c in d.candidates] == [("B", pytest.approx(3.5)),
                                                         ("C", pytest.approx(2.5))]
    assert d.viewpoint == "C"


def test_optimal_refuses_more_than_ten_sites():
    sites = [(f"s{i}", "r", (float(i), 0.0), {"mug": 1.0}) for i in range(14)]
    scenario = make_scenario(sites, [("mug", "mug", "s0")])
    belief = BeliefEngine(scenario, load_model("factorised"))
    dist = euclidean_distances(scenario, (0.0, 0.0))
    with pytest.raises(ValueError, match=r"optimal planner: 14 sites exceed the limit of 10"):
        OptimalPlanner().choose(belief, ["mug"], {"mug": 1.0}, dist, {})
    # Excluding four sites brings the problem within the limit.
    d = OptimalPlanner().choose(belief, ["mug"], {"mug": 1.0}, dist, {},
                                frozenset({"s10", "s11", "s12", "s13"}))
    assert d.viewpoint == "s0" and len(d.candidates) == 10
    with pytest.raises(ValueError, match="hidden truths"):
        OptimalPlanner(max_truths=5).choose(belief, ["mug"], {"mug": 1.0}, dist, {},
                                            frozenset({"s10", "s11", "s12", "s13"}))


def test_every_built_in_refusal_is_a_planner_refused_with_its_kind():
    """One exception for every planner that states a limit; ``check`` is on the protocol."""
    from fg_tea.common.errors import PlannerRefused
    from fg_tea.planning.lookahead import LookaheadPlanner

    sites = [(f"s{i}", "r", (float(i), 0.0), {"mug": 1.0, "kettle": 1.0, "teabag": 1.0})
             for i in range(14)]
    scenario = make_scenario(sites, [("mug", "mug", "s0"), ("kettle", "kettle", "s1"),
                                     ("teabag", "teabag", "s2")])
    belief = BeliefEngine(scenario, load_model("factorised"))
    with pytest.raises(PlannerRefused, match="optimal planner: 14 sites") as refused:
        OptimalPlanner().check(belief, ["mug"])
    assert refused.value.kind == "size" and refused.value.planner == "optimal"
    many = [(f"s{i}", "r", (float(i), 0.0), {"mug": 1.0, "kettle": 1.0, "teabag": 1.0})
            for i in range(40)]  # 40^3 = 64,000 joint truths: over the lookahead's 50,000
    big = make_scenario(many, [("mug", "mug", "s0"), ("kettle", "kettle", "s1"),
                               ("teabag", "teabag", "s2")])
    joint = BeliefEngine(big, load_model("joint"))
    planner = make_planner("lookahead", load_model("joint"))
    assert isinstance(planner, LookaheadPlanner) and joint.correlated
    assert planner.check(joint, ["mug", "kettle", "teabag"]) is None  # held as its subset program
    joint.structured_model = lambda: None   # relations that are not site- or room-local
    with pytest.raises(PlannerRefused) as refused:
        planner.check(joint, ["mug", "kettle", "teabag"])
    assert refused.value.kind == "belief" and refused.value.planner == "lookahead"
    for name in ("efe", "nearest", "greedy", "factorised_efe", "mi_efe"):
        assert make_planner(name, load_model("factorised")).check(belief, ["mug"]) is None


def test_an_excluded_site_error_is_an_error_not_a_refusal():
    """The optimal planner's "every configuration on an excluded site" is not a size limit."""
    from fg_tea.common.errors import PlannerRefused
    from fg_tea.planning.optimal import truth_table

    sites = [(f"s{i}", "r", (float(i), 0.0), {"mug": 1.0 if i == 0 else 0.0}) for i in range(3)]
    scenario = make_scenario(sites, [("mug", "mug", "s0")])
    model = load_model("factorised").with_overrides(prior_floor=1e-12)
    belief = BeliefEngine(scenario, model)
    belief.observe_site("s0", {"mug": False})
    try:
        truth_table(belief, ["mug"], [1, 2])
    except ValueError as exc:
        assert not isinstance(exc, PlannerRefused)
