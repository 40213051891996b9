"""The video's 3D views at a fraction of their cost: render-only copies of the house.

PyBullet's TinyRenderer (EGL through Mesa's llvmpipe, the only OpenGL here, spends as much CPU on
an image of an empty scene: experiments/results/video/renderers.md) spends about 0.2
microseconds on every pixel a body covers, and the walls and furniture cover most of every
image. A :class:`SceneViews` gives the same pictures from two render-only copies of the house
(one with the chase view's cut-away walls, one with full walls for the first-person view):

* the walls and furniture, boxes along x and y, are painted without the renderer, as it draws
  them (:class:`~fg_tea.render.boxes.BoxPainter`: its face culling, near-plane clipping, pixel
  coverage and colours);
* the objects and the drone are drawn by TinyRenderer in the windows their bounds cover, each
  in a scene of its own that holds the walls and furniture too, laid over the painted image
  nearest first (:class:`~fg_tea.render.windows.BodyWindows`), so what hides an object hides it
  as in a whole image;
* neither copy has a floor body; the floor's top face is a plane of one colour (flat shading
  under a directional light), so every pixel where nothing was drawn and that sees the floor's
  rectangle is filled with that colour, measured once from a floor-only rendering;
* a house with a wall along neither x nor y is drawn by TinyRenderer alone, as before
  (``SceneViews.painters`` is then None for its copies).

Each copy's walls are one mesh body (:func:`wall_mesh`) without the faces a row of box pieces
had inside a wall: in 1 m pieces where TinyRenderer draws whole images (a long face's triangles
make it scan screen-sized boxes; finer pieces cost more), in whole faces where it draws only
windows (fewer triangles to transform). Moving every body the camera cannot see out of the
scene saves nothing measurable (experiments/results/video/tinyrenderer.md).

The agent's own camera (detections, pixel counts) never uses these copies: episodes and their
logs are unchanged. The images equal the plain renderer's but for a few pixels on edges
(tests/test_video_boxes.py, tests/test_video_walls.py; tests/test_video_speed.py asks PSNR >=
40 dB of whole frames against the reference frames).
"""

from __future__ import annotations

import functools
import math
from typing import Callable, Sequence

import numpy as np

from fg_tea.env import assets
from fg_tea.env.pybullet_quiet import pybullet
from fg_tea.env.base import EnvConfig
from fg_tea.env.house import WALL_COLOR, PyBulletHouse, _corners
from fg_tea.render.boxes import Box, BoxPainter
from fg_tea.render.windows import BodyWindows
from fg_tea.world.navigation import Box2D, wall_boxes
from fg_tea.world.interface import Pose
from fg_tea.world.scenario import Scenario


#: Walls are drawn in pieces at most this long (m): a long wall's faces are thin triangles whose
#: screen bounding boxes the renderer scans whole.
WALL_PIECE_M = 1.0


