"""Contract tests for every EnvAdapter (dm_env style mixin): the fake house and the PyBullet house.

Each concrete test class provides an `env` fixture (built once per module) and inherits every
check: reset before use, observation fields, detections only for considered objects, no truth in
results, same seed -> same results, and the shared failure reasons.
"""

from __future__ import annotations

import dataclasses
import math

import pytest

from fg_tea.env.base import EnvConfig
from fg_tea.world.interface import ActionRequest, ActionResult, InspectionResult, Pose, StateReading
from fg_tea.env.fake import FakeHouse
from fg_tea.world.scenario import load_scenario

SCENARIO = load_scenario("default_apartment")
OBJECTS = ("mug", "kettle", "teabag")
TRUTH_WORDS = ("true_site", "hidden_state_truth", "truth", "site_of", "contained_in", "held")


def script(env):
    """A short fixed interaction touching every result type; returns the results in order."""
    return [
        env.inspect_viewpoint("kitchen_counter", ["mug", "kettle"]),
        env.observe_state("kettle", "contains_water", "kitchen_counter", 0.7, 0.7),
        env.execute(ActionRequest("PICK", "mug", "kitchen_counter")),
        env.inspect_viewpoint("sideboard", ["mug", "teabag"]),
        env.execute(ActionRequest("PICK", "mug", "sideboard")),
        env.observe_state("mug", "contains_water", None, 0.7, 0.7),
        env.execute(ActionRequest("PLACE", "mug", "dining_table")),
        env.observe_state("kettle", "kettle.water_hot", None, 0.6, 0.6),
    ]


class EnvContract:
    """Mixin: every adapter must pass these. Subclasses define the `env` fixture."""

    def test_use_before_reset_raises(self, fresh_env):
        with pytest.raises(RuntimeError, match="reset"):
            fresh_env.inspect_viewpoint("kitchen_counter", ["mug"])

    def test_reset_returns_start_pose(self, env):
        pose = env.reset(0)
        assert isinstance(pose, Pose)
        assert (pose.x, pose.y) == SCENARIO.start_position
        assert env.agent_pose() == pose

    def test_inspection_fields(self, env):
        env.reset(0)
        result = env.inspect_viewpoint("sideboard", ["mug", "teabag"])
        assert isinstance(result, InspectionResult)
        assert result.viewpoint == "sideboard" and result.reachable
        assert set(result.detections) == set(result.pixel_counts) == {"mug", "teabag"}
        assert all(isinstance(v, bool) for v in result.detections.values())
        assert all(isinstance(v, int) and v >= 0 for v in result.pixel_counts.values())
        assert result.detections == {"mug": True, "teabag": False}  # scenario truth: mug on sideboard
        assert result.frames == len(result.motion) > 0
        assert result.distance > 0
        assert result.image_size == (env.config.ego_width, env.config.ego_height)
        last = result.motion[-1]
        vx, vy = SCENARIO.site("sideboard").vantage
        assert math.hypot(last[0] - vx, last[1] - vy) < 1e-6  # ends at the vantage point

    def test_detections_only_for_considered_objects(self, env):
        env.reset(0)
        assert env.inspect_viewpoint("kitchen_counter", []).detections == {}
        result = env.inspect_viewpoint("kitchen_counter", ["teabag"])
        assert set(result.detections) == {"teabag"}  # the kettle stands there but was not asked about
        assert set(result.pixel_counts) == {"teabag"}

    def test_unknown_names_are_caller_errors(self, env):
        env.reset(0)
        with pytest.raises(ValueError):
            env.inspect_viewpoint("attic", ["mug"])
        with pytest.raises(ValueError):
            env.inspect_viewpoint("kitchen_counter", ["spoon"])
        with pytest.raises(ValueError):
            env.execute(ActionRequest("SEARCH", "mug"))

    def test_no_truth_leaks(self, env):
        env.reset(0)
        for result in script(env):
            names = {f.name for f in dataclasses.fields(result)}
            assert not names & set(TRUTH_WORDS)
            assert "true_site" not in repr(result) and "hidden_state" not in repr(result)
        assert not any(hasattr(env, name) for name in ("true_site", "truth", "hidden_state_truth"))

    def test_same_seed_same_results(self, env):
        env.reset(11)
        first = script(env)
        env.reset(11)
        assert script(env) == first

    def test_state_reading_follows_sensor_model(self, env):
        env.reset(0)
        exact = env.observe_state("kettle", "contains_water", None, 1.0, 1.0)
        assert isinstance(exact, StateReading) and exact.state == "kettle.contains_water"
        assert exact.value is False  # truth: the default kettle is empty
        assert env.observe_state("kettle", "contains_water", None, 1.0, 0.0).value is True  # beta = 0 lies

    def test_failures_are_reported_not_raised(self, env):
        env.reset(0)
        wrong = env.execute(ActionRequest("PICK", "mug", "kitchen_counter"))
        assert isinstance(wrong, ActionResult) and not wrong.ok and wrong.reason == "object_not_at_site"
        assert env.execute(ActionRequest("PLACE", "mug", "dining_table")).reason == "not_held"
        assert env.execute(ActionRequest("POUR", "kettle", None, destination="mug")).reason == "not_held"
        assert env.execute(ActionRequest("PICK", "mug", "sideboard")).ok
        assert env.execute(ActionRequest("PICK", "kettle", "kitchen_counter")).reason == "hands_full"
        placed = env.execute(ActionRequest("PLACE", "mug", "dining_table"))
        assert placed.ok and placed.placements["mug"][:2] == pytest.approx(SCENARIO.site("dining_table").position[:2])

    def test_distance_to_site(self, env):
        env.reset(0)
        d = env.distance_to_site("kitchen_counter")
        sx, sy = SCENARIO.start_position
        vx, vy = SCENARIO.site("kitchen_counter").vantage
        assert d >= math.hypot(vx - sx, vy - sy) - 1e-9
        env.inspect_viewpoint("kitchen_counter", [])
        assert env.distance_to_site("kitchen_counter") == pytest.approx(0.0, abs=1e-9)


