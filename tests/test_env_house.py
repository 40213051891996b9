"""What the PyBullet house must show (docs/design.md §8): scene, navigation, perception, truth, determinism."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fg_tea.env.base import EnvConfig
from fg_tea.env.house import PyBulletHouse
from fg_tea.world.navigation import Navigator
from fg_tea.env.motion import follow_path, turn_frames
from fg_tea.world.interface import ActionRequest, Pose
from fg_tea.common.errors import InputError
from fg_tea.common.resources import bundled, resolve_scenario
from fg_tea.world.scenario import load_scenario, parse_scenario

SCENARIO = load_scenario("default_apartment")
OBJECTS = ("mug", "kettle", "teabag")


@pytest.fixture(scope="module")
def house():
    h = PyBulletHouse(SCENARIO)
    h.reset(0)
    yield h
    h.close()


@pytest.mark.parametrize("path", bundled("scenarios", ".json"), ids=lambda p: p.stem)
def test_every_bundled_scenario_builds(path):
    scenario = load_scenario(path)
    h = PyBulletHouse(scenario)
    try:
        pose = h.reset(1)
        assert (pose.x, pose.y) == scenario.start_position
        assert set(h.placements()) == set(scenario.object_names)
        for site in scenario.sites:  # every vantage reachable from the start
            assert math.isfinite(h.distance_to_site(site.name))
    finally:
        h.close()


def test_paths_never_cross_a_blocked_cell(house):
    nav = house.navigator
    grid = nav.grid
    points = [tuple(SCENARIO.start_position)] + nav.vantages
    step = grid.resolution / 10
    for a in points:
        for k in range(len(SCENARIO.sites)):
            corners = nav.path(k, a)
            assert corners is not None and corners[0] == a and corners[-1] == nav.vantages[k]
            for p, q in zip(corners, corners[1:]):
                n = max(2, int(math.hypot(q[0] - p[0], q[1] - p[1]) / step) + 2)
                for t in np.linspace(0.0, 1.0, n):
                    x, y = p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])
                    r, c = grid.cell((x, y))
                    assert grid.free[r, c] and not grid.blocked[r, c], (a, k, (x, y))


def test_followed_motion_stays_on_free_cells(house):
    frames = follow_path(Pose(*SCENARIO.start_position, 180.0), house.navigator.path(1, SCENARIO.start_position),
                         house.config)
    assert all(house.navigator.grid.is_free((f.x, f.y)) for f in frames)
    steps = [math.hypot(b.x - a.x, b.y - a.y) for a, b in zip(frames, frames[1:])]
    assert max(steps) <= house.config.movement_step + 1e-12
    turns = [abs((b.yaw_deg - a.yaw_deg + 180) % 360 - 180) for a, b in zip(frames, frames[1:])]
    assert max(turns) <= house.config.turn_step_deg + 1e-9
    moved_while_turning_hard = [
        b for a, b, t in zip(frames, frames[1:], turns) if t > 0 and (a.x, a.y) != (b.x, b.y)
        and abs((math.degrees(math.atan2(b.y - a.y, b.x - a.x)) - a.yaw_deg + 180) % 360 - 180)
        > house.config.turn_before_move_deg]
    assert not moved_while_turning_hard


def test_turn_frames_reach_tolerance():
    cfg = EnvConfig()
    frames = turn_frames(Pose(0, 0, 170.0), -170.0, cfg)  # 20 deg the short way, across +-180
    assert len(frames) == 7  # ceil((20 - 2.5) / 2.5) = 7 steps to within 2.5 deg
    assert abs((frames[-1].yaw_deg + 170.0 + 180) % 360 - 180) <= cfg.face_tolerance_deg


def test_geodesic_at_least_euclidean(house):
    nav = house.navigator
    longer = 0
    for i, a in enumerate(nav.vantages):
        for k, b in enumerate(nav.vantages):
            d = nav.distance(k, a)
            e = math.hypot(b[0] - a[0], b[1] - a[1])
            assert d >= e - 1e-9
            longer += d > e + 0.5
    assert longer > 0  # walls make some detours real (pantry -> study goes through doorways)


def test_euclidean_ablation():
    h = PyBulletHouse(SCENARIO, EnvConfig(distance="euclidean"))
    try:
        h.reset(0)
        sx, sy = SCENARIO.start_position
        for site in SCENARIO.sites:
            assert h.distance_to_site(site.name) == pytest.approx(math.hypot(site.vantage[0] - sx,
                                                                             site.vantage[1] - sy))
    finally:
        h.close()


@pytest.mark.parametrize("obj", OBJECTS)
def test_object_on_each_site_is_detected_from_its_vantage(house, obj):
    house.reset(0)
    for site in SCENARIO.sites:
        house.move_object(obj, site.name)
        result = house.inspect_viewpoint(site.name, [obj])
        assert result.detections[obj], (obj, site.name, result.pixel_counts)
        assert result.pixel_counts[obj] >= 25


def test_object_on_neighbouring_site_is_not_assigned(house):
    house.reset(0)
    seen_but_rejected = 0
    for site in SCENARIO.sites:
        others = [s for s in SCENARIO.sites if s.name != site.name]
        neighbour = min(others, key=lambda s: math.dist(s.position[:2], site.position[:2]))
        for obj in OBJECTS:
            house.move_object(obj, neighbour.name)
        result = house.inspect_viewpoint(site.name, list(OBJECTS))
        assert not any(result.detections.values()), (site.name, neighbour.name, result.pixel_counts)
        seen_but_rejected += any(n >= 25 for n in result.pixel_counts.values())
    assert seen_but_rejected > 0  # the spatial association check [29] did real work


def test_occluded_object_is_not_detected(house):
    house.reset(0)
    site = SCENARIO.site("kitchen_counter")
    house.move_object("teabag", site.name)
    house.move_object("kettle", "coffee_table")
    assert house.inspect_viewpoint(site.name, ["teabag"]).detections["teabag"]
    # a board standing on the counter between the camera and the teabag
    px, py, pz = site.position
    vx, vy = site.vantage
    d = math.hypot(px - vx, py - vy)
    ux, uy = (vx - px) / d, (vy - py) / d
    house.add_obstacle((px + 0.2 * ux, py + 0.2 * uy, pz + 0.15), (0.5, 0.03, 0.3))
    hidden = house.inspect_viewpoint(site.name, ["teabag"])
    assert not hidden.detections["teabag"] and hidden.pixel_counts["teabag"] < 25
    house.reset(0)  # obstacles go away with a reset
    house.move_object("teabag", site.name)
    assert house.inspect_viewpoint(site.name, ["teabag"]).detections["teabag"]


def test_roi_counts_equal_full_image_counts(house):
    house.reset(0)
    try:
        for site in SCENARIO.sites:
            for obj in OBJECTS:
                house.move_object(obj, site.name)
            house.inspect_viewpoint(site.name, [])
            house.roi = True
            roi = house._pixel_counts(0, OBJECTS)
            house.roi = False
            assert house._pixel_counts(0, OBJECTS) == roi
    finally:
        house.roi = True


def _ahead_of_camera(house, forward_m, up_m):
    """A point `forward_m` along the egocentric camera's heading and `up_m` above the lens (m)."""
    from fg_tea.env import assets

    yaw = math.radians(house._pose.yaw_deg)
    forward = assets.CAMERA_FORWARD_M + forward_m
    return (house._pose.x + forward * math.cos(yaw), house._pose.y + forward * math.sin(yaw),
            house.config.sensor_height + up_m)