class SceneViews:
    """Chase and first-person images of a logged scene, rendered without a floor body.

    Args:
        scenario: the house.
        config: the environment configuration (sensor height, field of view, ...).
        seed: the episode's seed (reset of both copies).
        wall_cutaway: chase walls' height (m); None for full walls.
    """

    def __init__(self, scenario: Scenario, config: EnvConfig, seed: int, wall_cutaway: float | None) -> None:
        self.ego_house = PyBulletHouse(scenario, config)
        self.chase_house = PyBulletHouse(scenario, config)
        self.wall_cutaway = wall_cutaway
        self.config, self.scenario = config, scenario
        for house in (self.ego_house, self.chase_house):
            house.reset(seed)
        self.floor_rgb = self._floor_colour()
        (x0, y0), (x1, y1) = scenario.house.floor_min, scenario.house.floor_max
        self.floor_rect = (x0 - 0.3, y0 - 0.3, x1 + 0.3, y1 + 0.3)  # the floor box of PyBulletHouse
        for h in (self.ego_house, self.chase_house):
            pybullet.removeBody(h._static[0], physicsClientId=h._client)  # noqa: SLF001 (render-only copy)
        boxes = {house: house_boxes(scenario, top) for house, top in ((self.chase_house, wall_cutaway),
                                                                      (self.ego_house, None))}
        for house, top in ((self.chase_house, wall_cutaway), (self.ego_house, None)):
            # Painted walls are drawn by the renderer only in small windows, where a long face's
            # triangles cost little and fewer triangles cost less (every image transforms them all).
            self._cut_walls(house, top, WALL_PIECE_M if boxes[house] is None else math.inf)
        self.calls = 0
        self._floor_images: dict[tuple[int, int], np.ndarray] = {}
        #: The walls and furniture drawn without the renderer (None: a wall not along x or y, and
        #: the renderer draws everything).
        self.painters = {house: None if b is None else BoxPainter(b, self._shade) for house, b in boxes.items()}
        #: The objects and the drone, drawn by the renderer in windows (painted houses only).
        self.windows = {house: BodyWindows(house._client, self._small_bodies(house),  # noqa: SLF001
                                           functools.partial(self._statics, top=top))
                        for house, top in ((self.chase_house, wall_cutaway), (self.ego_house, None))
                        if self.painters[house] is not None}

    def _floor_colour(self) -> np.ndarray:
        """The floor's colour as the renderer shades it: one floor-only image, looking down."""
        h = self.chase_house
        client, floor = h._client, h._static[0]  # noqa: SLF001
        ids = [pybullet.getBodyUniqueId(i, physicsClientId=client)
               for i in range(pybullet.getNumBodies(physicsClientId=client))]
        saved = {b: pybullet.getBasePositionAndOrientation(b, physicsClientId=client) for b in ids if b != floor}
        for b in saved:
            pybullet.resetBasePositionAndOrientation(b, [0, 0, -500], [0, 0, 0, 1], physicsClientId=client)
        (x0, y0), (x1, y1) = h.scenario.house.floor_min, h.scenario.house.floor_max
        eye = ((x0 + x1) / 2, (y0 + y1) / 2, 2.0)
        view = pybullet.computeViewMatrix(list(eye), [eye[0], eye[1], 0.0], [1.0, 0.0, 0.0])
        proj = pybullet.computeProjectionMatrixFOV(30.0, 1.0, 0.03, 30.0)
        rgb = h._render((view, proj), 16, 16, segmentation=False)[0]  # noqa: SLF001
        for b, (pos, orn) in saved.items():
            pybullet.resetBasePositionAndOrientation(b, pos, orn, physicsClientId=client)
        return rgb[8, 8].copy()

    def _shade(self, rgba: tuple, normal: tuple) -> np.ndarray:
        """The renderer's colour of a face of colour `rgba` facing `normal` (one small image of a
        box far from the house, looking at that face)."""
        h = self.chase_house
        centre = np.array([1000.0, 1000.0, 1000.0])
        body = assets.box(h._client, tuple(centre), (0.5, 0.5, 0.5), rgba)  # noqa: SLF001
        eye = centre + 3.0 * np.asarray(normal)
        up = [0.0, 0.0, 1.0] if abs(normal[2]) < 0.5 else [1.0, 0.0, 0.0]
        view = pybullet.computeViewMatrix(list(eye), list(centre), up)
        proj = pybullet.computeProjectionMatrixFOV(20.0, 1.0, 0.03, 30.0)
        rgb = h._render((view, proj), 16, 16, segmentation=False)[0]  # noqa: SLF001
        pybullet.removeBody(body, physicsClientId=h._client)  # noqa: SLF001
        return rgb[8, 8].copy()

    def _small_bodies(self, house: PyBulletHouse) -> list[tuple[int, np.ndarray, Callable[[int], int]]]:
        """The bodies the renderer still draws (objects, the drone): each with its local bounds
        and what creates it in another client; the drone not for the first-person copy when
        every corner of its bounds lies behind that camera (the camera rides with it, so it is
        then never drawn there)."""
        bodies: list[tuple[int, np.ndarray, Callable[[int], int]]] = []
        for spec in self.scenario.objects:
            parts = assets.object_parts(spec.asset, spec.category)
            bodies.append((house._bodies[spec.name], house._bounds[spec.name],  # noqa: SLF001
                           functools.partial(_create, parts)))
        drone = _corners(assets.drone_parts())
        if house is self.ego_house:
            saved = house._pose  # noqa: SLF001
            house._pose = Pose(0.0, 0.0, 0.0)  # noqa: SLF001
            view, proj = house._ego_camera(64, 48)  # noqa: SLF001
            house._pose = saved  # noqa: SLF001
            world = drone + np.array([[0.0], [0.0], [self.config.sensor_height], [0.0]])
            clip = np.reshape(proj, (4, 4)).T @ np.reshape(view, (4, 4)).T @ world
            if (clip[3] < 0).all():
                return bodies
        return bodies + [(house._drone, drone, functools.partial(_create, assets.drone_parts()))]  # noqa: SLF001

    def _statics(self, client: int, top: float | None) -> None:
        """The walls (one mesh, whole faces) and furniture of a render-only copy, in `client`:
        as :meth:`_cut_walls` and :class:`~fg_tea.env.house.PyBulletHouse` build them."""
        add_walls(client, self.scenario, top, math.inf)
        for f in self.scenario.house.furniture:
            assets.box(client, (f.center[0], f.center[1], f.size[2] / 2), (f.size[0] / 2, f.size[1] / 2, f.size[2] / 2),
                       f.color)

    @staticmethod
    def _cut_walls(house: PyBulletHouse, top: float | None, piece_m: float = WALL_PIECE_M) -> None:
        """Replace `house`'s walls by one mesh body: their pieces, at most `piece_m` long, from the
        floor up to `top` metres (None: full height)."""
        for body, _, _ in house._walls:  # noqa: SLF001
            pybullet.removeBody(body, physicsClientId=house._client)  # noqa: SLF001
        add_walls(house._client, house.scenario, top, piece_m)  # noqa: SLF001
        house._walls = []  # noqa: SLF001 (render_chase must not move the removed walls)

    def set_scene_state(self, pose, placements, held: str | None) -> None:
        for house in (self.ego_house, self.chase_house):
            house.set_scene_state(pose, placements, held)

    def chase_camera(self, width: int, height: int, distance: float, height_m: float, pitch_deg: float,
                     hfov_deg: float) -> tuple[list, list]:
        """The chase camera's matrices, as :meth:`PyBulletHouse.chase_camera_matrices` gives them."""
        return self.chase_house.chase_camera_matrices(width, height, distance, height_m, pitch_deg,
                                                      hfov_deg, self.wall_cutaway)

    def chase(self, width: int, height: int, distance: float, height_m: float, pitch_deg: float,
              hfov_deg: float) -> np.ndarray:
        camera = self.chase_camera(width, height, distance, height_m, pitch_deg, hfov_deg)
        return self._draw(self.chase_house, camera, width, height)

    def ego(self, width: int, height: int) -> np.ndarray:
        camera = self.ego_house._ego_camera(width, height)  # noqa: SLF001
        return self._draw(self.ego_house, camera, width, height)

    def _draw(self, house: PyBulletHouse, camera: tuple[list, list], width: int, height: int) -> np.ndarray:
        """The image: walls and furniture painted (:class:`~fg_tea.render.boxes.BoxPainter`), the
        objects and the drone drawn by the renderer in the windows their bounds cover
        (:class:`~fg_tea.render.windows.BodyWindows`), the floor filled in."""
        import cv2

        painter = self.painters[house]
        if painter is None:
            return self._render(house, camera, width, height)
        self.calls += 1
        ids, colours = painter.paint(camera[0], camera[1], width, height)
        rgb = np.take(colours, ids, axis=0)
        empty = ids == 0
        self.windows[house].draw(rgb, empty, camera)
        if empty.any():
            empty &= floor_mask(camera, width, height, self.floor_rect).view(bool)
            cv2.copyTo(self._floor_image(height, width), empty.view(np.uint8), rgb)
        return rgb

    def _render(self, house: PyBulletHouse, camera: tuple[list, list], width: int, height: int) -> np.ndarray:
        import cv2

        self.calls += 1
        rgb, depth, _ = house._render(camera, width, height, segmentation=False)  # noqa: SLF001
        rgb = _contiguous_rgb(rgb)
        empty = depth >= 1.0
        if empty.any():
            empty &= floor_mask(camera, width, height, self.floor_rect).view(bool)
            # OpenCV, not numpy's indexing: the same pixels, about 0.7 ms less per chase image.
            cv2.copyTo(self._floor_image(height, width), empty.view(np.uint8), rgb)
        return rgb

    def _floor_image(self, height: int, width: int) -> np.ndarray:
        """An image of the floor's colour (kept per size)."""
        image = self._floor_images.get((height, width))
        if image is None:
            image = self._floor_images[(height, width)] = np.empty((height, width, 3), np.uint8)
            image[:] = self.floor_rgb
        return image

    def close(self) -> None:
        for windows in self.windows.values():
            windows.close()
        self.ego_house.close()
        self.chase_house.close()


