"""The injected detector miss rate (``EnvConfig.detection_miss_rate``), an experiment knob.

A would-be detection is dropped with the given probability, drawn from the environment's seeded
RNG: rate 1 never detects, rate 0 changes nothing (and draws nothing), the same seed gives the same
drops, and rate 0.5 drops about half. Checked on the fake house (oracle perception: an object is
seen exactly when it truly stands at the inspected site) and once on the PyBullet house.
"""

from __future__ import annotations

import pytest

from fg_tea.env.base import EnvConfig
from fg_tea.env.fake import FakeHouse
from fg_tea.world.scenario import load_scenario

SCENARIO = load_scenario("default_apartment")
OBJECTS = ("mug", "kettle", "teabag")
#: Scenario truth: mug on the sideboard, kettle on the kitchen counter, teabag on the pantry shelf.
TOUR = ("sideboard", "kitchen_counter", "pantry_shelf", "dining_table")


def tour(env, rounds: int) -> list[dict[str, bool]]:
    """Inspect the TOUR sites `rounds` times over; the detections of every inspection, in order."""
    return [dict(env.inspect_viewpoint(site, OBJECTS).detections)
            for _ in range(rounds) for site in TOUR]


def fake(rate: float) -> FakeHouse:
    return FakeHouse(SCENARIO, EnvConfig(detection_miss_rate=rate))


def test_rate_one_never_detects():
    env = fake(1.0)
    env.reset(0)
    results = tour(env, 3)
    assert results and all(v is False for r in results for v in r.values())
    # the pixels are still counted: only the detector's verdict is dropped
    assert env.inspect_viewpoint("sideboard", ["mug"]).pixel_counts["mug"] > 0


def test_rate_zero_is_the_plain_detector_and_draws_nothing():
    env = fake(0.0)
    env.reset(0)
    results = tour(env, 2)
    expected = {"sideboard": "mug", "kitchen_counter": "kettle", "pantry_shelf": "teabag",
                "dining_table": None}
    for site, r in zip(TOUR * 2, results):
        assert r == {o: o == expected[site] for o in OBJECTS}
    # no draw was made: the RNG is where a fresh reset leaves it
    after = float(env._rng.random())
    env.reset(0)
    assert after == float(env._rng.random())


@pytest.mark.parametrize("rate", [0.0, 0.3])
def test_same_seed_same_results(rate):
    a, b = fake(rate), fake(rate)
    a.reset(7), b.reset(7)
    assert tour(a, 10) == tour(b, 10)


def test_different_seeds_drop_different_detections():
    a, b = fake(0.5), fake(0.5)
    a.reset(1), b.reset(2)
    assert tour(a, 10) != tour(b, 10)


def test_rate_half_drops_about_half():
    env = fake(0.5)
    env.reset(0)
    results = tour(env, 100)   # 300 would-be detections (3 of the 4 tour sites hold an object)
    seen = sum(v for r in results for v in r.values())
    # Binomial(300, 0.5): mean 150, sd 8.7; 120..180 is +-3.5 sd
    assert 120 <= seen <= 180
    # misses stay misses: an object not at the site is never reported seen
    assert not any(r["mug"] for site, r in zip(TOUR * 100, results) if site != "sideboard")


def test_rate_outside_unit_interval_is_rejected():
    with pytest.raises(ValueError, match="detection_miss_rate"):
        fake(1.5)
    with pytest.raises(ValueError, match="detection_miss_rate"):
        fake(-0.1)


def test_pybullet_house_applies_the_rate():
    from fg_tea.env.house import PyBulletHouse

    for rate, seen in ((0.0, True), (1.0, False)):
        house = PyBulletHouse(SCENARIO, EnvConfig(ego_width=160, ego_height=120,
                                                  detection_miss_rate=rate))
        try:
            house.reset(0)
            result = house.inspect_viewpoint("sideboard", ["mug"])
        finally:
            house.close()
        assert result.detections["mug"] is seen
        assert result.pixel_counts["mug"] >= 25


def test_a_miss_rate_with_no_effect_under_the_camera_is_refused():
    """The visibility detector draws each detection from its curve; injected misses would be
    silently ignored, so the setting is refused with one line naming it (docs/design.md §1.3)."""
    from fg_tea.common.errors import InputError
    from fg_tea.episode.runner import env_config_for
    from fg_tea.model.spec import load_model

    with pytest.raises(InputError, match="detection_miss_rate: has no effect with camera 'visibility'"):
        env_config_for(load_model("factorised"), detection_miss_rate=0.2)
    with pytest.raises(InputError, match="detection_miss_rate: has no effect with camera 'visibility'"):
        env_config_for(load_model("factorised_close"), "visibility", detection_miss_rate=0.2)
    assert env_config_for(load_model("factorised_close"), detection_miss_rate=0.2).detection_miss_rate == 0.2
    assert env_config_for(load_model("factorised"), "threshold",
                          detection_miss_rate=0.2).detection_miss_rate == 0.2
    assert env_config_for(load_model("factorised")).detection_miss_rate == 0.0
