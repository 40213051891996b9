"""World sampler: declared distributions over hidden truth (docs/design.md §11)."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from fg_tea.common.errors import InputError
from fg_tea.world.distributions import load_world

ROOT = Path(__file__).resolve().parent.parent


def truth(scenario):
    return {o.name: o.true_site for o in scenario.objects}


def test_same_seed_same_world_and_seeds_differ():
    world = load_world("correlated")
    assert world.sample(7) == world.sample(7)
    assert len({tuple(truth(world.sample(s)).values()) for s in range(30)}) > 5


def test_co_location_rate_matches_the_declared_rule():
    world = load_world("correlated")
    n = 1500
    same = sum(truth(w)["teabag"] == truth(w)["kettle"] for w in map(world.sample, range(n)))
    # P(same site) = same_site + P(drawn again onto the anchor's site by the other branches) >= 0.5
    assert 0.5 <= same / n <= 0.8
    independent = load_world("independent")
    same_ind = sum(truth(w)["teabag"] == truth(w)["kettle"] for w in map(independent.sample, range(n)))
    assert same_ind / n < same / n - 0.2
    none = world.with_knobs(same_site=0.0, same_room=0.0)
    same_none = sum(truth(w)["teabag"] == truth(w)["kettle"] for w in map(none.sample, range(n)))
    assert abs(same_none - same_ind) / n < 0.06


def test_capacity_is_never_exceeded():
    world = load_world("correlated").with_knobs(same_site=1.0)
    for seed in range(400):
        scenario = world.sample(seed)
        counts = Counter(truth(scenario).values())
        for site in scenario.sites:
            if site.capacity is not None:
                assert counts[site.name] <= site.capacity


def test_prior_violation_moves_mass_to_low_prior_sites():
    base = load_world("independent")
    violated = base.with_knobs(prior_violation=1.0)
    low = "study_shelf"  # prior 0.01 for the mug
    n = 800
    rate = lambda w: np.mean([truth(w.sample(s))["mug"] == low for s in range(n)])  # noqa: E731
    assert rate(base) < 0.04 and rate(violated) > 0.15


def test_states_drawn_pinned_or_kept_from_the_base_scenario():
    world = load_world("correlated")
    water = [world.sample(s).object("kettle").hidden_state_truth for s in range(600)]
    assert 0.28 < np.mean([w["contains_water"] for w in water]) < 0.42  # drawn from prior 0.35
    assert not any(w["water_hot"] for w in water)  # not listed: the base truth (cold) is kept


@pytest.mark.parametrize("edit,path,words", [
    (lambda d: d["placement"]["co_location"][0].__setitem__("object", "spoon"),
     "$.placement.co_location[0].object", "'spoon' is referenced but not defined"),
    (lambda d: d["states"].__setitem__("kettle.colour", "prior"), "$.states.kettle.colour",
     "no object of scenario"),
    (lambda d: d["placement"]["co_location"][0].__setitem__("same_site", 1.5),
     "$.placement.co_location[0].same_site", "outside [0, 1]"),
])
def test_bad_world_files_name_the_field(tmp_path, edit, path, words):
    data = json.loads((ROOT / "scenarios/worlds/correlated.json").read_text())
    edit(data)
    bad = tmp_path / "w.json"
    bad.write_text(json.dumps(data))
    with pytest.raises(InputError) as info:
        load_world(bad)
    assert info.value.path == path and words in info.value.fault