class HouseViews:
    """The same views straight from a :class:`PyBulletHouse` (its own floor and walls): the
    plain renderer, for a house already built (``fg-tea preview``)."""

    def __init__(self, house: PyBulletHouse, wall_cutaway: float | None) -> None:
        self.house, self.wall_cutaway, self.config = house, wall_cutaway, house.config
        self.calls = 0

    def set_scene_state(self, pose, placements, held: str | None) -> None:
        self.house.set_scene_state(pose, placements, held)

    def chase_camera(self, width: int, height: int, distance: float, height_m: float, pitch_deg: float,
                     hfov_deg: float) -> tuple[list, list]:
        return self.house.chase_camera_matrices(width, height, distance, height_m, pitch_deg, hfov_deg,
                                                self.wall_cutaway)

    def chase(self, width: int, height: int, distance: float, height_m: float, pitch_deg: float,
              hfov_deg: float) -> np.ndarray:
        self.calls += 1
        return self.house.render_chase(width, height, distance, height_m, pitch_deg, hfov_deg, self.wall_cutaway)

    def ego(self, width: int, height: int) -> np.ndarray:
        self.calls += 1
        return self.house.render_ego(width, height)[0]

    def close(self) -> None:
        self.house.close()


def _contiguous_rgb(rgb: np.ndarray) -> np.ndarray:
    """A writable, contiguous copy of `rgb`; when it is the first three channels of a contiguous
    RGBA image (as the renderer gives it), copied by OpenCV (about 0.6 ms less at 640x360)."""
    import cv2

    rgba = rgb.base
    if (isinstance(rgba, np.ndarray) and rgba.dtype == np.uint8 and rgba.shape == rgb.shape[:2] + (4,)
            and rgba.flags.c_contiguous and rgb.ctypes.data == rgba.ctypes.data):
        return cv2.cvtColor(rgba, cv2.COLOR_RGBA2RGB)
    return np.array(rgb)


