"""The lookahead planner: it reduces to EFE at depth 1 without a rollout, is deterministic, prices a
re-look under the miss model, conditions exactly like the belief engine, and beats EFE's travel."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.env.fake import FakeHouse
from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
from fg_tea.model.spec import load_model
from fg_tea.planning import (DistanceTable, LookaheadPlanner, LookaheadSettings,
    check_planner_name, make_planner, planner_names)
from fg_tea.planning.problem import build_problem, rollout_values
from fg_tea.world.scenario import load_scenario
from fg_tea.episode.log import encode
from fg_tea.study.sweep import world_path
from fg_tea.world.distributions import load_world
from houses import make_scenario


def _world(name):
    return load_world(world_path(name))


def _injectable(model, miss_rate: float) -> float:
    """Injected misses act on the threshold detector only (a visibility-detector model draws every
    detection from its curve, and refuses the setting), so they are injected there only."""
    return miss_rate if model.detector == "threshold" else 0.0


def _decisions(scenario, model, planner, seed, miss_rate=0.05):
    env = FakeHouse(scenario, env_config_for(model, detection_miss_rate=_injectable(model, miss_rate)))
    runner = EpisodeRunner(scenario, model, env, RunConfig(seed=seed, planner=planner))
    runner.run()
    env.close()
    return [(e["object"], e["viewpoint"], e["viewpoint_kind"]) for e in runner.log.events
            if e["event"] == "decision"], runner


@pytest.mark.parametrize("model_name", ["factorised_close", "joint_close", "factorised", "joint"])
@pytest.mark.parametrize("world_seed", [0, 3])
def test_depth_one_without_rollout_is_efe(model_name, world_seed):
    """Whole episodes (so many beliefs, close looks and room glances) choose exactly as EFE."""
    scenario = _world("correlated").sample(world_seed)
    model = load_model(model_name)
    efe, _ = _decisions(scenario, model, "efe", world_seed)
    look, runner = _decisions(scenario, model, "lookahead:depth=1,rollout=none", world_seed)
    assert look == efe and len(efe) >= 1
    assert all(e["planner"] == "lookahead" for e in runner.log.events if e["event"] == "decision")


def test_depth_one_without_rollout_is_efe_in_a_generated_house():
    scenario = load_scenario("generated_small")
    model = load_model("factorised")
    efe, _ = _decisions(scenario, model, "efe", 1)
    look, _ = _decisions(scenario, model, "lookahead:depth=1,rollout=none", 1)
    assert look == efe


def _episode_log(planner, model_name="factorised", seed=2):
    scenario = _world("correlated").sample(seed)
    model = load_model(model_name)
    env = FakeHouse(scenario, env_config_for(model, detection_miss_rate=_injectable(model, 0.05)))
    runner = EpisodeRunner(scenario, model, env, RunConfig(seed=seed, planner=planner))
    runner.run()
    return "\n".join(encode(e) for e in runner.log.events)


@pytest.mark.parametrize("model_name", ["factorised", "joint_close"])
def test_same_budget_same_log(model_name):
    a = _episode_log("lookahead:depth=2,width=3,nodes=50", model_name)
    b = _episode_log("lookahead:depth=2,width=3,nodes=50", model_name)
    assert a == b


def test_decision_record_has_counts_and_values():
    _, runner = _decisions(_world("correlated").sample(4), load_model("joint"),
                           "lookahead:depth=2,width=3,nodes=80", 4)
    decisions = [e for e in runner.log.events if e["event"] == "decision"]
    assert decisions
    for e in decisions:
        info = e["info"]
        assert info["nodes"] >= 1 and info["leaves"] >= 1 and info["nodes"] <= 80 + 64
        assert info["best_value"] <= info["second_value"]
        assert e["total"] == pytest.approx(info["best_value"])
        assert min(c["total"] for c in e["candidates"]) == pytest.approx(info["best_value"])


def _two_site_house():
    """Two sites 6 m apart; the mug is very probably at `near` (where the agent stands)."""
    sites = [("near", "kitchen", (0.0, 0.0), {"mug": 0.9}, None),
             ("far", "kitchen", (6.0, 0.0), {"mug": 0.1}, None),
             ("farther", "kitchen", (6.0, 3.0), {"mug": 0.05}, None)]
    return make_scenario(sites, [("mug", "mug", "near")])


def _at_near(scenario):
    names = [s.name for s in scenario.sites]
    pts = np.array([s.vantage for s in scenario.sites])
    matrix = np.linalg.norm(pts[:, None] - pts[None], axis=2)
    return DistanceTable(tuple(names), tuple(matrix[0]), tuple(map(tuple, matrix)))


def test_relook_is_preferred_when_the_detector_misses_often():
    """After one miss at `near`: with mu = 0.6 the mug is still most likely there, so look again;
    with mu = 1e-3 the re-look (0.144 m) is worth less than its 0.6 % chance of saving the trip."""
    scenario = _two_site_house()
    distances = _at_near(scenario)
    planner = LookaheadPlanner(load_model("factorised_close").planning,
                               LookaheadSettings(depth=2, width=3))
    for mu, expected in ((0.6, "near"), (1e-3, "far")):
        model = load_model("factorised_close").with_overrides(miss_likelihood=mu)
        belief = BeliefEngine(scenario, model)
        belief.observe_site("near", {"mug": False})
        d = planner.choose(belief, ["mug"], {"mug": 1.0}, distances, {"near": 1})
        assert d.viewpoint == expected, (mu, d.candidates)
    # No flat penalty: the re-look's value is its travel-free look cost plus the expected rest.
    model = load_model("factorised_close").with_overrides(miss_likelihood=0.6)
    belief = BeliefEngine(scenario, model)
    belief.observe_site("near", {"mug": False})
    d = planner.choose(belief, ["mug"], {"mug": 1.0}, distances, {"near": 5})
    assert d.viewpoint == "near"


@pytest.mark.parametrize("model_name", ["factorised_close", "joint_close"])
def test_tree_conditioning_matches_the_engine(model_name):
    """A miss conditioned on the truth table gives the engine's hypothetical marginals (eq. 37)."""
    scenario = _world("correlated").sample(1)
    model = load_model(model_name)
    belief = BeliefEngine(scenario, model)
    objects = list(belief.objects)
    distances = DistanceTable(tuple(belief.sites), tuple([1.0] * len(belief.sites)),
                              tuple(tuple(0.0 if i == j else 1.0 for j in range(len(belief.sites)))
                                    for i in range(len(belief.sites))))
    problem = build_problem(belief, objects, distances, frozenset(), None, 0.1)
    miss, _ = belief.hypothetical_all()
    mu = model.miss_likelihood
    k = len(belief.sites)
    for j in range(k):
        for o in range(len(objects)):
            lik = np.where(problem.loc[:, o] == j, mu, 1.0)
            w = problem.p * lik
            w /= w.sum()
            for p in range(len(objects)):
                q = np.bincount(problem.loc[:, p], weights=w, minlength=k)
                np.testing.assert_allclose(q, miss[o, j, p], atol=1e-12)


