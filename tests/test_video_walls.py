"""The render-only house's walls as one mesh (fg_tea.render.scene.wall_mesh), and the views of
fg_tea.render.scene.SceneViews (walls and furniture painted, objects in windows), give the pixels
of the plain renderer: chase and first-person images of the default episode, compared with a
house drawn as the episode drew it. (The cost is measured by experiments/bench_video.py.)
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fg_tea.env.base import EnvConfig
from fg_tea.env.house import PyBulletHouse
from fg_tea.render.compose import load_plan_scenario
from fg_tea.render.scene import HouseViews, SceneViews, wall_mesh
from fg_tea.render.video import plan_frames
from fg_tea.world.navigation import Box2D
from video_reference import default_episode, default_options, psnr


@pytest.fixture(scope="module")
def default_events(tmp_path_factory):
    return default_episode(tmp_path_factory.mktemp("default"))


def test_a_wall_mesh_has_sides_pieces_tops_and_ends_facing_out():
    """One 2.5 m wall in 1 m pieces: 3 pieces x (2 sides + top) + 2 ends, no bottom; every
    triangle wound counter-clockwise seen along its outward normal."""
    box = Box2D((1.0, 2.0), (1.25, 0.05), (1.0, 0.0))
    vertices, normals, indices = wall_mesh([box], 1.0, 1.0)
    assert len(indices) == 11 * 6  # 11 quads of two triangles
    assert len(vertices) == 4 * 11
    v, n = np.array(vertices), np.array(normals)
    assert v[:, 2].min() == 0.0 and v[:, 2].max() == 1.0
    assert not (n[:, 2] < 0).any()  # no bottom
    for t in np.reshape(indices, (-1, 3)):
        a, b, c = v[t]
        assert np.dot(np.cross(b - a, c - a), n[t[0]]) > 0
    ends = [k for k in range(len(n)) if abs(n[k][0]) == 1.0]
    assert sorted({v[k][0] for k in ends}) == [-0.25, 2.25]  # only the wall's own two ends


@pytest.mark.slow
def test_views_with_a_wall_mesh_give_the_plain_renderers_pixels(default_events):
    """Chase (walls cut away) and first-person images at frames across the episode: at least
    99.9 % of pixels the same as the plain renderer's, PSNR >= 50 dB."""
    options = default_options()
    plan = plan_frames(default_events, options)
    scenario = load_plan_scenario(plan)
    env = {k: v for k, v in plan.env.items() if k in EnvConfig.__dataclass_fields__}
    config = dataclasses.replace(EnvConfig(), **env)
    house = PyBulletHouse(scenario, config)
    house.reset(plan.seed)
    plain = HouseViews(house, options.wall_cutaway)
    cheap = SceneViews(scenario, config, plan.seed, options.wall_cutaway)
    chase = (options.chase_distance, options.chase_height, options.chase_pitch_deg, options.chase_hfov_deg)
    try:
        for index in np.linspace(0, len(plan.frames) - 1, 6).astype(int):
            spec = plan.frames[index]
            for views in (plain, cheap):
                views.set_scene_state(spec.pose, plan.placements[spec.placements], spec.held)
            for a, b in ((plain.chase(640, 360, *chase), cheap.chase(640, 360, *chase)),
                         (plain.ego(216, 162), cheap.ego(216, 162))):
                assert a.shape == b.shape
                assert (a != b).any(axis=2).mean() <= 0.001, index
                assert psnr(a, b) >= 50.0, index
    finally:
        plain.close()
        cheap.close()


def test_a_house_with_a_slanted_wall_is_drawn_by_the_renderer_alone():
    """The painter draws boxes along x and y only: the default house gives its walls (cut to the
    given height) and furniture as boxes; a wall at 45 degrees gives none, and the views are then
    TinyRenderer's (walls one mesh in 1 m pieces), still without a floor body."""
    from fg_tea.render.scene import house_boxes
    from fg_tea.world.navigation import wall_boxes
    from fg_tea.world.scenario import Wall, load_scenario

    scenario = load_scenario("default_apartment")
    boxes = house_boxes(scenario, 1.0)
    assert boxes is not None
    assert len(boxes) == len(wall_boxes(scenario.house)) + len(scenario.house.furniture)
    assert {b.hi[2] for b in boxes[:len(wall_boxes(scenario.house))]} == {1.0}
    slanted = dataclasses.replace(scenario, house=dataclasses.replace(
        scenario.house, walls=scenario.house.walls + (Wall((1.0, 1.0), (2.0, 2.0)),)))
    assert house_boxes(slanted, 1.0) is None
    views = SceneViews(slanted, EnvConfig(), 0, 1.0)
    try:
        assert set(views.painters.values()) == {None} and not views.windows
        views.set_scene_state((1.0, 3.0, 0.0), {}, None)
        image = views.chase(160, 90, 3.2, 2.2, -22.0, 78.0)
        assert image.shape == (90, 160, 3) and views.calls == 1
    finally:
        views.close()
