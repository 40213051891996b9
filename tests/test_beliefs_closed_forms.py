"""Factorised beliefs equal the closed forms of docs/design.md §4.2 to 1e-12, arithmetic written out.

Equations: prior [2], positive evidence [4], negative evidence [5, 6], noisy state reading
[23, 24], direct action effects [25, 26] and full transitions P(z'|z, a) [27], including the
kettle -> mug coupling of pouring. Each expected number is computed by hand in a comment and
then as a literal expression, never through the engine's own code.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fg_tea.beliefs.engine import BeliefEngine, entropy
from fg_tea.beliefs.graph import assemble_graph
from fg_tea.model.spec import Effect, load_model
from fg_tea.world.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
TOL = 1e-12


@pytest.fixture(scope="module")
def factorised():
    return load_model(ROOT / "models" / "factorised.toml")


def three_sites(model, weights=((2.0, 0.0, 1.0),), objects=("mug",), state_priors=None):
    """Sites a, b, c (one room) and one object per weight row."""
    graph = assemble_graph(model, sites=("a", "b", "c"), rooms=("r", "r", "r"), objects=objects,
                           categories=objects, weights=np.array(weights),
                           state_priors=state_priors)
    return BeliefEngine(graph, model)


def effects(model, action, obj, destination=None):
    """The model's declared effects of `action` with the role templates filled in."""
    def fill(s):
        return s.replace("{object}", obj).replace("{destination}", destination or "")

    return [Effect(fill(e.state), e.value, e.success, tuple(fill(r) for r in e.requires))
            for e in model.transition(action).effects]


# ---------------------------------------------------------------------------------- eq. 2
def test_prior_applies_the_floor_to_zero_weights(factorised):
    # a = (2, 0, 1), eps = 1e-4: max(a, eps) = (2, 1e-4, 1), sum = 3.0001
    belief = three_sites(factorised)
    assert factorised.prior_floor == 1e-4
    expected = np.array([2 / 3.0001, 1e-4 / 3.0001, 1 / 3.0001])
    np.testing.assert_allclose(belief.location("mug"), expected, rtol=0, atol=TOL)
    assert belief.location("mug")[1] > 0  # the floor keeps every site possible


def test_prior_matches_the_default_apartment_affordances(factorised):
    scenario = load_scenario(ROOT / "scenarios" / "default_apartment.json")
    belief = BeliefEngine(scenario, factorised)
    for obj in scenario.objects:
        w = np.array([max(s.affordances.get(obj.category, 0.0), 1e-4) for s in scenario.sites])
        np.testing.assert_allclose(belief.location(obj.name), w / w.sum(), rtol=0, atol=TOL)


# ---------------------------------------------------------------------------------- eq. 4
def test_positive_evidence_collapses_onto_the_site(factorised):
    # q+(i) ∝ 1 at j = c, eps elsewhere: (1e-4, 1e-4, 1) / 1.0002, whatever the prior was
    belief = three_sites(factorised)
    belief.observe_site("c", {"mug": True})
    expected = np.array([1e-4 / 1.0002, 1e-4 / 1.0002, 1 / 1.0002])
    np.testing.assert_allclose(belief.location("mug"), expected, rtol=0, atol=TOL)
    # A detection at a floor site collapses just the same.
    belief.observe_site("b", {"mug": True})
    np.testing.assert_allclose(belief.location("mug"), [1e-4 / 1.0002, 1 / 1.0002, 1e-4 / 1.0002],
                               rtol=0, atol=TOL)


def test_likelihood_detection_is_bayes_with_false_positive_rate(factorised):
    # positive_update = "likelihood": q(i) ∝ q(i) P(seen at c | i) = q(i) * (fp, fp, 1 - mu)
    # prior (2, 1e-4, 1)/3.0001 -> unnormalised (2 * 1e-4, 1e-4 * 1e-4, 1 * 0.95) (the 3.0001 cancels)
    model = factorised.with_overrides(positive_update="likelihood")
    belief = three_sites(model)
    belief.observe_site("c", {"mug": True})
    u = np.array([2 * 1e-4, 1e-4 * 1e-4, 0.95])
    np.testing.assert_allclose(belief.location("mug"), u / u.sum(), rtol=0, atol=TOL)


# ---------------------------------------------------------------------------------- eqs. 5, 6
def test_negative_evidence_scales_the_inspected_site_by_mu(factorised):
    # miss at a: q ∝ (2 * 0.05, 1e-4, 1) = (0.1, 1e-4, 1), sum 1.1001
    belief = three_sites(factorised)
    belief.observe_site("a", {"mug": False})
    np.testing.assert_allclose(belief.location("mug"), [0.1 / 1.1001, 1e-4 / 1.1001, 1 / 1.1001],
                               rtol=0, atol=TOL)


