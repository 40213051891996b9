"""Walls and furniture painted without the renderer (fg_tea.render.boxes) show TinyRenderer's
pixels, and the windows where the renderer still draws objects hold every pixel of them
(fg_tea.render.scene.body_window). The cost is measured by experiments/bench_video.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fg_tea.env.house import LIGHT_COEFFS, LIGHT_DIRECTION, _corners, sub_projection
from fg_tea.env.pybullet_quiet import pybullet
from fg_tea.env import assets
from fg_tea.render.boxes import Box, BoxPainter, disjoint
from fg_tea.render.windows import body_window


def _tiny(client: int, view, proj, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """TinyRenderer's RGB and depth buffer, lit as the house's cameras are."""
    _, _, rgba, depth, _ = pybullet.getCameraImage(
        width, height, viewMatrix=view, projectionMatrix=proj, renderer=pybullet.ER_TINY_RENDERER,
        lightDirection=list(LIGHT_DIRECTION), shadow=0, lightAmbientCoeff=LIGHT_COEFFS[0],
        lightDiffuseCoeff=LIGHT_COEFFS[1], lightSpecularCoeff=LIGHT_COEFFS[2],
        flags=pybullet.ER_NO_SEGMENTATION_MASK, physicsClientId=client)
    rgb = np.reshape(np.asarray(rgba, np.uint8), (height, width, 4))[:, :, :3]
    return rgb, np.reshape(np.asarray(depth, np.float32), (height, width))


@pytest.fixture()
def client():
    c = pybullet.connect(pybullet.DIRECT)
    yield c
    pybullet.disconnect(c)


def _shader(client: int):
    def shade(rgba, normal):
        centre = np.array([500.0, 500.0, 500.0])
        body = assets.box(client, tuple(centre), (0.5, 0.5, 0.5), rgba)
        eye = centre + 3.0 * np.asarray(normal)
        up = [0.0, 0.0, 1.0] if abs(normal[2]) < 0.5 else [1.0, 0.0, 0.0]
        view = pybullet.computeViewMatrix(list(eye), list(centre), up)
        rgb, _ = _tiny(client, view, pybullet.computeProjectionMatrixFOV(20.0, 1.0, 0.03, 30.0), 16, 16)
        pybullet.removeBody(body, physicsClientId=client)
        return rgb[8, 8].copy()
    return shade


def _room(rng) -> list[Box]:
    """Walls of a room with an opening and crossing inner walls (they overlap at corners), and
    furniture of several colours, some of it touching or overlapping the walls."""
    wall = (0.97, 0.94, 0.86, 1.0)
    boxes = [Box((0, 0, 0), (6, 0.1, 1.0), wall), Box((0, 0, 0), (0.1, 5, 1.0), wall),
             Box((5.9, 0, 0), (6, 5, 1.0), wall), Box((0, 4.9, 0), (2.5, 5, 1.0), wall),
             Box((3.5, 4.9, 0), (6, 5, 1.0), wall), Box((2.95, 0, 0), (3.05, 3.2, 1.0), wall),
             Box((1.0, 2.0, 0), (5.0, 2.1, 1.0), wall)]
    for _ in range(7):
        x, y = rng.uniform(0.0, 5.5), rng.uniform(0.0, 4.5)
        sx, sy, sz = rng.uniform(0.3, 1.4), rng.uniform(0.3, 1.0), rng.uniform(0.3, 1.1)
        boxes.append(Box((x, y, 0.0), (x + sx, y + sy, sz), (*rng.uniform(0.2, 0.9, 3), 1.0)))
    return boxes


def _add(client: int, boxes: list[Box]) -> None:
    for b in boxes:
        lo, hi = np.array(b.lo), np.array(b.hi)
        assets.box(client, tuple((lo + hi) / 2), tuple((hi - lo) / 2), b.rgba)


def _cameras(rng, count: int):
    """Chase-like cameras above the room, and low ones inside it close to walls (the near plane
    cuts faces that reach behind them)."""
    for k in range(count):
        eye = np.array([rng.uniform(-1.0, 7.0), rng.uniform(-1.0, 6.0), rng.uniform(1.5, 3.0)])
        if k % 2:
            eye = np.array([rng.uniform(0.3, 5.7), rng.uniform(0.3, 4.7), rng.uniform(0.3, 1.6)])
        yaw, pitch = rng.uniform(0, 2 * math.pi), rng.uniform(-0.8, -0.05)
        if k % 5 == 0:
            yaw = round(yaw / (math.pi / 2)) * (math.pi / 2)  # along an axis: edges through pixels exactly
        target = eye + [math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), math.sin(pitch)]
        yield pybullet.computeViewMatrix(list(eye), list(target), [0, 0, 1])


def test_disjoint_boxes_fill_the_same_space_and_do_not_overlap():
    rng = np.random.default_rng(3)
    boxes = _room(rng)
    pieces = disjoint(boxes)
    points = rng.uniform([-0.5, -0.5, -0.1], [6.5, 5.5, 1.2], size=(20000, 3))

    def inside(bs):
        return np.array([[all(b.lo[k] < p[k] < b.hi[k] for k in range(3)) for b in bs] for p in points])

    before, after = inside(boxes), inside(pieces)
    np.testing.assert_array_equal(before.any(axis=1), after.any(axis=1))
    assert after.sum(axis=1).max() == 1  # no point in two pieces
    assert before.sum(axis=1).max() > 1  # the room's boxes did overlap


@pytest.mark.parametrize("size", [(320, 180), (216, 162)])
def test_painted_boxes_show_the_renderers_pixels(client, size):
    """Random rooms and cameras (from above, from inside near walls, along the axes): the face
    each pixel shows and its colour are TinyRenderer's on all but a few pixels in 10 000."""
    width, height = size
    rng = np.random.default_rng(11)
    boxes = _room(rng)
    _add(client, boxes)
    painter = BoxPainter(boxes, _shader(client))
    differ = total = 0
    for view in _cameras(rng, 12):
        proj = pybullet.computeProjectionMatrixFOV(60.0, width / height, 0.03, 30.0)
        rgb, depth = _tiny(client, view, proj, width, height)
        ids, colours = painter.paint(view, proj, width, height)
        painted = np.take(colours, ids, axis=0)
        np.testing.assert_array_equal(rgb[depth >= 1.0], 255)  # the renderer's empty pixels are white
        differ += int((painted != rgb).any(axis=2).sum())
        total += width * height
    assert differ <= total * 2e-4, (differ, total)