def test_rollout_value_is_the_exact_cost_of_its_sequence():
    """One object, close looks: the rollout's value is sum_s c_s P(not found before s)."""
    scenario = _two_site_house()
    model = load_model("factorised_close").with_overrides(miss_likelihood=0.2)
    belief = BeliefEngine(scenario, model)
    distances = _at_near(scenario)
    problem = build_problem(belief, ["mug"], distances, frozenset(), None, 0.5)
    first = np.full(1, -1)
    value, _ = rollout_values(problem, np.array([-1]), problem.root()[None], np.ones((1, 1), bool),
                              first=first, max_looks=3)
    q = belief.location("mug")
    # The sweep: near (0 m), then the better per metre of far / farther, then the last.
    order = [0] + sorted([1, 2], key=lambda j: -q[j] / distances.between("near", belief.sites[j]))
    cost, pos, unfound = 0.0, None, 1.0
    rem = np.ones(3)
    for j in order:
        step = (distances.from_agent(belief.sites[j]) if pos is None
                else distances.between(belief.sites[pos], belief.sites[j])) + 0.5
        cost += step * (q * rem).sum()
        rem[j] *= 0.2
        pos = j
    assert first[0] == 0
    assert value[0] == pytest.approx(cost, rel=1e-12)


def test_lookahead_travels_less_than_efe_on_paired_worlds():
    scenario_dist = _world("correlated")
    model = load_model("factorised_close")
    totals = {"efe": 0.0, "lookahead": 0.0}
    for seed in range(6):
        for planner in totals:
            _, runner = _decisions(scenario_dist.sample(seed), model, planner, seed)
            totals[planner] += runner.metrics()["search_distance"]
    assert totals["lookahead"] < totals["efe"]