def house_boxes(scenario: Scenario, top: float | None) -> list[Box] | None:
    """The walls (up to `top` m; None: full height) and furniture of a house as axis-aligned
    boxes, as :class:`~fg_tea.env.house.PyBulletHouse` builds them; None if a wall runs along
    neither x nor y."""
    house = scenario.house
    height = house.wall_height if top is None else min(max(top, 0.05), house.wall_height)
    boxes = []
    for wall in wall_boxes(house):
        ux, uy = abs(wall.axis[0]), abs(wall.axis[1])
        if (ux, uy) not in ((1.0, 0.0), (0.0, 1.0)):
            return None
        hx, hy = ux * wall.half[0] + uy * wall.half[1], uy * wall.half[0] + ux * wall.half[1]
        (cx, cy) = wall.center
        boxes.append(Box((cx - hx, cy - hy, 0.0), (cx + hx, cy + hy, height), WALL_COLOR))
    for f in house.furniture:
        (cx, cy), (sx, sy, sz) = f.center, f.size
        r, g, b, alpha = f.color
        boxes.append(Box((cx - sx / 2, cy - sy / 2, 0.0), (cx + sx / 2, cy + sy / 2, sz), (r, g, b, alpha)))
    return boxes


def _create(parts: Sequence[assets.Part], client: int) -> int:
    return assets.create_compound(client, parts)


def add_walls(client: int, scenario: Scenario, top: float | None, piece_m: float) -> int:
    """The walls of `scenario`'s house as one mesh body in `client` (:func:`wall_mesh`), from the
    floor up to `top` metres (None: full height); returns the body."""
    full = scenario.house.wall_height
    height = full if top is None else min(max(top, 0.05), full)
    vertices, normals, indices = wall_mesh(wall_boxes(scenario.house), height, piece_m)
    visual = pybullet.createVisualShape(pybullet.GEOM_MESH, vertices=vertices, indices=indices, normals=normals,
                                        uvs=[[0.0, 0.0]] * len(vertices), rgbaColor=list(WALL_COLOR),
                                        meshScale=[1.0, 1.0, 1.0], physicsClientId=client)
    return pybullet.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=visual,
                                    physicsClientId=client)