def test_two_misses_at_one_site_compound_mu_squared(factorised):
    # two misses at a: q ∝ (2 * 0.05^2, 1e-4, 1) = (0.005, 1e-4, 1), sum 1.0051
    belief = three_sites(factorised)
    belief.observe_site("a", {"mug": False})
    belief.observe_site("a", {"mug": False})
    np.testing.assert_allclose(belief.location("mug"), [0.005 / 1.0051, 1e-4 / 1.0051, 1 / 1.0051],
                               rtol=0, atol=TOL)


def test_omitted_object_is_no_observation_and_others_stay_independent(factorised):
    # mug missed at a, kettle seen at a, teabag omitted: each follows its own closed form.
    belief = three_sites(factorised, weights=((2, 0, 1), (1, 1, 1), (0, 3, 1)),
                         objects=("mug", "kettle", "teabag"))
    teabag_before = belief.location("teabag")
    update = belief.observe_site("a", {"mug": False, "kettle": True})
    np.testing.assert_allclose(belief.location("mug"), [0.1 / 1.1001, 1e-4 / 1.1001, 1 / 1.1001],
                               rtol=0, atol=TOL)
    np.testing.assert_allclose(belief.location("kettle"), [1 / 1.0002, 1e-4 / 1.0002, 1e-4 / 1.0002],
                               rtol=0, atol=TOL)
    # teabag prior (1e-4, 3, 1) / 4.0001, untouched
    np.testing.assert_allclose(teabag_before, [1e-4 / 4.0001, 3 / 4.0001, 1 / 4.0001], rtol=0, atol=TOL)
    np.testing.assert_array_equal(belief.location("teabag"), teabag_before)
    assert update.detected == ("kettle",)
    # entropy eq. 7 of the mug after the miss
    q = np.array([0.1, 1e-4, 1]) / 1.1001
    assert belief.entropy("L[mug]") == pytest.approx(-(q * np.log(q)).sum(), abs=TOL)
    assert entropy(q) == pytest.approx(belief.entropy("L[mug]"), abs=TOL)


# ---------------------------------------------------------------------------------- eqs. 23, 24
@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
def test_noisy_state_reading_is_bayes(factorised, backend):
    scenario = load_scenario(ROOT / "scenarios" / "default_apartment.json")
    sensor = factorised.sensor("state")
    assert (sensor.sensitivity, sensor.specificity) == (0.95, 0.95)
    belief = BeliefEngine(scenario, factorised, backend=backend)
    assert belief.state("kettle.contains_water") == pytest.approx(0.35, abs=TOL)
    # eq. 23: 0.95 * 0.35 / (0.95 * 0.35 + 0.05 * 0.65) = 0.3325 / 0.365 = 0.910958904...
    update = belief.observe_state("kettle.contains_water", True, sensor)
    assert update.after["kettle.contains_water"] == pytest.approx(0.3325 / 0.365, abs=TOL)
    assert 0.3325 / 0.365 == pytest.approx(0.9109589041, abs=1e-10)
    # eq. 24 from p = 0.3325/0.365: (0.05 p) / (0.05 p + 0.95 (1 - p))
    p = 0.3325 / 0.365
    belief.observe_state("kettle.contains_water", False, sensor)
    assert belief.state("kettle.contains_water") == pytest.approx(0.05 * p / (0.05 * p + 0.95 * (1 - p)),
                                                                  abs=TOL)
    # one positive and one negative reading of a symmetric sensor cancel: back to 0.35
    assert belief.state("kettle.contains_water") == pytest.approx(0.35, abs=TOL)
    # the other states are untouched
    assert belief.state("kettle.water_hot") == pytest.approx(0.01, abs=TOL)


def test_negative_reading_from_the_prior(factorised):
    # eq. 24: 0.05 * 0.35 / (0.05 * 0.35 + 0.95 * 0.65) = 0.0175 / 0.635 = 0.027559...
    belief = three_sites(factorised, state_priors={"kettle.contains_water": 0.35})
    belief.observe_state("kettle.contains_water", False, factorised.sensor("state"))
    assert belief.state("kettle.contains_water") == pytest.approx(0.0175 / 0.635, abs=TOL)