def test_specs_and_registry():
    assert "lookahead" in planner_names()
    check_planner_name("lookahead:depth=3,width=2,rollout=none,nodes=10,look=0")
    s = LookaheadSettings.parse("depth=3, width=2")
    assert (s.depth, s.width, s.rollout) == (3, 2, "mppm")
    for bad in ("lookahead:depth=0", "lookahead:deep=2", "lookahead:depth=two",
                "lookahead:rollout=random", "lookahead:look=-1", "pouct:0", "pouct:x", "nope:1"):
        with pytest.raises(ValueError):
            check_planner_name(bad)
    planner = make_planner("lookahead:depth=3", load_model("factorised"))
    assert isinstance(planner, LookaheadPlanner) and planner.settings.depth == 3


# ------------------------------------------------------------------ size: per-object form, refusals
def test_factorised_belief_is_held_per_object_beyond_the_truth_limit(monkeypatch):
    """A factorised belief is planned on its per-object marginals, so the truth limit (which
    bounds only a correlated belief's dense joint) does not apply; the choice does not change."""
    from fg_tea.planning import lookahead, problem

    scenario = _world("correlated").sample(5)
    model = load_model("factorised_close")
    before, _ = _decisions(scenario, model, "lookahead", 5)
    monkeypatch.setattr(problem, "MAX_TRUTHS", 10)  # 8 sites ^ 3 objects = 512 truths > 10
    after, runner = _decisions(scenario, model, "lookahead", 5)
    assert after == before and runner.metrics()["success"]


@pytest.mark.parametrize("model_name", ["joint_close", "joint"])
def test_joint_belief_beyond_the_dense_limit_is_planned_on_its_subset_program(monkeypatch, model_name):
    """Beyond the dense limit a correlated belief is held as the engine's subset program times
    one weight vector per object: whole episodes (close looks; glances) make the dense joint's
    choices. Without a subset program it is refused in one line."""
    from fg_tea.planning import lookahead, problem

    scenario = _world("correlated").sample(5)
    model = load_model(model_name)
    before, _ = _decisions(scenario, model, "lookahead", 5)
    forms = []
    build = lookahead.build_problem

    def recording(*args, **kwargs):
        problem = build(*args, **kwargs)
        forms.append(problem.structured is not None)
        return problem

    monkeypatch.setattr(lookahead, "build_problem", recording)
    monkeypatch.setattr(problem, "MAX_TRUTHS", 1)  # every table is over the limit
    after, runner = _decisions(scenario, model, "lookahead", 5)
    assert after == before and runner.metrics()["success"] and forms and all(forms)
    monkeypatch.setattr(BeliefEngine, "structured_model", lambda self: None)
    with pytest.raises(ValueError, match="^lookahead planner: 3 objects over 8 sites give 512 joint"):
        _decisions(scenario, model, "lookahead", 5)