def test_a_box_behind_a_long_wall_is_painted_before_it(client):
    """The order matters: a tall box behind a long wall, seen over it, is hidden where the wall
    is in front; the wall's centre is farther from the camera than the box's, so painting by
    distance to the centres would draw the whole box over the wall."""
    wall = Box((0.0, 2.0, 0.0), (8.0, 2.1, 1.0), (0.97, 0.94, 0.86, 1.0))
    tall = Box((0.3, 2.6, 0.0), (0.7, 3.0, 1.3), (0.3, 0.3, 0.8, 1.0))
    _add(client, [wall, tall])
    shade = _shader(client)
    view = pybullet.computeViewMatrix([0.5, -1.5, 1.2], [0.5, 2.0, 0.7], [0, 0, 1])
    proj = pybullet.computeProjectionMatrixFOV(60.0, 1.0, 0.03, 30.0)
    rgb, _ = _tiny(client, view, proj, 96, 96)
    ids, colours = BoxPainter([wall, tall], shade).paint(view, proj, 96, 96)
    alone, _ = BoxPainter([tall], shade).paint(view, proj, 96, 96)
    painted = np.take(colours, ids, axis=0)
    assert (painted != rgb).any(axis=2).sum() <= 2
    blue = painted[:, :, 2].astype(int) > painted[:, :, 0].astype(int) + 40
    assert 0 < blue.sum() < (alone > 0).sum()  # partly seen over the wall, partly hidden by it