@pytest.mark.parametrize("case", ["behind", "straddling"])
def test_roi_counts_equal_full_image_counts_with_objects_behind_the_camera(house, case):
    """Bodies wholly behind the camera are left out of the window; one across it is still counted."""
    site = SCENARIO.sites[0].name
    house.reset(0)
    try:
        house.move_object("mug", site)
        house.inspect_viewpoint(site, [])  # stand at the close vantage, facing the site
        if case == "behind":  # wholly behind the lens: no pixels, and no reason to render it all
            house._positions["kettle"] = _ahead_of_camera(house, -0.6, -0.1)
            house._positions["teabag"] = _ahead_of_camera(house, -1.5, -0.3)
        else:  # its box reaches from behind the camera to in front of the near plane
            house._positions["kettle"] = _ahead_of_camera(house, 0.0, -0.05)
        house.roi = True
        roi = house._pixel_counts(0, OBJECTS)
        w, h = house.config.ego_width, house.config.ego_height
        view, proj = house._ego_camera(w, h)
        window = house._window(view, proj, w, h, [(house._bodies[o], house._bounds[o]) for o in OBJECTS])
        house.roi = False
        assert house._pixel_counts(0, OBJECTS) == roi
        assert roi["mug"] > 0
        if case == "behind":
            assert roi["kettle"] == roi["teabag"] == 0
            assert window != (0, 0, w, h)  # the window is the mug's, not the whole image
        else:
            assert roi["kettle"] > 0 and window == (0, 0, w, h)
    finally:
        house.roi = True
        house.reset(0)