# ---------------------------------------------------------------------------------- eqs. 25, 26
def test_direct_effects_set_the_declared_reliability(factorised):
    belief = three_sites(factorised, state_priors={"kettle.contains_water": 0.35,
                                                   "kettle.water_hot": 0.01,
                                                   "mug.contains_water": 0.02,
                                                   "mug.water_hot": 0.01})
    # eq. 25: fill -> q'(water) = rho = 0.995, whatever the prior 0.35 was
    update = belief.apply_effects(effects(factorised, "fill", "kettle"), direct=True)
    assert update.after["kettle.contains_water"] == pytest.approx(0.995, abs=TOL)
    # eq. 26: pour sets kettle water false with rho = 0.99 -> q' = 1 - 0.99 = 0.01;
    # mug water true with 0.99, mug hot true with 0.97, kettle hot false -> 0.01
    belief.apply_effects(effects(factorised, "pour", "kettle", "mug"), direct=True)
    assert belief.state("kettle.contains_water") == pytest.approx(1 - 0.99, abs=TOL)
    assert belief.state("kettle.water_hot") == pytest.approx(1 - 0.99, abs=TOL)
    assert belief.state("mug.contains_water") == pytest.approx(0.99, abs=TOL)
    assert belief.state("mug.water_hot") == pytest.approx(0.97, abs=TOL)


def test_model_option_selects_the_direct_form(factorised):
    direct = factorised.with_overrides(transition_form="direct")
    belief = three_sites(direct, state_priors={"kettle.contains_water": 0.35,
                                               "kettle.water_hot": 0.2})
    # boil, direct: q'(hot) = 0.995 even though water is only 0.35 likely
    belief.apply_effects(effects(direct, "boil", "kettle"))
    assert belief.state("kettle.water_hot") == pytest.approx(0.995, abs=TOL)


# ---------------------------------------------------------------------------------- eq. 27
@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
def test_full_transitions_fill_boil_pour(factorised, backend):
    scenario = load_scenario(ROOT / "scenarios" / "default_apartment.json")
    belief = BeliefEngine(scenario, factorised, backend=backend)
    # fill from p = 0.35: p' = 0.995 + 0.005 p = 0.995 + 0.00175 = 0.99675
    belief.apply_effects(effects(factorised, "fill", "kettle"))
    w = 0.995 + 0.005 * 0.35
    assert belief.state("kettle.contains_water") == pytest.approx(w, abs=TOL)
    assert w == pytest.approx(0.99675, abs=TOL)
    # boil requires water: hot' = P(hot) + P(not hot, water) * 0.995 (water, hot independent so far)
    #   = 0.01 + 0.99 * 0.99675 * 0.995 = 0.01 + 0.9818485875 = 0.9918485875
    belief.apply_effects(effects(factorised, "boil", "kettle"))
    h = 0.01 + 0.99 * w * 0.995
    assert belief.state("kettle.water_hot") == pytest.approx(h, abs=TOL)
    assert h == pytest.approx(0.9918485875, abs=TOL)
    # boiling made water and heat dependent: P(water, hot) = P(water) (P(hot) + P(not hot) 0.995)
    #   = 0.99675 * (0.01 + 0.99 * 0.995) = 0.99675 * 0.99505
    p_wh = w * (0.01 + 0.99 * 0.995)
    np.testing.assert_allclose(belief.state_joint(["kettle.contains_water", "kettle.water_hot"])[1, 1],
                               p_wh, rtol=0, atol=TOL)
    # pour couples kettle -> mug (all effects read the pre-pour state):
    #   mug water' = 0.02 + 0.98 * P(kettle water) * 0.99
    #   mug hot'   = 0.01 + 0.99 * P(kettle water, kettle hot) * 0.97
    #   kettle water' = P(kettle water) * (1 - 0.99); kettle hot' = P(kettle hot) * (1 - 0.99)
    belief.apply_effects(effects(factorised, "pour", "kettle", "mug"))
    assert belief.state("mug.contains_water") == pytest.approx(0.02 + 0.98 * w * 0.99, abs=TOL)
    assert belief.state("mug.water_hot") == pytest.approx(0.01 + 0.99 * p_wh * 0.97, abs=TOL)
    assert belief.state("kettle.contains_water") == pytest.approx(w * 0.01, abs=TOL)
    assert belief.state("kettle.water_hot") == pytest.approx(h * 0.01, abs=TOL)


def test_boil_of_an_empty_kettle_does_nothing(factorised):
    # water known false (prior 0): hot' = P(hot) + P(not hot) * P(water) * 0.995 = 0.01 + 0 = 0.01
    belief = three_sites(factorised, state_priors={"kettle.contains_water": 0.0,
                                                   "kettle.water_hot": 0.01})
    belief.apply_effects(effects(factorised, "boil", "kettle"))
    assert belief.state("kettle.water_hot") == pytest.approx(0.01, abs=TOL)
    # from the bundled prior 0.35 instead: 0.01 + 0.99 * 0.35 * 0.995 = 0.3547675
    belief = three_sites(factorised, state_priors={"kettle.contains_water": 0.35,
                                                   "kettle.water_hot": 0.01})
    belief.apply_effects(effects(factorised, "boil", "kettle"))
    assert belief.state("kettle.water_hot") == pytest.approx(0.3547675, abs=TOL)
