"""Floor plan: every site, vantage and room vantage is drawn and labelled, legibly, at 48 sites."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from fg_tea.render.floorplan import MiniMap, draw_floor_plan, write_floor_plan
from fg_tea.world.scenario import (Doorway, Furniture, House, ObjectSpec, RoomVantage, Scenario,
    Site, Wall, load_scenario)


def grid_house(rows: int = 3, cols: int = 4, per_room: int = 4, room_w: float = 5.0,
               room_h: float = 4.0) -> Scenario:
    """A rows x cols grid of rooms, `per_room` sites on furniture along each room's walls, doorways
    between neighbours and one room vantage per room (48 sites at the defaults)."""
    W, H = cols * room_w, rows * room_h
    walls = [Wall((0, 0), (W, 0)), Wall((W, 0), (W, H)), Wall((W, H), (0, H)), Wall((0, H), (0, 0))]
    for c in range(1, cols):
        walls.append(Wall((c * room_w, 0), (c * room_w, H),
                          tuple(Doorway((r + 0.5) * room_h, 1.0) for r in range(rows))))
    for r in range(1, rows):
        walls.append(Wall((0, r * room_h), (W, r * room_h),
                          tuple(Doorway((c + 0.5) * room_w, 1.0) for c in range(cols))))
    furniture, sites, vantages = [], [], []
    spots = [((0.3, 0.5), (0.3, 1.2)), ((0.7, 0.5), (0.7, 1.2)), ((0.3, 3.5), (0.3, 2.8)),
             ((0.7, 3.5), (0.7, 2.8))]
    for r in range(rows):
        for c in range(cols):
            room = f"room_{r}_{c}"
            x0, y0 = c * room_w, r * room_h
            for k in range(per_room):
                (fx, fy), (vx, vy) = spots[k % len(spots)]
                cx, cy = x0 + fx * room_w, y0 + fy * (room_h / 4.0)
                name = f"{room}_surface_{k}"
                furniture.append(Furniture(name, (cx, cy), (1.0, 0.6, 0.8)))
                sites.append(Site(name, room, (cx, cy, 0.8), (x0 + vx * room_w, y0 + vy * (room_h / 4.0)),
                                  {"mug": 1.0, "kettle": 1.0, "teabag": 1.0}, None, name))
            vantages.append(RoomVantage(f"{room}_centre", room, (x0 + room_w / 2, y0 + room_h / 2)))
    house = House((0, 0), (W, H), 2.4, 0.1, tuple(walls), tuple(furniture))
    objects = tuple(ObjectSpec(n, n, sites[i * 7].name, i + 1, frozenset(), n, {}, {})
                    for i, n in enumerate(("mug", "kettle", "teabag")))
    return Scenario("grid_48", 2, "synthetic", tuple(sites), objects, house, (room_w / 2, room_h / 2),
                    0.0, sites[0].name, room_vantages=tuple(vantages))


def _area_overlap(a, b) -> int:
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    return max(w, 0) * max(h, 0)


@pytest.mark.parametrize("scenario", [load_scenario("default_apartment"), grid_house()],
                         ids=["default_apartment", "grid_48"])
@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_floor_plan_labels_every_site_and_vantage(scenario, tmp_path):
    out = tmp_path / "plan.png"
    plan = write_floor_plan(scenario, out)
    assert out.stat().st_size > 10_000
    image = cv2.imread(str(out))
    assert image.shape == plan.image.shape
    assert len(np.unique(image.reshape(-1, 3), axis=0)) > 50  # not a blank canvas
    h, w = plan.image.shape[:2]
    assert set(plan.site_labels) == set(scenario.site_names)
    assert set(plan.vantage_labels) == set(scenario.site_names)
    assert set(plan.room_vantage_labels) == {v.name for v in scenario.room_vantages}
    assert set(plan.room_labels) == set(scenario.rooms)
    assert set(plan.truth_labels) == set(scenario.object_names)
    labels = [*plan.site_labels.values(), *plan.vantage_labels.values(), *plan.room_vantage_labels.values(),
              *plan.room_labels.values(), *plan.truth_labels.values()]
    for x0, y0, x1, y1 in labels:
        assert 0 <= x0 < x1 <= w and 0 <= y0 < y1 <= h  # on the image
    # No label overlaps another (measured: none does in either house; a few px^2 are tolerated).
    worst = max(_area_overlap(a, b) for i, a in enumerate(labels) for b in labels[i + 1:])
    assert worst < 40


def test_floor_plan_scales_with_the_floor():
    small = draw_floor_plan(load_scenario("default_apartment")).image
    big = draw_floor_plan(grid_house()).image
    assert big.shape[1] > 1.5 * small.shape[1]
    assert draw_floor_plan(grid_house(), px_per_m=20).image.shape[1] < big.shape[1]


def test_truth_marks_are_optional():
    scenario = load_scenario("default_apartment")
    with_truth = draw_floor_plan(scenario)
    without = draw_floor_plan(scenario, show_truth=False)
    assert with_truth.truth_labels and not without.truth_labels
    red = np.array([205, 30, 60])
    count = lambda img: int(np.all(np.abs(img.astype(int) - red) < 30, axis=2).sum())
    assert count(with_truth.image) > 100 and count(without.image) == 0


def test_minimap_shows_a_room_glance_differently_from_a_close_look():
    scenario = grid_house()
    minimap = MiniMap(scenario)
    room = scenario.room_vantages[5]
    in_room = [s.name for s in scenario.sites if s.room == room.room]
    pose = (*room.position, 90.0)
    bare = minimap.render(160, 96, pose)
    close = minimap.render(160, 96, pose, in_room[0], "site", [in_room[0]])
    glance = minimap.render(160, 96, pose, room.name, "room", in_room)
    assert not np.array_equal(bare, close) and not np.array_equal(close, glance)
    cyan = np.all(np.abs(glance.astype(int) - np.array([60, 220, 255])) < 40, axis=2).sum()
    assert cyan > 4 * np.all(np.abs(close.astype(int) - np.array([60, 220, 255])) < 40, axis=2).sum() + 10
    # The field-of-view wedge turns with the agent.
    assert not np.array_equal(minimap.render(160, 96, (*room.position, 0.0)), bare)


def test_preview_writes_the_camera_view_and_the_floor_plan(tmp_path, capsys):
    from fg_tea.cli import main

    out = tmp_path / "house.png"
    assert main(["preview", "--out", str(out), "--width", "192", "--height", "108"]) == 0
    plan = tmp_path / "house_plan.png"
    assert cv2.imread(str(out)).shape == (108, 192, 3)
    assert cv2.imread(str(plan)).shape == draw_floor_plan(load_scenario("default_apartment")).image.shape
    assert str(plan) in capsys.readouterr().out