def test_a_body_window_holds_every_pixel_of_the_body(client):
    """The renderer's pixels of an object, alone, lie inside its window: in view, partly behind
    the camera (the near plane cuts it), and wholly behind (no window)."""
    parts = assets.kettle_parts()
    body = assets.create_compound(client, parts)
    bounds = _corners(parts)
    width, height = 160, 120
    proj = pybullet.computeProjectionMatrixFOV(70.0, width / height, 0.03, 30.0)
    for eye, target, expect_window in (([0.0, -1.0, 0.6], [0.0, 0.0, 0.1], True),
                                       ([0.0, -0.03, 0.12], [0.0, 1.0, 0.0], True),
                                       ([0.05, 0.0, 0.2], [0.5, 1.0, -0.5], True),
                                       ([0.0, 0.5, 0.1], [0.0, 3.0, 0.1], False)):
        view = pybullet.computeViewMatrix(eye, target, [0, 0, 1])
        clip = np.reshape(proj, (4, 4)).T @ np.reshape(view, (4, 4)).T @ bounds
        window = body_window(clip, width, height)
        _, depth = _tiny(client, view, proj, width, height)
        drawn = depth < 1.0
        if not expect_window:
            assert window is None and not drawn.any()
            continue
        assert window is not None and drawn.any()
        c0, r0, c1, r1 = window
        outside = drawn.copy()
        outside[r0:r1, c0:c1] = False
        assert not outside.any()
        # and the window, rendered alone, gives the whole image's pixels there
        part, _ = _tiny(client, view, sub_projection(proj, width, height, window), c1 - c0, r1 - r0)
        whole, _ = _tiny(client, view, proj, width, height)
        assert (part != whole[r0:r1, c0:c1]).any(axis=2).sum() <= 2


def test_body_windows_lay_each_body_where_its_scene_is_nearest(client):
    """Two objects whose windows overlap, one partly in front of the other, and a wall hiding
    part of one: drawn each in a scene of its own (with the wall) and laid nearest first, the
    image is one rendering of the whole scene, but for a few pixels on edges."""
    from fg_tea.render.windows import BodyWindows

    wall = Box((0.06, 0.6, 0.0), (1.0, 0.7, 0.35), (0.97, 0.94, 0.86, 1.0))  # hides the kettle's right side

    def statics(c: int) -> None:
        _add(c, [wall])

    statics(client)
    kinds = (assets.mug_parts(), assets.kettle_parts())  # the nearer first: its window is laid first
    bodies, places = [], ([0.0, 0.3, 0.0], [0.0, 0.9, 0.0])
    for parts, place in zip(kinds, places):
        body = assets.create_compound(client, parts)
        pybullet.resetBasePositionAndOrientation(body, place, [0, 0, 0, 1], physicsClientId=client)
        bodies.append((body, _corners(parts), lambda c, parts=parts: assets.create_compound(c, parts)))
    windows = BodyWindows(client, bodies, statics)
    try:
        width, height = 160, 120
        view = pybullet.computeViewMatrix([0.0, -0.5, 0.08], [0.0, 0.9, 0.08], [0, 0, 1])  # the mug before the kettle
        proj = pybullet.computeProjectionMatrixFOV(60.0, width / height, 0.03, 30.0)
        whole, depth = _tiny(client, view, proj, width, height)
        painted = BoxPainter([wall], _shader(client))
        ids, colours = painted.paint(view, proj, width, height)
        rgb = np.take(colours, ids, axis=0)
        empty = ids == 0
        windows.draw(rgb, empty, (view, proj))
        assert windows.calls == 2
        assert (rgb != whole).any(axis=2).sum() <= 3
        np.testing.assert_array_equal(empty, depth >= 1.0)
    finally:
        windows.close()
