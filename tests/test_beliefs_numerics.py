"""Long evidence sequences stay exact on both backends, checked against closed forms.

Repeated readings of one state and repeated misses at one site are merged into one evidence
factor per variable, summed in log space (``fg_tea.beliefs.factors.Evidence``). Without that, the
57th state reading exceeded numpy's einsum operand limit, 465 alternating readings underflowed in
gtsam into a false "probability zero", and a detection after ~240 misses at its site overflowed
eq. 4's collapse ratio.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.beliefs.factors import collapse_target
from fg_tea.beliefs.graph import assemble_graph
from fg_tea.model.spec import Sensor, load_model

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def factorised():
    return load_model(ROOT / "models" / "factorised.toml")


@pytest.fixture(scope="module")
def joint():
    return load_model(ROOT / "models" / "joint.toml")


def engine(model, backend, p_water=0.35, objects=("mug",), weights=((2.0, 0.0, 1.0),)):
    graph = assemble_graph(model, sites=("a", "b", "c"), rooms=("r", "r", "r"), objects=objects,
                           categories=objects, weights=np.array(weights),
                           state_priors={f"{objects[0]}.contains_water": p_water})
    return BeliefEngine(graph, model, backend=backend)


def odds_posterior(prior: float, readings, alpha: float, beta: float) -> float:
    """Closed form: posterior odds = prior odds x prod of likelihood ratios (eqs. 23, 24)."""
    log_odds = math.log(prior / (1 - prior))
    for value in readings:
        log_odds += math.log(alpha / (1 - beta)) if value else math.log((1 - alpha) / beta)
    if log_odds < 0:
        return math.exp(log_odds) / (1.0 + math.exp(log_odds))
    return 1.0 / (1.0 + math.exp(-log_odds))


@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
def test_five_thousand_alternating_readings_stay_exact(factorised, backend):
    belief = engine(factorised, backend)
    sensor = Sensor(0.95, 0.95)
    readings = [i % 2 == 0 for i in range(5000)]
    for i, value in enumerate(readings):
        belief.observe_state("mug.contains_water", value, sensor)
        if i in (56, 57, 464, 465, 4998, 4999):
            expected = odds_posterior(0.35, readings[:i + 1], 0.95, 0.95)
            assert belief.state("mug.contains_water") == pytest.approx(expected, abs=1e-9)
    assert belief.state("mug.contains_water") == pytest.approx(0.35, abs=1e-9)
    # One evidence factor per variable: the graph does not grow with the readings.
    assert sum(label.startswith("evidence mug.contains_water") for label in belief.factor_labels()) == 1


@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
def test_unbalanced_readings_match_the_closed_form(factorised, backend):
    belief = engine(factorised, backend)
    sensor = Sensor(0.9, 0.8)
    rng = np.random.default_rng(7)
    # log LR: +log 4.5 for a true reading, log 0.125 for a false one; a true reading with
    # probability 0.58 keeps the walk near balance, so the posterior visits moderate values.
    readings = [bool(x) for x in rng.random(3000) < 0.58]
    for i, value in enumerate(readings):
        belief.observe_state("mug.contains_water", value, sensor)
        if i % 500 == 499:
            expected = odds_posterior(0.35, readings[:i + 1], 0.9, 0.8)
            assert belief.state("mug.contains_water") == pytest.approx(expected, abs=1e-9)


@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
def test_thousand_misses_then_a_detection_collapse_as_eq_4(factorised, backend):
    belief = engine(factorised, backend)
    mu, floor = factorised.miss_likelihood, factorised.prior_floor
    for n in range(1, 1001):
        belief.observe_site("a", {"mug": False})
        if n in (10, 240, 300):
            # q(L = a) = 2 mu^n / (2 mu^n + 1e-4 + 1) (prior (2, 1e-4, 1) with the floor)
            expected = 2 * mu ** n / (2 * mu ** n + floor + 1)
            assert belief.location("mug")[0] == pytest.approx(expected, rel=1e-9, abs=1e-300)
    belief.observe_site("a", {"mug": True})
    # Eq. 4: q+(L = i) is proportional to 1 at the site and eps elsewhere: 1 / (1 + 2 eps) there.
    target = np.array([1.0, floor, floor]) / (1 + 2 * floor)
    np.testing.assert_allclose(belief.location("mug"), target, rtol=0, atol=1e-12)
    np.testing.assert_allclose(collapse_target(0, 3, floor), target, rtol=0, atol=1e-15)
    assert belief.check_against_gtsam() < 1e-9


@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
@pytest.mark.parametrize("which", ["factorised", "joint"])
def test_misses_elsewhere_then_a_detection_keep_eq_4s_floor(factorised, joint, which, backend):
    """About 250 misses at the *other* sites push their q below the smallest float; a detection
    must still give eq. 4's floor there (it gave [1, 0, 0]), and a later detection at one of those
    sites must collapse there, not raise ContradictionError."""
    model = factorised if which == "factorised" else joint
    belief = engine(model, backend)
    floor = model.prior_floor
    for _ in range(300):
        belief.observe_site("b", {"mug": False})
        belief.observe_site("c", {"mug": False})
    belief.observe_site("a", {"mug": True})
    target = np.array([1.0, floor, floor]) / (1 + 2 * floor)
    np.testing.assert_allclose(belief.location("mug"), target, rtol=1e-9, atol=0)
    belief.observe_site("b", {"mug": True})
    np.testing.assert_allclose(belief.location("mug"), [floor / (1 + 2 * floor), 1 / (1 + 2 * floor),
                                                        floor / (1 + 2 * floor)], rtol=1e-9, atol=0)


@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
def test_joint_model_thousand_misses_then_a_detection(joint, backend):
    belief = engine(joint, backend, objects=("kettle", "teabag"),
                    weights=((2.0, 0.0, 1.0), (1.0, 1.0, 1.0)))
    for _ in range(1000):
        belief.observe_site("b", {"kettle": False})
    belief.observe_site("b", {"kettle": True})
    floor = joint.prior_floor
    target = np.array([floor, 1.0, floor]) / (1 + 2 * floor)
    np.testing.assert_allclose(belief.location("kettle"), target, rtol=0, atol=1e-12)
    assert belief.check_against_gtsam() < 1e-9


# ------------------------------------------------------------------ several objects in one look
def _apartment(order):
    import dataclasses

    from fg_tea.world.scenario import load_scenario
    scenario = load_scenario("default_apartment")
    return dataclasses.replace(scenario, objects=tuple(
        sorted(scenario.objects, key=lambda o: order.index(o.name))))


@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
def test_joint_several_objects_seen_in_one_look_each_end_at_eq_4_in_any_order(joint, backend):
    # The kettle and the teabag are co-located and share capacity in the joint model, so one
    # collapse moves the other; applied one after the other, the first one seen ended 3e-4 off
    # eq. 4, and which one depended on the order of objects in the scenario file.
    results = []
    for order in (("mug", "kettle", "teabag"), ("teabag", "kettle", "mug"), ("kettle", "mug", "teabag")):
        scenario = _apartment(order)
        belief = BeliefEngine(scenario, joint, backend=backend)
        belief.observe_site("pantry_shelf", {"mug": False})
        belief.observe_site("kitchen_counter", {"kettle": True, "teabag": True, "mug": False})
        j = scenario.site_index("kitchen_counter")
        target = collapse_target(j, len(scenario.sites), joint.prior_floor)
        for obj in ("kettle", "teabag"):
            np.testing.assert_allclose(belief.location(obj), target, rtol=0, atol=1e-12)
        results.append(belief.location("mug"))
        assert belief.check_against_gtsam() < 1e-9
    for other in results[1:]:
        np.testing.assert_allclose(other, results[0], rtol=0, atol=1e-12)


def _fit(table: np.ndarray, targets: dict[int, np.ndarray], sweeps: int = 20_000) -> np.ndarray:
    """Iterative proportional fitting of a dense joint to the given marginals, to the last bit."""
    t = table / table.sum()
    for _ in range(sweeps):
        old = t
        for axis, target in targets.items():
            other = tuple(a for a in range(t.ndim) if a != axis)
            now = t.sum(axis=other)
            shape = [1] * t.ndim
            shape[axis] = -1
            t = t * np.where(now > 0, target / np.where(now > 0, now, 1.0), 0.0).reshape(shape)
        if np.array_equal(t, old):
            break
    return t


@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
def test_a_chain_of_looks_after_several_detections_matches_dense_enumeration(joint, backend):
    """Several objects seen in one look, then misses: the engine's marginals equal a dense joint
    fitted to eq. 4's targets and multiplied by the same miss factors, to 1e-14 (the fit stops on
    a relative rule, docs/design.md §3.2)."""
    scenario = _apartment(("mug", "kettle", "teabag"))
    belief = BeliefEngine(scenario, joint, backend=backend)
    belief.observe_site("pantry_shelf", {"mug": False, "teabag": False})
    sites, objects = list(scenario.site_names), list(belief.objects)
    table = belief.location_joint()
    j = scenario.site_index("kitchen_counter")
    belief.observe_site("kitchen_counter", {"kettle": True, "teabag": True, "mug": False})
    target = collapse_target(j, len(sites), joint.prior_floor)
    miss = np.ones(len(sites))
    miss[j] = joint.miss_likelihood
    shape = [1] * table.ndim
    shape[objects.index("mug")] = -1
    reference = _fit(table * miss.reshape(shape), {objects.index("kettle"): target,
                                                   objects.index("teabag"): target})
    # Looks that miss the seen objects where they were seen (they were moved, or the camera
    # missed): the fit's residue on the floor entries is what these magnify.
    for _ in range(8):
        for obj in ("kettle", "teabag", "mug"):
            belief.observe_site("kitchen_counter", {obj: False})
            factor = np.ones(len(sites))
            factor[j] = joint.miss_likelihood
            axis = [1] * table.ndim
            axis[objects.index(obj)] = -1
            reference = reference * factor.reshape(axis)
            reference = reference / reference.sum()
        for u, obj in enumerate(objects):
            want = reference.sum(axis=tuple(a for a in range(reference.ndim) if a != u))
            np.testing.assert_allclose(belief.location(obj), want, rtol=0, atol=1e-14, err_msg=obj)
