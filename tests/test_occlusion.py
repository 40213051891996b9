"""Detection that knows the turn tolerance and what shares a site (docs/design.md §3.4, "Facing and
company"): the conditional probabilities, their mean under a belief, the exact coupled likelihood
of a look, and what the object-by-object update costs against it.
"""

from __future__ import annotations

import importlib.util
import itertools
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fg_tea.agent.agent import Agent
from fg_tea.beliefs.detection import ViewModel
from fg_tea.beliefs.occlusion import (CompanyModel, company_probability, coupled_likelihood,
                                      curve_values, share_matrix, together_from)
from fg_tea.common.errors import InputError
from fg_tea.env.fake import FakeHouse
from fg_tea.episode.runner import env_config_for
from fg_tea.model.spec import load_model
from fg_tea.world.scenario import load_scenario
from fg_tea.world.visibility import VisibilityCurve

ROOT = Path(__file__).resolve().parents[1]


def _script(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "experiments" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(module)
    return module


def _fake_tables(scenario, model):
    env = FakeHouse(scenario, env_config_for(model))
    env.reset(0)
    cats = [scenario.object(o).category for o in scenario.object_names]
    return env.expected_pixel_counts(sorted(set(cats))), env.company_pixel_counts(sorted(cats))


def _hiding_tables(scenario, model, pair, share):
    """The fake house's tables with `pair` ("hidden|hider") scaled by `share` everywhere."""
    expected, company = _fake_tables(scenario, model)
    for cell in (c for v in company["views"].values() for c in v.values()):
        cell["company"][pair] = [[None if x is None else x * share for x in r]
                                 for r in cell["company"][pair]]
    return expected, company


def test_the_curve_on_arrays_is_the_curve():
    curve = VisibilityCurve(half_pixels=50, slope=3.0, max_probability=0.95)
    n = np.array([0.0, 1.0, 20.0, 50.0, 400.0, 1e9])
    assert np.allclose(curve_values(curve, "teabag", n),
                       [curve.probability("teabag", x) for x in n], atol=1e-15, rtol=0)


def test_alone_is_slot_zero_averaged_over_headings():
    curve = VisibilityCurve(half_pixels=50, slope=3.0, max_probability=0.95)
    facing = np.array([[30.0, 40.0, 50.0, 60.0], [200.0, 200.0, 200.0, 200.0]])
    p = company_probability(curve, "mug", facing, [])
    assert p == pytest.approx(np.mean([curve.probability("mug", n) for n in facing[0]]), abs=1e-15)


def test_one_companion_averages_both_arrival_orders():
    curve = VisibilityCurve(half_pixels=50, slope=3.0, max_probability=0.95)
    facing = np.array([[60.0, 80.0], [90.0, 70.0]])
    share = np.array([[1.0, 0.5], [0.25, 1.0]])  # hidden to half at slot 0, to a quarter at 1
    p = company_probability(curve, "teabag", facing, [share])
    orders = [curve.probability("teabag", n * 0.5) for n in facing[0]]   # o first: slot 0
    orders += [curve.probability("teabag", n * 0.25) for n in facing[1]]  # o second: slot 1
    assert p == pytest.approx(np.mean(orders), abs=1e-15)
    assert p < company_probability(curve, "teabag", facing, [])


def test_shares_are_at_most_one_and_one_where_nothing_is_seen():
    m = share_matrix([[None, 120.0, 30.0], [10.0, None, 5.0], [1.0, 2.0, None]], [100.0, 0.0, 4.0])
    assert m.max() <= 1.0
    assert m[0, 1] == 1.0 and m[0, 2] == pytest.approx(0.3)
    assert (m[1] == 1.0).all()  # the object alone covers nothing there
    assert m[2, 0] == pytest.approx(0.25)


def _random_company(rng, n, sites, views=("v",)):
    table = np.zeros((n, len(sites), 1 << n))
    for o in range(n):
        for c in range(len(sites)):
            for mask in range(1 << n):
                if not mask >> o & 1:
                    table[o, c, mask] = rng.uniform(0.05, 0.95)
    model = CompanyModel.__new__(CompanyModel)
    model.n, model.occlusion, model.tables = n, True, {v: table for v in views}
    return model, table


def test_the_mean_under_a_belief_is_the_sum_over_companion_sets():
    rng = np.random.default_rng(3)
    n, k, sites = 4, 5, [1, 3]
    company, table = _random_company(rng, n, sites)
    together = rng.uniform(0, 1, (n, n, k))
    got = company.expected("v", sites, together)
    for o in range(n):
        for c, j in enumerate(sites):
            want = 0.0
            others = [x for x in range(n) if x != o]
            for present in itertools.product([0, 1], repeat=len(others)):
                w, mask = 1.0, 0
                for x, here in zip(others, present):
                    w *= together[o, x, j] if here else 1 - together[o, x, j]
                    mask |= here << x
                want += w * table[o, c, mask]
            assert got[o, c] == pytest.approx(want, abs=1e-14)


def test_together_from_a_factorised_and_a_joint_belief():
    rng = np.random.default_rng(1)
    joint = rng.uniform(0, 1, (3, 3, 3))
    joint /= joint.sum()
    m = np.stack([joint.sum(axis=(1, 2)), joint.sum(axis=(0, 2)), joint.sum(axis=(0, 1))])
    pw = np.zeros((3, 3, 3, 3))
    for a, b in itertools.permutations(range(3), 2):
        other = ({0, 1, 2} - {a, b}).pop()
        pw[a, b] = joint.sum(axis=other) if a < b else joint.sum(axis=other).T
    t = together_from(m, pw)
    assert t[0, 1, 2] == pytest.approx(joint[2, 2, :].sum() / m[0, 2], abs=1e-14)
    assert t[2, 0, 1] == pytest.approx(joint[1, :, 1].sum() / m[2, 1], abs=1e-14)
    assert np.array_equal(together_from(m, None)[0], m)


def test_the_coupled_likelihood_is_the_product_over_objects_of_their_conditional_chances():
    rng = np.random.default_rng(7)
    n, k, sites, fp = 3, 4, [0, 2], 1e-3
    _, table = _random_company(rng, n, sites)
    found = {0: None, 1: 2, 2: None}
    got = coupled_likelihood(table, sites, k, found, fp)
    for x in itertools.product(range(k), repeat=n):
        want = 1.0
        for o, seen_at in found.items():
            others = sum(1 << y for y in range(n) if y != o and x[y] == x[o])
            p = table[o, sites.index(x[o]), others] if x[o] in sites else 0.0
            if seen_at is None:
                want *= 1 - p
            else:
                want *= p if x[o] == seen_at else fp
        assert got[x] == pytest.approx(want, abs=1e-15)


def test_without_occlusion_the_object_by_object_update_is_exact():
    """The fake camera has no company effect: p does not depend on who shares a site, the
    likelihood factorises, and the update the agent uses equals the exact coupled one."""
    mod = _script("occlusion_error")
    scenario = load_scenario("default_apartment")
    for name in ("factorised_occlusion", "joint_occlusion"):
        model = replace(load_model(name), positive_update="likelihood")
        expected, company = _fake_tables(scenario, model)
        views = ViewModel(scenario, model, scenario.object_names, expected, company)
        rows = mod.run_chain(scenario, model, views, np.random.default_rng(0), 20)
        assert sum(r["seen"] for r in rows) > 0
        assert max(r["kl"] for r in rows) < 1e-12


def test_with_occlusion_the_update_differs_from_the_exact_coupled_one():
    """A company table in which the kettle hides half of the teabag: the exact update keeps the
    coupling, the object-by-object one does not, and the script measures a gap."""
    mod = _script("occlusion_error")
    scenario = load_scenario("default_apartment")
    model = replace(load_model("factorised_occlusion"), positive_update="likelihood")
    expected, company = _hiding_tables(scenario, model, "teabag|kettle", 0.3)
    views = ViewModel(scenario, model, scenario.object_names, expected, company)
    rows = mod.run_chain(scenario, model, views, np.random.default_rng(0), 20)
    assert max(r["kl"] for r in rows) > 1e-6


def test_the_belief_sets_who_hides_whom():
    """An agent with a company table in which the kettle hides the teabag entirely: once the
    kettle is seen on a site, the teabag's chance of being seen there falls to almost nothing,
    and on a site the kettle has left it does not fall."""
    scenario = load_scenario("default_apartment")
    model = load_model("factorised_occlusion")
    expected, company = _hiding_tables(scenario, model, "teabag|kettle", 0.0)
    agent = Agent(scenario, model)
    with pytest.raises(ValueError, match="company pixel counts"):
        agent.set_view_geometry(expected)
    views = agent.set_view_geometry(expected, company)
    site, away = "kitchen_counter", "pantry_shelf"
    before = views.probabilities(site)["teabag"][site]
    before_away = views.probabilities(away)["teabag"][away]
    agent.observe_look(site, {"kettle": site})
    agent._reweigh()
    q = agent.belief.location("kettle")[agent.belief.sites.index(site)]
    assert q > 0.99
    assert views.probabilities(site)["teabag"][site] < 0.02 * before
    assert views.probabilities(away)["teabag"][away] >= before_away - 1e-12


def test_facing_alone_is_belief_free_and_averages_headings():
    scenario = load_scenario("default_apartment")
    model = replace(load_model("factorised"), facing_tolerance=True)
    expected, company = _fake_tables(scenario, model)
    views = ViewModel(scenario, model, scenario.object_names, expected, company)
    plain = ViewModel(scenario, load_model("factorised"), scenario.object_names, expected)
    assert not views.belief_dependent
    for v in views.views:  # the fake camera's count does not move with the heading
        assert np.allclose(v.probability, plain.view(v.name).probability, atol=1e-15)


@pytest.mark.parametrize("key", ["occlusion", "facing_tolerance"])
def test_the_settings_need_the_visibility_detector(tmp_path, key):
    path = tmp_path / "m.toml"
    path.write_text(f'extends = "factorised_close"\nname = "m"\n[perception]\n{key} = true\n')
    with pytest.raises(InputError, match=f"{key}.*visibility"):
        load_model(path)


def test_bundled_occlusion_models_load():
    for name, structure in (("factorised_occlusion", "factorised"), ("joint_occlusion", "joint")):
        model = load_model(name)
        assert model.occlusion and model.facing_tolerance and model.structure == structure


@pytest.mark.parametrize("plain,occluding", [("factorised", "factorised_occlusion"),
                                             ("joint", "joint_occlusion")])
def test_a_camera_without_company_effects_gives_the_plain_models_episode(plain, occluding):
    """On the fake camera (same count at every slot and heading, nothing hides anything) the
    company model's probabilities are the plain model's: same decisions, same logged p."""
    from fg_tea.episode.run import run_episode

    scenario = load_scenario("default_apartment")

    def looks(model_name):
        runner = run_episode(scenario, load_model(model_name), env="fake", seed=3)
        return [(e["viewpoint"], e["detection_probability"]) for e in runner.events
                if e["event"] == "observation"], runner.metrics()["success"]

    a, ok_a = looks(plain)
    b, ok_b = looks(occluding)
    assert ok_a and ok_b and len(a) == len(b) > 0
    for (va, pa), (vb, pb) in zip(a, b):
        assert va == vb
        for o in pa:
            for s in pa[o]:
                assert pb[o][s] == pytest.approx(pa[o][s], abs=1e-12)


def test_the_pybullet_house_renders_heading_offsets_and_pairs_that_hide():
    pytest.importorskip("pybullet")
    from fg_tea.env.house import PyBulletHouse

    scenario = load_scenario("default_apartment")
    model = load_model("factorised_occlusion")
    env = PyBulletHouse(scenario, env_config_for(model))
    try:
        env.reset(0)
        cats = sorted(scenario.object(o).category for o in scenario.object_names)
        table = env.company_pixel_counts(cats)
        alone = env.expected_pixel_counts(sorted(set(cats)))
        assert env.company_pixel_counts(cats) == table  # cached, same numbers
    finally:
        env.close()
    assert len(table["offsets_deg"]) == 4
    assert max(abs(h) for h in table["offsets_deg"]) < env.config.face_tolerance_deg
    least = 1.0
    for view, cells in table["views"].items():
        for site, cell in cells.items():
            for cat, rows in cell["facing"].items():
                assert len(rows) == len(alone[view][site][cat]) and all(len(r) == 4 for r in rows)
            for pair, rows in cell["company"].items():
                cat = pair.split("|")[0]
                least = min(least, share_matrix(rows, alone[view][site][cat]).min())
    assert least < 0.8  # somewhere one object hides a fifth of another or more
    views = ViewModel(scenario, model, scenario.object_names, alone, table)
    assert views.belief_dependent


def _occluding_views(scenario, model, seed=0):
    """The fake house's tables with random shares: who hides whom matters everywhere."""
    rng = np.random.default_rng(seed)
    expected, company = _fake_tables(scenario, model)
    for cell in (c for v in company["views"].values() for c in v.values()):
        for pair, rows in cell["company"].items():
            cell["company"][pair] = [[None if x is None else x * rng.uniform(0.1, 1.0) for x in r]
                                     for r in rows]
    return ViewModel(scenario, model, scenario.object_names, expected, company)


def _chain(engine, views, truth, rng, looks):
    """`looks` random looks with detections drawn from the company model at `truth`, absorbed by
    `engine`; returns the exact coupled posterior by enumeration alongside."""
    from fg_tea.beliefs.engine import BeliefEngine  # noqa: F401 - the engine under test

    k = len(engine.sites)
    exact = engine.location_joint().copy()
    seen_total = 0
    for _ in range(looks):
        views.reweigh(engine.location_matrix(), engine.pairwise() if engine.correlated else None)
        view = views.views[int(rng.integers(len(views.views)))]
        found = {}
        for o, j in enumerate(truth):
            found[o] = None
            if j in view.sites:
                mask = sum(1 << x for x, jx in enumerate(truth) if x != o and jx == j)
                if rng.random() < view.conditional[o, view.sites.index(j), mask]:
                    found[o] = j
        seen_total += sum(v is not None for v in found.values())
        exact = exact * coupled_likelihood(view.conditional, view.sites, k, found,
                                           engine.model.false_positive_rate)
        exact /= exact.sum()
        engine.observe_viewpoint(view, {engine.objects[o]: None if j is None else engine.sites[j]
                                        for o, j in found.items()})
    return exact, seen_total


@pytest.mark.parametrize("solver", ["dense", "structured"])
def test_a_joint_belief_absorbs_the_coupled_looks_exactly(solver):
    """Twenty looks, glances and close looks, with two objects sharing a site and several seen in
    one look: the joint engine's marginals equal brute-force enumeration of prior x coupled
    likelihoods (eq. 59) to 1e-14, with both exact solvers, and gtsam agrees."""
    from fg_tea.beliefs.engine import BeliefEngine

    scenario = load_scenario("default_apartment")
    model = replace(load_model("joint_occlusion"), positive_update="likelihood")
    views = _occluding_views(scenario, model)
    sites = list(scenario.site_names)
    truth = [sites.index("kitchen_counter"), sites.index("kitchen_counter"), sites.index("pantry_shelf")]
    for seed in (1, 5):
        engine = BeliefEngine(scenario, model, location_solver=solver)
        exact, seen = _chain(engine, views, truth, np.random.default_rng(seed), 20)
        assert seen >= 3
        n = len(engine.objects)
        want = np.stack([exact.sum(axis=tuple(a for a in range(n) if a != o)) for o in range(n)])
        assert np.abs(engine.location_matrix() - want).max() < 1e-14
        assert engine.check_against_gtsam() < 1e-9


def test_coupled_misses_count_for_the_give_up():
    from fg_tea.beliefs.engine import BeliefEngine

    scenario = load_scenario("default_apartment")
    model = load_model("joint_occlusion")
    views = _occluding_views(scenario, model)
    engine = BeliefEngine(scenario, model)
    before, looks = engine.unseen_probability("teabag")
    assert looks == 0
    views.reweigh(engine.location_matrix(), engine.pairwise())
    view = views.view("kitchen_centre")
    engine.observe_viewpoint(view, {"teabag": None, "mug": None})
    after, looks = engine.unseen_probability("teabag")
    assert looks == 1 and after < before
    i = engine.objects.index("teabag")
    expected = sum((q * (1 - view.probability[i, view.sites.index(j)]) if j in view.sites else q)
                   for j, q in enumerate(engine.graph.location_priors[i].table
                                         / engine.graph.location_priors[i].table.sum()))
    assert after == pytest.approx(expected, rel=1e-12)


@pytest.mark.slow
def test_beside_plain_pairs_the_company_models_with_the_plain_ones(tmp_path, capsys):
    """On the fake camera the company models play the plain models' episodes, so every paired
    difference is zero and the joint − factorised answer is the same under both."""
    import csv
    import subprocess
    import sys

    for looks in ("occlusion", "glances"):
        subprocess.run([sys.executable, str(ROOT / "experiments" / "compare_at_scale.py"), "--table",
                        "houses", "--looks", looks, "--worlds", "2", "--confirmation-first-seed",
                        "10000", "--sizes", "small", "--tasks", "make_tea", "--planners",
                        "factorised_efe", "--env", "fake", "--workers", "1", "--timing-worlds", "0",
                        "--out", str(tmp_path / looks)], check=True, capture_output=True)
    mod = _script("occlusion_beside_plain")
    args = ["--plain", str(tmp_path / "glances" / "houses" / "episodes.csv"),
            "--occlusion", str(tmp_path / "occlusion" / "houses" / "episodes.csv"), "--out", str(tmp_path / "out")]
    assert mod.main(args) == 0
    rows = list(csv.DictReader(open(tmp_path / "out" / "summary.csv")))
    assert len(rows) == 4 and {r["seed_set"] for r in rows} == {"discovery", "confirmation"}
    for r in rows:
        assert r["company_minus_plain"] == "0.00 [0.00, 0.00]" and r["jf_plain"] == r["jf_company"]
        assert r["given_up"] == r["plain_given_up"] and int(r["searches"]) == 6
    with pytest.raises(SystemExit) as exc:
        from fg_tea.common.errors import run_script
        run_script(lambda: mod.main([*args[:2], "--plain", str(tmp_path / "none.csv"), "--out",
                                     str(tmp_path / "out2")]), "occlusion_beside_plain.py")
    assert exc.value.code == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_hundreds_of_coupled_misses_then_a_detection():
    """The unary part of each coupled miss is kept in log space and the site factors hold only the
    company's ratios, so hundreds of misses at one site do not rule it out: the object seen there
    afterwards is found there (with raw products the factors underflowed to zero after ~400 misses
    of the fake camera's 0.84 and the detection raised a contradiction)."""
    from fg_tea.beliefs.engine import BeliefEngine

    scenario = load_scenario("default_apartment")
    for name in ("joint_occlusion", "factorised_occlusion"):
        model = load_model(name)
        expected, company = _fake_tables(scenario, model)
        for views, misses in ((ViewModel(scenario, model, scenario.object_names, expected, company), 450),
                              (_occluding_views(scenario, model), 150)):
            engine = BeliefEngine(scenario, model)
            view = views.view("sideboard")
            for _ in range(misses):
                engine.observe_viewpoint(view, {"mug": None})
            assert engine.location("mug")[engine.sites.index("sideboard")] < 1e-10
            engine.observe_viewpoint(view, {"mug": "sideboard"})
            assert engine.location("mug")[engine.sites.index("sideboard")] > 0.99
            if engine.correlated:
                weights = engine._company.weights
                assert np.isfinite(weights).all() and (weights[:, 0] == 1.0).all()


def test_an_object_the_agent_moved_hides_where_it_is_now():
    """Location beliefs are where objects stood at the start; once the agent has put the kettle on
    the dining table, it hides the sugar there and nowhere else, whatever the kettle's start site
    (the review found the old site kept hiding and the new one not)."""
    scenario = load_scenario("milk_sugar_apartment")
    model = load_model("joint_occlusion")
    expected, company = _hiding_tables(scenario, model, "sugar|kettle", 0.0)
    agent = Agent(scenario, model)
    views = agent.set_view_geometry(expected, company)
    table_site = "dining_table"
    glance = next(v for v in scenario.viewpoints if v.kind == "room" and table_site in v.sites)
    before = views.probabilities(glance.name)["sugar"][table_site]
    agent.observe_look("kitchen_counter", {"kettle": "kitchen_counter"})
    agent.executor.objects["kettle"].current_site = table_site  # picked and put on the table
    agent._reweigh()
    after = views.probabilities(glance.name)["sugar"][table_site]
    assert after < 0.02 * before
    view = views.view(glance.name)
    s, k = agent.belief.objects.index("sugar"), agent.belief.objects.index("kettle")
    c = view.sites.index(agent.belief.sites.index(table_site))
    assert view.conditional[s, c, 0] == pytest.approx(0.0)       # nobody else by start site:
    assert view.conditional[s, c, 1 << k] == pytest.approx(0.0)  # the kettle is there anyway
    agent.executor.objects["kettle"].held = True                 # picked up again: hides nothing
    agent.executor.objects["kettle"].current_site = None
    agent._reweigh()
    assert views.probabilities(glance.name)["sugar"][table_site] == pytest.approx(
        views.view(glance.name).conditional[s, c, 0], rel=0.2)


def test_a_view_of_another_object_order_is_refused(tmp_path):
    from fg_tea.beliefs.engine import BeliefEngine

    scenario = load_scenario("default_apartment")
    model = load_model("joint_occlusion")
    expected, company = _fake_tables(scenario, model)
    views = ViewModel(scenario, model, list(reversed(scenario.object_names)), expected, company)
    with pytest.raises(ValueError, match="has rows for"):
        BeliefEngine(scenario, model).observe_viewpoint(views.views[0], {"mug": None})


def test_an_extending_file_that_switches_the_detector_is_named(tmp_path):
    path = tmp_path / "t1.toml"
    path.write_text('extends = "factorised_occlusion"\nname = "t1"\n[perception]\ndetector = "threshold"\n')
    with pytest.raises(InputError) as exc:
        load_model(path)
    assert str(path) in str(exc.value) and "detector" in str(exc.value)


def test_learning_cannot_be_combined_with_the_company_models(tmp_path, capsys):
    from fg_tea.cli.main import main

    assert main(["learn", "--base", "factorised_occlusion", "--out", str(tmp_path / "x.toml"),
                 str(ROOT / "tests" / "data" / "old_logs" / "before_viewpoints.jsonl")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--base" in err[0] and "occlusion" in err[0]
