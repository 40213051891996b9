"""The objects and the drone of the video's views, drawn by TinyRenderer in small windows.

With the walls and furniture painted (:mod:`fg_tea.render.boxes`), TinyRenderer draws only what
the objects and the drone cover: each in the window of the image its bounds can reach
(:func:`body_window`). A TinyRenderer call transforms every triangle of the scene it is given
before it draws a pixel (about 0.6 ms for a window of the house's render-only copy:
experiments/results/video/tinyrenderer.md), so :class:`BodyWindows` keeps, for each body, a
scene of its own: the walls and furniture (which hide it as in a whole image) and that one body,
placed where the render-only copy has it. The windows' images are then laid over the painted
image nearest first: a pixel takes the image of the body whose scene is nearest there. Each of
those scenes holds all the walls and furniture, so where two windows overlap the nearer body, or
the wall in front of both, wins, as in one rendering of the whole scene.
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np

from fg_tea.env.house import LIGHT_COEFFS, LIGHT_DIRECTION, sub_projection
from fg_tea.env.pybullet_quiet import pybullet

#: The edges of a box's corners as :func:`fg_tea.env.house._corners` orders them (x, then y, then z).
_EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]


def body_window(clip: np.ndarray, width: int, height: int) -> tuple[int, int, int, int] | None:
    """The pixel window (col0, row0, col1, row1) that can show what lies in a box, given its 8
    corners in clip space (4, 8): the box clipped against the near plane (z > -w, where the
    renderer clips triangles), projected, and 2 pixels more on every side; None if nothing of
    it is in front of the near plane or in the image."""
    front = clip[2] + clip[3]  # > 0 in front of the near plane
    inside = (front > 0) & (clip[3] > 0)
    if not inside.any():
        return None
    points = [clip[:, inside]]
    for a, b in _EDGES:
        if inside[a] != inside[b]:
            t = front[a] / (front[a] - front[b])
            points.append((clip[:, a] + t * (clip[:, b] - clip[:, a]))[:, None])
    pts = np.concatenate(points, axis=1)
    w = np.maximum(pts[3], 1e-12)
    xs, ys = (pts[0] / w + 1) * (width / 2), (pts[1] / w + 1) * (height / 2)
    c0, c1 = max(0, math.floor(xs.min()) - 2), min(width, math.ceil(xs.max()) + 3)
    r0, r1 = max(0, height - 1 - math.ceil(ys.max()) - 2), min(height, height - math.floor(ys.min()) + 2)
    if c1 <= c0 or r1 <= r0:
        return None
    return (c0, r0, c1, r1)


def tiny_render(client: int, camera: tuple[Sequence[float], Sequence[float]], width: int, height: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """TinyRenderer's RGB (a view of its RGBA) and depth buffer, lit as
    :meth:`fg_tea.env.house.PyBulletHouse._render` lights the house's cameras."""
    view, proj = camera
    _, _, rgba, depth, _ = pybullet.getCameraImage(
        width, height, viewMatrix=view, projectionMatrix=proj, renderer=pybullet.ER_TINY_RENDERER,
        lightDirection=list(LIGHT_DIRECTION), shadow=0, lightAmbientCoeff=LIGHT_COEFFS[0],
        lightDiffuseCoeff=LIGHT_COEFFS[1], lightSpecularCoeff=LIGHT_COEFFS[2],
        flags=pybullet.ER_NO_SEGMENTATION_MASK, physicsClientId=client)
    rgb = np.reshape(np.asarray(rgba, dtype=np.uint8), (height, width, 4))[:, :, :3]
    return rgb, np.reshape(np.asarray(depth, dtype=np.float32), (height, width))


class BodyWindows:
    """Bodies of a render-only copy drawn in windows, each in a scene of its own.

    Args:
        client: the render-only copy's pybullet client (where the bodies are placed).
        bodies: (body in the copy, its local bounds (4, 8), a function that creates the same
            body in a given client and returns its id).
        statics: creates the walls and furniture in a given client, as the copy has them.
    """

    def __init__(self, client: int, bodies: Sequence[tuple[int, np.ndarray, Callable[[int], int]]],
                 statics: Callable[[int], None]) -> None:
        self.client = client
        self.scenes: list[tuple[int, np.ndarray, int, int]] = []  # body, bounds, its scene, its twin there
        for body, bounds, create in bodies:
            scene = pybullet.connect(pybullet.DIRECT)
            statics(scene)
            self.scenes.append((body, bounds, scene, create(scene)))
        self.calls = 0

    def draw(self, rgb: np.ndarray, empty: np.ndarray, camera: tuple[Sequence[float], Sequence[float]]) -> None:
        """Lay every body's window over `rgb` (a painted image of the walls and furniture) where
        that body's scene is nearest; clear `empty` (pixels where nothing is drawn) there."""
        view, proj = camera
        height, width = empty.shape
        clip_from_world = np.reshape(proj, (4, 4)).T @ np.reshape(view, (4, 4)).T
        nearest: np.ndarray | None = None
        for body, bounds, scene, twin in self.scenes:
            pos, orn = pybullet.getBasePositionAndOrientation(body, physicsClientId=self.client)
            world = np.eye(4)
            world[:3, :3], world[:3, 3] = np.reshape(pybullet.getMatrixFromQuaternion(orn), (3, 3)), pos
            window = body_window(clip_from_world @ world @ bounds, width, height)
            if window is None:
                continue
            c0, r0, c1, r1 = window
            pybullet.resetBasePositionAndOrientation(twin, pos, orn, physicsClientId=scene)
            part, depth = tiny_render(scene, (view, sub_projection(proj, width, height, window)), c1 - c0, r1 - r0)
            self.calls += 1
            if nearest is None:
                nearest = np.ones((height, width), np.float32)
            shown = depth < nearest[r0:r1, c0:c1]
            np.copyto(rgb[r0:r1, c0:c1], part, where=shown[:, :, None])
            np.copyto(nearest[r0:r1, c0:c1], depth, where=shown)
            empty[r0:r1, c0:c1] &= ~shown

    def close(self) -> None:
        for _, _, scene, _ in self.scenes:
            pybullet.disconnect(scene)
        self.scenes = []