@pytest.fixture(scope="module")
def fake_house():
    return FakeHouse(SCENARIO)


class TestFakeHouse(EnvContract):
    @pytest.fixture
    def env(self, fake_house):
        return fake_house

    @pytest.fixture
    def fresh_env(self):
        return FakeHouse(SCENARIO)


@pytest.fixture(scope="module")
def pybullet_house():
    from fg_tea.env.house import PyBulletHouse

    house = PyBulletHouse(SCENARIO, EnvConfig(ego_width=160, ego_height=120))
    yield house
    house.close()


class TestPyBulletHouse(EnvContract):
    @pytest.fixture
    def env(self, pybullet_house):
        return pybullet_house

    def test_use_before_reset_raises(self):  # its own instance: the shared one is already reset
        from fg_tea.env.house import PyBulletHouse

        house = PyBulletHouse(SCENARIO)
        try:
            with pytest.raises(RuntimeError, match="reset"):
                house.inspect_viewpoint("kitchen_counter", ["mug"])
        finally:
            house.close()


def test_fake_and_pybullet_agree_at_the_interface(pybullet_house):
    """Same script, same seed: same detections, readings, reasons and final placements."""
    fake = FakeHouse(SCENARIO, pybullet_house.config)
    fake.reset(5)
    pybullet_house.reset(5)
    for a, b in zip(script(fake), script(pybullet_house)):
        assert type(a) is type(b)
        if isinstance(a, InspectionResult):
            assert a.detections == b.detections and a.reachable == b.reachable
        elif isinstance(a, StateReading):
            assert a.value == b.value and a.state == b.state
        else:
            assert (a.ok, a.reason) == (b.ok, b.reason)
            assert set(a.placements) == set(b.placements)
    assert fake.placements() == pybullet_house.placements()
