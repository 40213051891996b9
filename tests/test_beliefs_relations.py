"""Relational factors, contradictions, snapshots, new states and time slices of the belief engine.

- A detection of the kettle moves the teabag in the joint model (co-location) and not in the
  factorised one; a full site (capacity) pushes the other objects away.
- Evidence with probability zero raises ContradictionError and leaves the belief as it was; no NaN
  leaves the engine.
- Snapshots are JSON and round-trip; objects gain states (a cupboard's ``open``); time-sliced task
  states are summed out, so the graph does not grow with transitions.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.beliefs.graph import assemble_graph
from fg_tea.common.errors import ContradictionError
from fg_tea.model.spec import Effect, Relation, Sensor, load_model
from fg_tea.world.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
TOL = 1e-12


@pytest.fixture(scope="module")
def scenario():
    return load_scenario(ROOT / "scenarios" / "default_apartment.json")


@pytest.fixture(scope="module")
def joint():
    return load_model(ROOT / "models" / "joint.toml")


@pytest.fixture(scope="module")
def factorised():
    return load_model(ROOT / "models" / "factorised.toml")


def all_finite(belief: BeliefEngine) -> bool:
    arrays = [belief.location_matrix(), belief.pairwise(), *belief.hypothetical_all(),
              np.array(list(belief.states().values()))]
    return all(np.all(np.isfinite(a)) for a in arrays)


# ------------------------------------------------------------------ co-location and capacity
@pytest.mark.parametrize("positive_update", ["collapse", "likelihood"])
def test_kettle_detection_moves_the_teabag_only_in_the_joint_model(scenario, joint, factorised,
                                                                   positive_update):
    counter = scenario.site_index("kitchen_counter")
    moved = {}
    for model in (joint, factorised):
        model = model.with_overrides(positive_update=positive_update)
        belief = BeliefEngine(scenario, model)
        before = belief.location("teabag")
        belief.observe_site("kitchen_counter", {"kettle": True})
        moved[model.structure] = (before, belief.location("teabag"))
    before, after = moved["factorised"]
    np.testing.assert_array_equal(before, after)
    before, after = moved["joint"]
    assert np.max(np.abs(after - before)) > 1e-3
    # co-location (teabag with kettle, x3 on one site, x2 in one room) pulls it to the counter
    assert after[counter] > before[counter]
    kitchen = [scenario.site_index(s.name) for s in scenario.sites if s.room == "kitchen"]
    assert after[kitchen].sum() > before[kitchen].sum()


def test_a_full_site_pushes_the_other_objects_away(scenario, joint):
    side = scenario.site_index("side_table")            # capacity 1
    assert scenario.site("side_table").capacity == 1
    belief = BeliefEngine(scenario, joint)
    before = belief.location_matrix()
    belief.observe_site("side_table", {"mug": True})
    after = belief.location_matrix()
    for obj in ("kettle", "teabag"):
        o = belief.objects.index(obj)
        assert after[o, side] < before[o, side]


def test_capacity_arithmetic_on_a_tiny_house(joint):
    # Two objects, sites a (capacity 1), b, c, uniform priors, capacity penalty 0.05, A seen at a
    # with a perfect detector (fp = 0): A is at a, so q(B) ∝ (1/3 * 0.05, 1/3, 1/3)
    #   = (0.05, 1, 1) / 2.05.
    model = joint.with_overrides(relations=(Relation("capacity", penalty=0.05),),
                                 positive_update="likelihood", false_positive_rate=0.0)
    graph = assemble_graph(model, ("a", "b", "c"), ("r", "r", "r"), ("A", "B"), ("x", "y"),
                           np.ones((2, 3)), capacities=(1, None, None))
    for backend in ("numpy", "gtsam"):
        belief = BeliefEngine(graph, model, backend=backend)
        # before: q(B = a) = sum over A: (1/3)(1/3)(0.05 if A = a else 1) / Z with
        #   Z = 9 * (1/9) - (1/9)(1 - 0.05) = 1 - 0.95/9 -> q(B = a) = (0.05 + 2) / 9 / Z
        z = 1 - 0.95 / 9
        assert belief.location("B")[0] == pytest.approx((0.05 + 2) / 9 / z, abs=TOL)
        belief.observe_site("a", {"A": True})
        np.testing.assert_allclose(belief.location("B"), np.array([0.05, 1, 1]) / 2.05,
                                   rtol=0, atol=TOL)


# ------------------------------------------------------------------ contradictions
@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
def test_opposite_readings_of_a_perfect_sensor_are_a_contradiction(scenario, factorised, backend):
    belief = BeliefEngine(scenario, factorised, backend=backend)
    perfect = Sensor(1.0, 1.0)
    belief.observe_state("kettle.contains_water", True, perfect)
    assert belief.state("kettle.contains_water") == pytest.approx(1.0, abs=TOL)
    before, labels = belief.states(), belief.factor_labels()
    with pytest.raises(ContradictionError, match="probability zero"):
        belief.observe_state("kettle.contains_water", False, perfect)
    assert belief.states() == before
    assert belief.factor_labels() == labels
    assert all_finite(belief)
    # the belief is still usable afterwards
    belief.observe_state("kettle.contains_water", True, perfect)
    assert belief.state("kettle.contains_water") == pytest.approx(1.0, abs=TOL)


@pytest.mark.parametrize("backend, solver", [("numpy", "dense"), ("numpy", "structured"),
                                             ("gtsam", "auto")])
def test_two_objects_seen_on_a_hard_capacity_one_site_is_a_contradiction(scenario, joint,
                                                                        backend, solver):
    model = joint.with_overrides(relations=(Relation("capacity", penalty=0.0),),
                                 positive_update="likelihood", false_positive_rate=0.0)
    belief = BeliefEngine(scenario, model, backend=backend, location_solver=solver)
    belief.observe_site("side_table", {"mug": True})
    side = scenario.site_index("side_table")
    assert belief.location("kettle")[side] == 0.0          # the site is full
    before, labels = belief.location_matrix(), belief.factor_labels()
    with pytest.raises(ContradictionError):
        # the teabag's miss is absorbed first, then the kettle's detection fails: all undone
        belief.observe_site("side_table", {"teabag": False, "kettle": True})
    np.testing.assert_array_equal(belief.location_matrix(), before)
    assert belief.factor_labels() == labels
    assert all_finite(belief)
    # hypotheses of probability zero (kettle seen on the full site) leave the marginals as they are
    miss, seen = belief.hypothetical_all()
    np.testing.assert_allclose(seen[belief.objects.index("kettle"), side], before, atol=1e-12)


def test_no_nan_leaves_the_engine_after_extreme_but_possible_evidence(scenario, joint):
    belief = BeliefEngine(scenario, joint)
    for _ in range(40):                                   # mu^40 ~ 1e-52: still representable
        belief.observe_site("kitchen_counter", {"mug": False, "kettle": False, "teabag": False})
    belief.observe_site("study_shelf", {"mug": True, "kettle": True, "teabag": True})
    assert all_finite(belief)
    np.testing.assert_allclose(belief.location_matrix().sum(axis=1), 1.0, atol=1e-12)
    assert belief.check_against_gtsam() < 1e-9


# ------------------------------------------------------------------ snapshots and new states
def test_snapshot_is_json_and_round_trips(scenario, joint):
    belief = BeliefEngine(scenario, joint)
    belief.observe_site("pantry_shelf", {"teabag": False, "mug": False})
    belief.observe_state("kettle.contains_water", True, joint.sensor("state"))
    snap = belief.snapshot()
    back = json.loads(json.dumps(snap))
    assert back == snap
    np.testing.assert_array_equal(np.array([back["locations"][o] for o in belief.objects]),
                                  belief.location_matrix())
    assert back["states"] == belief.states()
    assert back["sites"] == list(scenario.site_names)
    rounded = json.loads(json.dumps(belief.snapshot(digits=4)))
    assert rounded["states"]["kettle.contains_water"] == round(belief.state("kettle.contains_water"), 4)


@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
def test_objects_gain_new_states(scenario, factorised, backend):
    belief = BeliefEngine(scenario, factorised, backend=backend)
    assert not belief.has_state("cupboard.open")
    belief.ensure_state("cupboard.open", 0.3)
    belief.ensure_state("cupboard.open", 0.9)             # already there: unchanged
    assert belief.state("cupboard.open") == pytest.approx(0.3, abs=TOL)
    # eq. 23 with alpha = beta = 0.95: 0.95 * 0.3 / (0.95 * 0.3 + 0.05 * 0.7) = 0.285 / 0.32
    belief.observe_state("cupboard.open", True, factorised.sensor("state"))
    p = 0.285 / 0.32
    assert belief.state("cupboard.open") == pytest.approx(p, abs=TOL)
    # eq. 27, open with success 0.9: p' = p + (1 - p) * 0.9
    belief.apply_effects([Effect("cupboard.open", True, 0.9)])
    assert belief.state("cupboard.open") == pytest.approx(p + (1 - p) * 0.9, abs=TOL)
    assert "cupboard.open" in belief.snapshot()["states"]
    with pytest.raises(ValueError):
        belief.ensure_state("drawer.open", 1.5)
    assert not belief.has_state("drawer.open")


# ------------------------------------------------------------------ time slices
@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
def test_transitions_keep_one_factor_over_the_current_slice(scenario, factorised, backend):
    belief = BeliefEngine(scenario, factorised, backend=backend)
    fill = [Effect("kettle.contains_water", True, 0.995)]
    boil = [Effect("kettle.water_hot", True, 0.995, ("kettle.contains_water",))]
    pour = [Effect("mug.contains_water", True, 0.99, ("kettle.contains_water",)),
            Effect("kettle.contains_water", False, 0.99)]
    belief.apply_effects(fill)
    sizes = [len(belief.factor_labels())]
    p = 0.995 + 0.005 * 0.35
    for _ in range(12):
        belief.apply_effects(pour)
        belief.apply_effects(fill)
        belief.apply_effects(boil)
        sizes.append(len(belief.factor_labels()))
        p = 0.995 + 0.005 * (p * 0.01)                   # pour empties (x 0.01), fill refills
    assert len(set(sizes)) == 1
    state_labels = [x for x in belief.factor_labels() if not x.startswith(("prior L[", "capacity"))]
    assert len(state_labels) == 1                        # one factor over the current slice
    assert belief.state("kettle.contains_water") == pytest.approx(p, abs=1e-12)
    assert 0.0 <= belief.state("mug.contains_water") <= 1.0