def test_drone_and_held_object_stay_out_of_the_egocentric_view(house):
    house.reset(0)
    assert house.execute(ActionRequest("PICK", "mug", "sideboard")).ok
    house.inspect_viewpoint("dining_table", [])
    w, h = house.config.ego_width, house.config.ego_height
    seg = house._render(house._ego_camera(w, h), w, h, segmentation=True)[2]
    assert house._drone not in seg and house._bodies["mug"] not in seg
    rgb, depth, semantic = house.render_ego(w, h)
    assert rgb.shape == (h, w, 3) and rgb.dtype == np.uint8
    assert depth.dtype == np.float32 and np.all(depth > 0)
    assert set(np.unique(semantic)) <= {0} | {o.semantic_id for o in SCENARIO.objects}
    chase = house.render_chase(160, 90)
    assert chase.shape == (90, 160, 3) and chase.std() > 5  # a real picture, not a blank


def test_same_seed_same_readings_paths_and_pixels(house):
    def run(seed):
        house.reset(seed)
        out = [house.inspect_viewpoint(s.name, list(OBJECTS)) for s in SCENARIO.sites[:4]]
        out += [house.observe_state("kettle", "contains_water", None, 0.6, 0.6).value for _ in range(30)]
        return out

    first = run(3)
    assert run(3) == first
    readings = first[4:]
    assert run(4)[4:] != readings  # a different seed really changes the noisy readings


def test_failure_injection_reports_failure():
    h = PyBulletHouse(SCENARIO, EnvConfig(failure_rates={"PICK": 1.0, "FILL": 0.5}))
    try:
        h.reset(0)
        result = h.execute(ActionRequest("PICK", "mug", "sideboard"))
        assert not result.ok and result.reason == "injected_failure"
        assert h.execute(ActionRequest("PLACE", "mug", "dining_table")).reason == "not_held"  # no effect
        fills = [h.execute(ActionRequest("FILL", "kettle", "kitchen_counter")).ok for _ in range(40)]
        assert 0 < sum(fills) < 40
    finally:
        h.close()


def _scenario_with_vantage(index, vantage):
    data = json.loads(resolve_scenario("default_apartment").read_text())
    data["sites"][index]["vantage_position"] = [*vantage, 0.0]
    return parse_scenario(data, "bad_vantage.json")


def test_vantage_inside_a_wall_is_an_input_error():
    scenario = _scenario_with_vantage(1, (4.0, 2.8))  # on the wall x = 4
    with pytest.raises(InputError) as err:
        PyBulletHouse(scenario)
    assert err.value.file == "bad_vantage.json"
    assert err.value.path == "$.sites[1].vantage_position"
    assert "pantry_shelf" in err.value.fault and "nearest free cell at (" in err.value.fault
    near = err.value.fault.split("nearest free cell at (")[1].rstrip(")").split(", ")
    assert Navigator(SCENARIO, EnvConfig()).grid.is_free((float(near[0]), float(near[1])))


def test_vantage_beside_furniture_within_agent_radius_is_an_input_error():
    scenario = _scenario_with_vantage(0, (2.0, 0.75))  # 0.10 m from the counter, radius 0.22 m
    with pytest.raises(InputError, match="kitchen_counter"):
        Navigator(scenario, EnvConfig())