def test_structured_and_dense_forms_agree_on_a_correlated_belief():
    """The same correlated belief held as a dense joint and as its subset program gives the same
    children (probabilities and marginals, two looks deep, close looks and glances, a site
    excluded, all objects or some) and the same rollout values, to 1e-12."""
    from dataclasses import replace as dc_replace

    from fg_tea.planning.lookahead import _Node
    from fg_tea.planning.problem import StructuredTruths, marginals

    scenario = _world("generated_small").sample(4)
    for model_name, objects in (("joint_close", ["teabag", "mug", "kettle"]),
                                ("joint", ["teabag", "mug", "kettle"]), ("joint", ["kettle", "mug"])):
        model = load_model(model_name)
        belief = BeliefEngine(scenario, model)
        belief.observe_site(scenario.site_names[0], {o: False for o in belief.objects})
        views = _views(scenario, model)
        dense = build_problem(belief, objects, _viewpoint_distances(scenario),
                              frozenset(scenario.site_names[1:2]), views, 0.144)
        assert ("room" in dense.kinds) == (model_name == "joint")
        rows = np.array([belief.objects.index(o) for o in objects])
        held = dc_replace(dense, joint=None,
                          structured=StructuredTruths(belief.structured_model(), rows, dense.allowed))
        planner = LookaheadPlanner(model.planning)
        n, a_count = len(objects), len(dense.names)
        worst = 0.0
        for a in range(a_count):
            kids = [planner._outcomes(pr, _Node(-1, pr.root(), np.ones(n, bool), 2, np.zeros(a_count)), a)
                    for pr in (dense, held)]
            assert len(kids[0]) == len(kids[1]) >= 2
            for (p0, c0), (p1, c1) in zip(*kids):
                worst = max(worst, abs(p0 - p1), np.abs(marginals(dense, c0.b) - c1.q).max())
                deeper = [planner._outcomes(pr, c, (a + 1) % a_count) for pr, c in ((dense, c0), (held, c1))]
                for (pp0, cc0), (pp1, cc1) in zip(*deeper):
                    worst = max(worst, abs(pp0 - pp1), np.abs(marginals(dense, cc0.b) - cc1.q).max())
        assert worst < 1e-12
        unfound = np.array([[True] * n, [False] + [True] * (n - 1)])
        values = [rollout_values(pr, np.array([-1, 2]), np.stack([pr.root()] * 2), unfound)[0]
                  for pr in (dense, held)]
        np.testing.assert_allclose(values[0], values[1], rtol=1e-12)