def wall_mesh(boxes: Sequence[Box2D], height: float, piece_m: float = WALL_PIECE_M
              ) -> tuple[list[list[float]], list[list[float]], list[int]]:
    """The faces of wall boxes standing on the floor, `height` m tall, as one triangle mesh.

    Each box's sides and top are cut into pieces at most `piece_m` long; its two ends are whole
    (no faces inside a wall, no bottom: it lies on the floor, facing away from every camera), each
    a quad of two triangles wound counter-clockwise seen from outside (the renderer culls back
    faces), with the face's outward normal at its four corners (flat shading, as a box's).

    Returns:
        vertices (x, y, z m), normals (one per vertex), triangle indices.
    """
    vertices: list[list[float]] = []
    normals: list[list[float]] = []
    indices: list[int] = []

    def quad(corners: list[tuple[float, float, float]], normal: tuple[float, float, float]) -> None:
        a, b, c = (np.array(corners[i]) for i in range(3))
        order = (0, 1, 2, 0, 2, 3) if np.dot(np.cross(b - a, c - a), normal) > 0 else (0, 2, 1, 0, 3, 2)
        indices.extend(len(vertices) + i for i in order)
        vertices.extend([float(v) for v in p] for p in corners)
        normals.extend([list(normal)] * 4)

    for box in boxes:
        (cx, cy), (hl, ht), (ux, uy) = box.center, box.half, box.axis
        nx, ny = -uy, ux

        def at(a: float, b: float, z: float) -> tuple[float, float, float]:
            return (cx + a * ux + b * nx, cy + a * uy + b * ny, z)

        n = max(1, math.ceil(2 * hl / piece_m)) if math.isfinite(piece_m) else 1
        cuts = [-hl + 2 * hl * k / n for k in range(n + 1)]
        for a0, a1 in zip(cuts, cuts[1:]):
            for side in (1.0, -1.0):
                b = side * ht
                quad([at(a0, b, 0.0), at(a1, b, 0.0), at(a1, b, height), at(a0, b, height)],
                     (side * nx, side * ny, 0.0))
            quad([at(a0, -ht, height), at(a1, -ht, height), at(a1, ht, height), at(a0, ht, height)], (0.0, 0.0, 1.0))
        for side in (1.0, -1.0):
            a = side * hl
            quad([at(a, -ht, 0.0), at(a, ht, 0.0), at(a, ht, height), at(a, -ht, height)], (side * ux, side * uy, 0.0))
    return vertices, normals, indices


def floor_mask(camera: tuple[Sequence[float], Sequence[float]], width: int, height: int,
               rect: tuple[float, float, float, float]) -> np.ndarray:
    """The pixels that see the rectangle `rect` (x0, y0, x1, y1) of the plane z = 0: its corners
    clipped to the camera's near plane, projected and filled (uint8, 1 inside)."""
    view, proj = camera
    v, m = np.reshape(view, (4, 4)).T, np.reshape(proj, (4, 4)).T
    x0, y0, x1, y1 = rect
    corners = v @ np.array([[x0, y0, 0, 1], [x1, y0, 0, 1], [x1, y1, 0, 1], [x0, y1, 0, 1]], float).T
    eye = corners[:3].T  # camera space; in front means z < -near
    near = -1.000001 * _near(m)
    kept = []
    for a, b in zip(eye, np.roll(eye, -1, axis=0)):
        a_in, b_in = a[2] <= near, b[2] <= near
        if a_in:
            kept.append(a)
        if a_in != b_in:
            t = (near - a[2]) / (b[2] - a[2])
            kept.append(a + t * (b - a))
    mask = np.zeros((height, width), np.uint8)
    if len(kept) < 3:
        return mask
    pts = np.array(kept)
    clip = m @ np.vstack([pts.T, np.ones(len(pts))])
    u = (clip[0] / clip[3] + 1) / 2 * width - 0.5
    r = (1 - clip[1] / clip[3]) / 2 * height - 0.5
    import cv2

    poly = np.round(np.stack([u, r], axis=1) * 16).astype(np.int32)
    cv2.fillPoly(mask, [poly], 1, lineType=cv2.LINE_8, shift=4)
    return mask


def _near(proj: np.ndarray) -> float:
    """The near distance of an OpenGL perspective projection matrix (row-major)."""
    a, b = proj[2, 2], proj[2, 3]
    return b / (a - 1)
