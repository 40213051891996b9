"""Does the agent's expected P(seen) average the curve over a site's placement slots?

The environment hands over one expected pixel count per placement slot of each site
(docs/design.md §3.4); the view model's p is the mean of the curve over those slots, each slot
equally likely (eq. (33)), not the curve at the mean pixel count. A single number counts as one
slot. The fake house, which has no slots, gives every slot the same count.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from fg_tea.beliefs.detection import ViewModel, slot_pixels
from fg_tea.env.fake import FakeHouse
from fg_tea.episode.runner import env_config_for
from fg_tea.model.spec import load_model
from fg_tea.world.scenario import load_scenario


def _table(scenario, value):
    """Every (viewpoint, in-view site, category) entry set to `value`."""
    cats = {o.category for o in scenario.objects}
    return {v.name: {s: {c: value for c in cats} for s in v.sites} for v in scenario.viewpoints}


def test_p_is_the_mean_of_the_curve_over_slots_not_the_curve_at_the_mean():
    scenario, model = load_scenario("default_apartment"), load_model("factorised")
    curve = model.detection_curve
    slots = [20.0, 50.0, 140.0]
    views = ViewModel(scenario, model, scenario.object_names, _table(scenario, slots))
    glance = next(v for v in scenario.viewpoints if v.kind == "room")
    site = glance.sites[0]
    p = views.probabilities(glance.name)["teabag"][site]
    expected = np.mean([curve.probability("teabag", n) for n in slots])
    assert p == pytest.approx(expected, abs=1e-12)
    # The curve is not linear in n, so the two differ here by more than rounding.
    assert abs(p - curve.probability("teabag", np.mean(slots))) > 0.01
    view = views.view(glance.name)
    assert view.pixels[0, 0] == pytest.approx(np.mean(slots))


def test_a_number_is_one_slot():
    scenario, model = load_scenario("default_apartment"), load_model("factorised")
    one = ViewModel(scenario, model, scenario.object_names, _table(scenario, 50.0))
    listed = ViewModel(scenario, model, scenario.object_names, _table(scenario, [50.0]))
    for v in one.views:
        assert np.array_equal(v.probability, listed.view(v.name).probability)
    with pytest.raises(ValueError):
        slot_pixels([])


def test_threshold_glance_counts_the_slots_that_reach_the_threshold():
    scenario = load_scenario("default_apartment")
    model = load_model("factorised")
    model = replace(model, detector="threshold")
    thr = model.min_visible_pixels
    views = ViewModel(scenario, model, scenario.object_names,
                      _table(scenario, [thr - 1, thr, thr + 10]))
    glance = next(v for v in scenario.viewpoints if v.kind == "room")
    p = views.probabilities(glance.name)["mug"][glance.sites[0]]
    assert p == pytest.approx((1.0 - model.miss_likelihood) * 2 / 3)


def test_fake_house_gives_one_equal_count_per_slot():
    scenario, model = load_scenario("default_apartment"), load_model("factorised")
    env = FakeHouse(scenario, env_config_for(model))
    env.reset(0)
    table = env.expected_pixel_counts(["mug", "teabag"])
    for vp in scenario.viewpoints:
        for s in vp.sites:
            cap = scenario.site(s).capacity
            n_slots = min(len(scenario.objects), cap) if cap is not None else len(scenario.objects)
            for counts in table[vp.name][s].values():
                assert len(counts) == n_slots == env.slot_count(s)
                assert len(set(counts)) == 1