def test_refusal_is_a_row_in_a_sweep_and_one_line_in_run(monkeypatch, capsys, tmp_path):
    from fg_tea import cli
    from fg_tea.planning import lookahead, problem
    from fg_tea.study.sweep import Job, run_job

    monkeypatch.setattr(problem, "MAX_TRUTHS", 100)
    monkeypatch.setattr(BeliefEngine, "structured_model", lambda self: None)
    row = run_job(Job("correlated", 0, model="joint_close", planner="lookahead", env="fake"))
    assert row["reason"].startswith("refused: belief: lookahead planner: 3 objects over 8 sites give 512 joint")
    assert row["success"] is False
    row = run_job(Job("correlated", 0, model="factorised_close", planner="lookahead", env="fake"))
    assert row["reason"] == "complete"
    out = tmp_path / "run"
    status = cli.main(["run", "default_apartment", "--model", "joint_close", "--planner",
                       "lookahead:nodes=20", "--no-video", "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and "lookahead planner refuses this house" in err[0]
    assert not (out / "episode.jsonl").exists()


def test_product_and_joint_forms_agree_on_an_independent_belief():
    """The same product belief held as factors and as a dense joint gives the same children
    (probabilities and marginals) and the same rollout values."""
    from fg_tea.planning.lookahead import _Node
    from fg_tea.planning.problem import _outer, marginals
    from dataclasses import replace as dc_replace

    scenario = _world("correlated").sample(2)
    model = load_model("factorised_close").with_overrides(miss_likelihood=0.3)
    belief = BeliefEngine(scenario, model)
    objects = list(belief.objects)
    distances = _at_near_of(scenario)
    product = build_problem(belief, objects, distances, frozenset(), None, 0.144)
    joint = dc_replace(product, joint=_outer(product.factors), factors=None)
    planner = LookaheadPlanner(model.planning)
    n, a_count = len(objects), len(product.names)
    for a in range(a_count):
        kids = [planner._outcomes(pr, _Node(-1, pr.root(), np.ones(n, bool), 2, np.zeros(a_count)), a)
                for pr in (product, joint)]
        assert len(kids[0]) == len(kids[1]) >= 2
        for (p0, c0), (p1, c1) in zip(*kids):
            assert p0 == pytest.approx(p1, abs=1e-12)
            np.testing.assert_allclose(marginals(product, c0.b), marginals(joint, c1.b), atol=1e-12)
            assert (c0.unfound == c1.unfound).all()
    unfound = np.array([[True] * n, [False] + [True] * (n - 1)])
    values = [rollout_values(pr, np.array([-1, 2]), np.stack([pr.root()] * 2), unfound)[0]
              for pr in (product, joint)]
    np.testing.assert_allclose(values[0], values[1], rtol=1e-12)


def _views(scenario, model):
    """The viewpoints' detection model of an episode in the fake house (None: close looks only)."""
    env = FakeHouse(scenario, env_config_for(model))
    runner = EpisodeRunner(scenario, model, env, RunConfig(seed=0))
    runner.start()
    env.close()
    return runner.agent.views


def _viewpoint_distances(scenario):
    """Straight-line distances between every viewpoint (sites and room vantages), the agent at
    the first site's vantage point."""
    from fg_tea.planning import euclidean_distances

    return euclidean_distances(scenario, scenario.sites[0].vantage[:2])


def _at_near_of(scenario):
    names = [s.name for s in scenario.sites]
    pts = np.array([s.vantage for s in scenario.sites])
    matrix = np.linalg.norm(pts[:, None] - pts[None], axis=2)
    return DistanceTable(tuple(names), tuple(matrix[0]), tuple(map(tuple, matrix)))


def test_a_look_that_cannot_find_anything_is_not_a_candidate():
    """A re-look of a site missed so often that it cannot change the belief costs and changes
    nothing; kept as a candidate, a depth-limited tree can still prefer it for ever (this
    27-site joint episode re-looked one site 105 times and ran out of looks). Now the episode
    ends, and no chosen look is expected to find less than NULL_LOOK."""
    from fg_tea.planning import lookahead, problem

    scenario = _world("generated_medium").sample(9)
    model = load_model("joint_close")
    _, runner = _decisions(scenario, model, "lookahead", 9)
    assert runner.metrics()["success"]
    assert max(runner.agent.inspected.values()) < 10
    assert lookahead.NULL_LOOK > 0


def test_grouping_glance_outcomes_by_who_is_seen_loses_nothing_for_a_factorised_belief():
    """Outcomes are grouped by which objects a look shows, not where (docs/design.md §6.6). For a
    factorised belief a found object leaves the search, so the grouped tree's values equal those
    of a tree that branches on every in-view site each object could be seen at (brute force,
    every viewpoint at every node, two looks deep)."""
    from fg_tea.planning.lookahead import _Node

    scenario = _world("generated_small").sample(2)
    model = load_model("factorised")
    belief = BeliefEngine(scenario, model)
    objects = ["mug", "kettle", "teabag"]
    problem = build_problem(belief, objects, _viewpoint_distances(scenario), frozenset(),
                            _views(scenario, model), 0.144)
    planner = LookaheadPlanner(model.planning)
    a_count = len(problem.names)
    assert any(kind == "room" for kind in problem.kinds)

    def cost(pos, a):
        return (problem.start[a] if pos < 0 else problem.between[pos, a]) + problem.look[a]

    def by_site(q, unfound, pos, depth):
        """Brute force: each unfound object unseen, or seen at one in-view site."""
        if not unfound or depth == 0:
            return 0.0
        best = np.inf
        for a in range(a_count):
            p = problem.prob[a]
            branches = []
            for u in unfound:
                options = [(float(q[u] @ (1 - p[u])), True)]
                options += [(float(q[u][k] * p[u][k]), False) for k in np.flatnonzero(p[u] > 0)]
                branches.append(options)
            total = 0.0
            for combo in itertools.product(*branches):
                mass = float(np.prod([m for m, _ in combo]))
                if mass < 1e-12:
                    continue
                left = [u for u, (_, unseen) in zip(unfound, combo) if unseen]
                post = q.copy()
                for u in left:
                    post[u] = q[u] * (1 - p[u]) / (q[u] @ (1 - p[u]))
                total += mass * by_site(post, left, a, depth - 1)
            best = min(best, cost(pos, a) + total)
        return best

    def grouped(node, depth):
        if not node.unfound.any() or depth == 0:
            return 0.0
        return min(cost(node.pos, a) + sum(p * grouped(kid, depth - 1)
                                           for p, kid in planner._outcomes(problem, node, a))
                   for a in range(a_count))

    root = _Node(-1, problem.root(), np.ones(3, bool), 2, np.zeros(a_count))
    assert grouped(root, 2) == pytest.approx(by_site(problem.root(), [0, 1, 2], -1, 2), rel=1e-9)


@pytest.mark.slow
def test_ranked_root_pruning_makes_the_unpruned_choices_over_an_episode(monkeypatch):
    """Five objects in a 13-site house: the joint gain comes from the subset program, whose
    bounds prune the root's candidates to the `width` best; the choices of a whole episode are
    those of ranking every candidate exactly."""
    from fg_tea.planning import efe

    scenario = _world("generated_small_milk_sugar").sample(3)
    model = load_model("joint")

    def run():
        env = FakeHouse(scenario, env_config_for(model))
        runner = EpisodeRunner(scenario, model, env, RunConfig(seed=3, planner="lookahead",
                                                                 task="make_tea_milk_sugar"))
        runner.run()
        env.close()
        return [(e["object"], e["viewpoint"]) for e in runner.log.events if e["event"] == "decision"]

    ranked = run()
    unpruned = efe.EFEPlanner.__init__

    def exact_everywhere(self, weights, information="auto", prune=True, rank=1):
        unpruned(self, weights, information, prune=prune and rank == 1, rank=1)

    monkeypatch.setattr(efe.EFEPlanner, "__init__", exact_everywhere)
    assert run() == ranked and len(ranked) > 3


def test_one_object_left_plans_on_its_marginal_with_the_structured_gain():
    """With one object left on a belief beyond the dense limit, the planner's gains (the
    one-object closed form) are the structured solver's for every viewpoint, and the search
    problem holds the object's marginal over the open sites (not the subset program)."""
    from fg_tea.planning import EFEPlanner
    from fg_tea.planning.efe import structured_gain

    scenario = _world("generated_large_milk_sugar").sample(1)
    model = load_model("joint")
    belief = BeliefEngine(scenario, model)
    assert belief.structured_model() is not None
    belief.observe_site(scenario.site_names[0], {o: False for o in belief.objects})
    views, distances = _views(scenario, model), _viewpoint_distances(scenario)
    excluded = frozenset(scenario.site_names[1:2])
    for obj in ("teabag", "mug"):
        decision = EFEPlanner(model.planning, information="joint").choose(
            belief, [obj], {obj: 1.0}, distances, {}, excluded, views)
        o = belief.objects.index(obj)
        solver = structured_gain(belief, [o])
        assert solver is not None
        eligible = [v for v in views.views if v.name not in excluded]
        want = solver.gains([(v.sites, v.probability[[o]]) for v in eligible])[0]
        got = [c.information_gain for c in decision.candidates]
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
        assert decision.info["gain_solver"] == "one_object"
        problem = build_problem(belief, [obj], distances, excluded, views, 0.144)
        q = belief.location_matrix()[o, problem.allowed]
        np.testing.assert_allclose(problem.joint, q / q.sum(), rtol=0, atol=1e-15)


def test_episode_distance_matrices_are_the_pairwise_lookups():
    """The episode's distance cache gives each viewpoint subset the same numbers whether built
    pair by pair or copied out of an earlier, larger matrix."""
    from fg_tea.episode.distances import EnvDistances

    class Floor:
        def distance_between_sites(self, a, b):
            return float(abs(hash((min(a, b), max(a, b)))) % 1000) / 7.0

    names = [f"v{i}" for i in range(9)]
    cached = EnvDistances(Floor())
    cached.matrix_for(names)
    fresh = EnvDistances(Floor())
    for subset in (names[2:], names[::2], [names[4], names[1], names[7]], names[:1]):
        got = cached.matrix_for(subset)
        want = np.array([[fresh.between(a, b) if a != b else 0.0 for b in subset] for a in subset])
        assert got.tobytes() == want.tobytes() and not got.flags.writeable
    assert cached.matrix_for(["v1", "elsewhere"])[0, 1] == fresh.between("v1", "elsewhere")
