"""The PyBullet house: how an action happens in the house, and what the camera sees.

This module answers the environment question (docs/design.md §8; defaults §8.6) with PyBullet
in DIRECT mode (CPU, no window, no GPU) in place of Habitat-Sim:

* the scene: floor, walls with doorway gaps, furniture boxes whose tops are the semantic sites,
  distinct mug, kettle and teabag bodies on their true sites, and a drone body for the agent;
* navigation on the occupancy grid of :mod:`fg_tea.world.navigation` (geodesic distance d_j of
  eq. 12 as a lookup; Euclidean as the ablation);
* perception: at a site's vantage the agent turns to face the surface and renders one
  egocentric segmentation image; n_o counts the pixels of object o [28]; o is detected iff
  n_o >= ``min_visible_pixels`` and o lies within ``site_association_radius`` of the site [29].
  Occlusion is real: the image is rendered, so a body in front of an object hides it;
* kinematic manipulation and hidden truth (:class:`~fg_tea.env.adapter.TruthBackedAdapter`,
  §8.5); cameras for people: the egocentric view and a chase camera (defaults §8.6).

Headless use renders exactly one egocentric image per inspection; with ``render_motion`` every
frame of motion is mirrored into the scene and handed to a frame sink (or rendered). This is the
only fg_tea module that imports pybullet besides :mod:`fg_tea.env.assets`.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from typing import Callable, Mapping, Sequence

import numpy as np

from fg_tea.env import assets
from fg_tea.env.pybullet_quiet import pybullet
from fg_tea.env.adapter import TruthBackedAdapter
from fg_tea.env.company import category_pairs
from fg_tea.env.base import EnvConfig
from fg_tea.env.motion import follow_path, held_position
from fg_tea.env.table_cache import cached_table
from fg_tea.world.interface import Pose
from fg_tea.world.navigation import Navigator, path_length, wall_boxes
from fg_tea.world.scenario import Scenario

#: Fixed downward tilt (deg) of the egocentric camera, so surfaces from 0.45 m to 1.05 m high are
#: all in view from their vantage points.
EGO_PITCH_DEG = -20.0
#: Near and far clipping planes (m) of both cameras.
NEAR_M, FAR_M = 0.03, 30.0
#: A body counts as behind the camera when every corner of its bounding box lies at least this far
#: (m) behind the camera plane; the margin absorbs float rounding of the renderer's own test.
BEHIND_MARGIN_M = 1e-4
#: The chase camera is pulled in front of any wall between it and the agent, keeping this gap (m).
CHASE_WALL_GAP_M = 0.15
#: Half width (m) of the corridor behind the agent that must be free of walls for the chase camera
#: (three parallel rays), so it does not peer through a doorway past its frame.
CHASE_SIDE_CLEARANCE_M = 0.35
#: Shortest chase-camera distance (m) after the pull-in.
CHASE_MIN_DISTANCE_M = 0.6

FLOOR_COLOR = (0.56, 0.60, 0.66, 1.0)
WALL_COLOR = (0.97, 0.94, 0.86, 1.0)
LIGHT_DIRECTION = (0.4, -0.6, 1.0)
#: TinyRenderer lighting: ambient, diffuse and specular coefficients.
LIGHT_COEFFS = (0.6, 0.45, 0.05)

#: Where bodies wait out of every camera's sight (m): below the floor, far from the house.
PARKED = (0.0, 0.0, -50.0)
#: Bump when the expected-visibility computation changes, so cached tables are recomputed.
VISIBILITY_VERSION = 2

FrameSink = Callable[["PyBulletHouse", Pose], None]


class PyBulletHouse(TruthBackedAdapter):
    """The scenario's house in PyBullet, as an :class:`~fg_tea.env.base.EnvAdapter`.

    Args:
        scenario: the house, sites and objects (truth is read only inside the environment).
        config: embodiment parameters (docs/design.md §8.6).
        render_motion: mirror every frame of motion into the scene and hand it to `frame_sink`
            (or, without a sink, render the egocentric camera each frame). Off for headless runs.
        frame_sink: called as ``frame_sink(house, pose)`` once per frame of motion when
            `render_motion` is on, after the scene shows that frame; it may call
            :meth:`render_ego` / :meth:`render_chase`.
        roi: count pixels [28] by rendering only the window of the egocentric image that can
            contain a considered object (the union of their projected bounding boxes, on the same
            pixel grid as the full image). Pixels outside that window cannot hold those objects,
            so the counts equal the full image's; ``roi=False`` renders the whole image.

    Raises:
        InputError: a vantage point (or the start) is off the free floor or unreachable; raised at
            construction, naming the site and the nearest free cell.
    """

    def __init__(self, scenario: Scenario, config: EnvConfig = EnvConfig(), render_motion: bool = False,
                 *, frame_sink: FrameSink | None = None, roi: bool = True) -> None:
        super().__init__(scenario, config)
        if config.agent_radius < assets.DRONE_RADIUS_M:
            raise ValueError(f"agent_radius {config.agent_radius} m is smaller than the drone body "
                             f"({assets.DRONE_RADIUS_M} m)")
        self.render_motion = render_motion
        self.frame_sink = frame_sink
        self.roi = roi
        self.navigator = Navigator(scenario, config)
        self.frames_rendered = 0
        self._client = pybullet.connect(pybullet.DIRECT)
        self._bodies: dict[str, int] = {}
        self._static: list[int] = []
        self._obstacles: list[int] = []
        self._drone = -1
        self._built = False
        self._probes: dict[str, tuple[int, np.ndarray]] = {}

    # --- scene -----------------------------------------------------------------------------

    def _build(self) -> None:
        if not self._built:
            self._build_static()
            self._built = True
        for body in self._obstacles:
            pybullet.removeBody(body, physicsClientId=self._client)
        self._obstacles = []
        self.frames_rendered = 0

    def _build_static(self) -> None:
        c, house = self._client, self.scenario.house
        (x0, y0), (x1, y1) = house.floor_min, house.floor_max
        self._static.append(assets.box(c, ((x0 + x1) / 2, (y0 + y1) / 2, -0.025),
                                       ((x1 - x0) / 2 + 0.3, (y1 - y0) / 2 + 0.3, 0.025), FLOOR_COLOR))
        h = house.wall_height
        self._walls: list[tuple[int, tuple[float, float], tuple]] = []
        for wall in wall_boxes(house):
            yaw = math.atan2(wall.axis[1], wall.axis[0])
            body = assets.box(c, (wall.center[0], wall.center[1], h / 2),
                              (wall.half[0], wall.half[1], h / 2), WALL_COLOR, yaw=yaw)
            self._static.append(body)
            self._walls.append((body, wall.center, pybullet.getQuaternionFromEuler((0.0, 0.0, yaw))))
        for f in house.furniture:
            self._static.append(assets.box(c, (f.center[0], f.center[1], f.size[2] / 2),
                                           (f.size[0] / 2, f.size[1] / 2, f.size[2] / 2), f.color))
        self._bounds: dict[str, np.ndarray] = {}
        for spec in self.scenario.objects:
            parts = assets.object_parts(spec.asset, spec.category)
            self._bodies[spec.name] = assets.create_compound(c, parts)
            self._bounds[spec.name] = _corners(parts)
        self._drone = assets.create_compound(c, assets.drone_parts())
        self._body_to_object = {body: name for name, body in self._bodies.items()}
        self._semantic = {self._bodies[s.name]: s.semantic_id for s in self.scenario.objects}

    def add_obstacle(self, center: Sequence[float], size: Sequence[float],
                     rgba: Sequence[float] = (0.5, 0.5, 0.55, 1.0)) -> int:
        """Add a box that occludes the cameras (not the navigation grid); removed on reset.

        Args:
            center: box centre (x, y, z) in metres.
            size: full box size (x, y, z) in metres.

        Returns:
            The body id.
        """
        self._require_reset()
        (x, y, z), (sx, sy, sz), (r, g, b, a) = center, size, rgba
        body = assets.box(self._client, (x, y, z), (sx / 2, sy / 2, sz / 2), (r, g, b, a))
        self._obstacles.append(body)
        return body

    def close(self) -> None:
        if self._client >= 0:
            pybullet.disconnect(self._client)
            self._client = -1

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # interpreter shutdown: pybullet may already be gone
            pass

    # --- hooks -----------------------------------------------------------------------------

    def _route(self, k: int) -> list[Pose] | None:
        corners = self.navigator.path(k, (self._pose.x, self._pose.y))
        if corners is None:
            return None
        return follow_path(self._pose, corners, self.config)

    def _distance_from(self, k: int, xy: Sequence[float]) -> float:
        return self.navigator.distance(k, xy)

    def _walk_length(self, k: int, xy: Sequence[float]) -> float:
        vx, vy = self._viewpoints[k].position
        if math.hypot(vx - xy[0], vy - xy[1]) < 1e-9:  # already there: _go_to does not move
            return 0.0
        corners = self.navigator.path(k, xy)
        return math.inf if corners is None else path_length(corners)

    def _pixel_counts(self, k: int, objects: Sequence[str]) -> dict[str, int]:
        self._sync()
        if not objects:
            return {}
        return self._count_pixels({name: (self._bodies[name], self._bounds[name]) for name in objects})

    def _count_pixels(self, bodies: Mapping[str, tuple[int, np.ndarray]]) -> dict[str, int]:
        """Segmentation pixels of each body in the egocentric image at the current pose [28].

        Args:
            bodies: label -> (body id, its 8 local bounding-box corners as a (4, 8) array).
        """
        width, height = self.config.ego_width, self.config.ego_height
        view, proj = self._ego_camera(width, height)
        if self.roi:
            window = self._window(view, proj, width, height, list(bodies.values()))
            if window is None:
                return {label: 0 for label in bodies}
            c0, r0, c1, r1 = window
            proj = sub_projection(proj, width, height, window)
            width, height = c1 - c0, r1 - r0
        seg = self._render((view, proj), width, height, segmentation=True)[2]
        return {label: int(np.count_nonzero(seg == body)) for label, (body, _) in bodies.items()}

    def _window(self, view: Sequence[float], proj: Sequence[float], width: int, height: int,
                bodies: Sequence[tuple[int, np.ndarray]]) -> tuple[int, int, int, int] | None:
        """Pixel window (col0, row0, col1, row1) covering every body's projected bounds.

        A body whose bounding box lies entirely behind the camera (every corner has clip
        w = -z_eye < 0) contributes no pixels and is left out: TinyRenderer discards every triangle
        whose three vertices all have w < 0, and each of the body's vertices lies inside its box.
        A body whose box reaches from in front of the near plane to behind it (or lies within
        the near plane's slab, 0 <= w <= near) may still cover pixels anywhere, so it makes the
        window the whole image. None if no body can be in view.
        """
        clip_from_world = np.reshape(proj, (4, 4)).T @ np.reshape(view, (4, 4)).T
        boxes = []
        for body, bounds in bodies:
            pos, orn = pybullet.getBasePositionAndOrientation(body, physicsClientId=self._client)
            rot = np.reshape(pybullet.getMatrixFromQuaternion(orn), (3, 3))
            world = np.eye(4)
            world[:3, :3], world[:3, 3] = rot, pos
            clip = clip_from_world @ world @ bounds
            if (clip[3] < -BEHIND_MARGIN_M).all():
                continue  # entirely behind the camera: no triangle of it is drawn
            if (clip[3] <= NEAR_M).any():
                return (0, 0, width, height)
            ndc = clip[:2] / clip[3]
            boxes.append((ndc[0].min(), ndc[1].min(), ndc[0].max(), ndc[1].max()))
        if not boxes:
            return None
        b = np.array(boxes)
        x0, y0, x1, y1 = b[:, 0].min(), b[:, 1].min(), b[:, 2].max(), b[:, 3].max()
        c0 = max(0, int(math.floor((x0 + 1) / 2 * width)) - 2)
        c1 = min(width, int(math.ceil((x1 + 1) / 2 * width)) + 2)
        r0 = max(0, int(math.floor((1 - y1) / 2 * height)) - 2)
        r1 = min(height, int(math.ceil((1 - y0) / 2 * height)) + 2)
        if c1 <= c0 or r1 <= r0:
            return None
        return (c0, r0, c1, r1)

    # --- expected visibility ---------------------------------------------------------------

    def _probe(self, category: str, copy: int = 0) -> tuple[int, np.ndarray]:
        """A body of `category` (the scenario's asset for it) parked out of sight, and its bounds;
        `copy` 1 is a second body of the same category (a category paired with itself)."""
        key = category if copy == 0 else f"{category}#{copy}"
        if key not in self._probes:
            asset = next((s.asset for s in self.scenario.objects if s.category == category), category)
            parts = assets.object_parts(asset, category)
            body = assets.create_compound(self._client, parts, PARKED)
            self._probes[key] = (body, _corners(parts))
        return self._probes[key]

    def _expected_pixels(self, target: int, site: int, categories: Sequence[str]) -> dict[str, list[float]]:
        vx, vy = self._viewpoints[target].position
        spec = self.scenario.sites[site]
        px, py, _ = spec.position
        saved = self._pose
        self._pose = Pose(float(vx), float(vy), math.degrees(math.atan2(py - vy, px - vx)))
        try:
            for body in self._bodies.values():  # the house alone: no task object in the way
                self._place_body(body, PARKED, 0.0)
            self._place_drone(self._pose)
            slots = [self._slot_position(spec.name, k) for k in range(self.slot_count(spec.name))]
            out: dict[str, list[float]] = {}
            for category in categories:
                body, bounds = self._probe(category)
                seen: dict[tuple[float, float, float], float] = {}  # slots clipped onto one point
                for slot in slots:
                    if slot not in seen:
                        self._place_body(body, slot, 0.0)
                        seen[slot] = float(self._count_pixels({category: (body, bounds)})[category])
                self._place_body(body, PARKED, 0.0)
                out[category] = [seen[slot] for slot in slots]
            return out
        finally:
            self._pose = saved
            self._sync()

    def _company_pixels(self, target: int, site: int, categories: Sequence[str],
                        offsets: Sequence[float]) -> dict[str, dict[str, list]]:
        """Rendered: each category alone at each slot and heading offset, then each pair of
        categories at each two different slots, facing the site exactly (docs/design.md §3.4)."""
        vx, vy = self._viewpoints[target].position
        spec = self.scenario.sites[site]
        px, py, _ = spec.position
        saved = self._pose
        facing_yaw = math.degrees(math.atan2(py - vy, px - vx))
        try:
            for body in self._bodies.values():
                self._place_body(body, PARKED, 0.0)
            slots = [self._slot_position(spec.name, k) for k in range(self.slot_count(spec.name))]
            facing: dict[str, list[list[float]]] = {c: [[0.0] * len(offsets) for _ in slots]
                                                    for c in dict.fromkeys(categories)}
            for h, offset in enumerate(offsets):
                self._pose = Pose(float(vx), float(vy), facing_yaw + float(offset))
                self._place_drone(self._pose)
                for category in facing:
                    body, bounds = self._probe(category)
                    for s, slot in enumerate(slots):
                        self._place_body(body, slot, 0.0)
                        facing[category][s][h] = float(self._count_pixels({category: (body, bounds)})[category])
                    self._place_body(body, PARKED, 0.0)
            self._pose = Pose(float(vx), float(vy), facing_yaw)
            self._place_drone(self._pose)
            company: dict[str, list[list[float | None]]] = {}
            for c, c2 in category_pairs(categories):
                if f"{c}|{c2}" in company:
                    continue  # rendered with its mirror: one image gives both objects' counts
                first, second = self._probe(c), self._probe(c2, 1 if c == c2 else 0)
                rows: list[list[float | None]] = [[None] * len(slots) for _ in slots]
                mirror: list[list[float | None]] = [[None] * len(slots) for _ in slots]
                for s, s2 in itertools.permutations(range(len(slots)), 2):
                    self._place_body(first[0], slots[s], 0.0)
                    self._place_body(second[0], slots[s2], 0.0)
                    counts = self._count_pixels({"a": first, "b": second})
                    rows[s][s2], mirror[s2][s] = float(counts["a"]), float(counts["b"])
                self._place_body(first[0], PARKED, 0.0)
                self._place_body(second[0], PARKED, 0.0)
                company[f"{c}|{c2}"] = rows
                if c != c2:
                    company[f"{c2}|{c}"] = mirror
            return {"facing": facing, "company": company}
        finally:
            self._pose = saved
            self._sync()

    def expected_pixel_counts(self, categories: Sequence[str]) -> dict[str, dict[str, dict[str, list[float]]]]:
        """See :meth:`TruthBackedAdapter.expected_pixel_counts`; cached in memory and in
        ``$FG_TEA_CACHE_DIR`` (default ``~/.cache/fg_tea``) under a hash of everything the numbers
        depend on (walls, furniture, sites and capacities, viewpoints, the number of objects,
        object models, camera parameters), so a second run pays nothing."""
        compute = super().expected_pixel_counts
        return self._cached("visibility", categories, lambda: compute(categories))

    def company_pixel_counts(self, categories: Sequence[str]) -> dict:
        """See :meth:`TruthBackedAdapter.company_pixel_counts`; cached as :meth:`expected_pixel_counts`
        (the face tolerance is part of the key)."""
        compute = super().company_pixel_counts
        return self._cached("company", categories, lambda: compute(categories))

    def _cached(self, kind: str, categories: Sequence[str], compute: Callable[[], dict]) -> dict:
        key = self._visibility_key(categories)
        if kind != "visibility":
            key = hashlib.sha256(f"{kind}:{key}:{self.config.face_tolerance_deg!r}:"
                                 f"{list(categories)!r}".encode()).hexdigest()[:32]
        return cached_table(kind, key, compute)

    def _visibility_key(self, categories: Sequence[str]) -> str:
        sc, cfg = self.scenario, self.config
        assets_used = {c: repr(assets.object_parts(
            next((s.asset for s in sc.objects if s.category == c), c), c)) for c in sorted(categories)}
        doc = {"version": VISIBILITY_VERSION, "house": repr(sc.house),
               "sites": [[s.name, s.position, s.vantage, s.furniture, s.capacity] for s in sc.sites],
               "objects": len(sc.objects),
               "viewpoints": [[v.name, v.kind, v.position, v.sites] for v in sc.viewpoints],
               "assets": assets_used,
               "camera": [cfg.ego_width, cfg.ego_height, cfg.ego_hfov_deg, cfg.sensor_height,
                          EGO_PITCH_DEG, NEAR_M, FAR_M, assets.CAMERA_FORWARD_M, self.roi]}
        return hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()[:32]

    def _sync(self) -> None:
        held = self._truth.held if hasattr(self, "_truth") else None
        moving = {held, *self._truth.contents_of(held)} if held is not None else set()
        for name, body in self._bodies.items():
            yaw = self._pose.yaw_deg if name in moving else 0.0
            self._place_body(body, self._positions[name], yaw)
        self._place_drone(self._pose)

    def _on_frames(self, frames: Sequence[Pose], start: Pose) -> None:
        if not self.render_motion:
            return
        held = self._truth.held
        inner = self._truth.contents_of(held) if held is not None else []
        for pose in frames:
            self._place_drone(pose)
            if held is not None:
                spot = held_position(pose, self.config)
                self._place_body(self._bodies[held], spot, pose.yaw_deg)
                for name in inner:
                    self._place_body(self._bodies[name], (spot[0], spot[1], spot[2] + 0.035), pose.yaw_deg)
            if self.frame_sink is not None:
                self.frame_sink(self, pose)
            else:
                self.render_ego(self.config.ego_width, self.config.ego_height)
            self.frames_rendered += 1

    def _place_body(self, body: int, xyz: Sequence[float], yaw_deg: float) -> None:
        pybullet.resetBasePositionAndOrientation(
            body, list(xyz), pybullet.getQuaternionFromEuler((0.0, 0.0, math.radians(yaw_deg))),
            physicsClientId=self._client)

    def _place_drone(self, pose: Pose) -> None:
        self._place_body(self._drone, (pose.x, pose.y, self.config.sensor_height), pose.yaw_deg)

    # --- replay ----------------------------------------------------------------------------

    def set_scene_state(self, agent_pose: Pose | Sequence[float],
                        placements: Mapping[str, Sequence[float]], held: str | None = None) -> None:
        """Show a logged state without running the agent (for re-rendering from a log).

        Args:
            agent_pose: a Pose or (x, y, yaw_deg).
            placements: object name -> (x, y, z) base position (m); missing objects stay put.
            held: the object riding in front of the agent, placed from `agent_pose` (overrides
                its entry in `placements`).
        """
        self._require_reset()
        pose = agent_pose if isinstance(agent_pose, Pose) else Pose(*map(float, agent_pose))
        self._pose = pose
        for name, xyz in placements.items():
            self._place_body(self._bodies[name], xyz, 0.0)
        if held is not None:
            self._place_body(self._bodies[held], held_position(pose, self.config), pose.yaw_deg)
        self._place_drone(pose)

    # --- cameras ---------------------------------------------------------------------------

    def _ego_camera(self, width: int, height: int) -> tuple[list, list]:
        cfg, pose = self.config, self._pose
        yaw = math.radians(pose.yaw_deg)
        eye = (pose.x + assets.CAMERA_FORWARD_M * math.cos(yaw), pose.y + assets.CAMERA_FORWARD_M * math.sin(yaw),
               cfg.sensor_height)
        vfov = 2 * math.degrees(math.atan(math.tan(math.radians(cfg.ego_hfov_deg) / 2) * height / width))
        return _view(eye, yaw, math.radians(EGO_PITCH_DEG)), _projection(vfov, width, height)

    def _chase_camera(self, width: int, height: int, distance: float, height_m: float, pitch_deg: float,
                      hfov_deg: float, avoid_walls: bool = True) -> tuple[list, list]:
        pose = self._pose
        yaw = math.radians(pose.yaw_deg)
        back = (pose.x - distance * math.cos(yaw), pose.y - distance * math.sin(yaw))
        grid = self.navigator.grid
        side = (-math.sin(yaw) * CHASE_SIDE_CLEARANCE_M, math.cos(yaw) * CHASE_SIDE_CLEARANCE_M)
        frac = min(grid.clear_fraction((pose.x + s * side[0], pose.y + s * side[1]),
                                       (back[0] + s * side[0], back[1] + s * side[1]), grid.walls)
                   for s in (-1.0, 0.0, 1.0)) if avoid_walls else 1.0
        if frac < 1.0 and avoid_walls:
            distance = max(CHASE_MIN_DISTANCE_M, frac * distance - CHASE_WALL_GAP_M)
            back = (pose.x - distance * math.cos(yaw), pose.y - distance * math.sin(yaw))
        vfov = 2 * math.degrees(math.atan(math.tan(math.radians(hfov_deg) / 2) * height / width))
        return (_view((back[0], back[1], height_m), yaw, math.radians(pitch_deg)),
                _projection(vfov, width, height))

    def _render(self, camera: tuple[list, list], width: int, height: int, segmentation: bool
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        view, proj = camera
        flags = 0 if segmentation else pybullet.ER_NO_SEGMENTATION_MASK
        _, _, rgba, depth, seg = pybullet.getCameraImage(
            width, height, viewMatrix=view, projectionMatrix=proj, renderer=pybullet.ER_TINY_RENDERER,
            lightDirection=list(LIGHT_DIRECTION), shadow=0, lightAmbientCoeff=LIGHT_COEFFS[0],
            lightDiffuseCoeff=LIGHT_COEFFS[1], lightSpecularCoeff=LIGHT_COEFFS[2], flags=flags,
            physicsClientId=self._client)
        rgb = np.reshape(np.asarray(rgba, dtype=np.uint8), (height, width, 4))[:, :, :3]
        depth = np.reshape(np.asarray(depth, dtype=np.float32), (height, width))
        seg_img = np.reshape(np.asarray(seg, dtype=np.int32), (height, width)) if segmentation else None
        return rgb, depth, seg_img

    def render_ego(self, width: int, height: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The egocentric camera at the current pose (what the agent sees).

        Returns:
            rgb: uint8 (height, width, 3).
            depth: float32 (height, width), metres along the optical axis.
            seg: int32 (height, width): the object's semantic id where a task object is visible,
                0 elsewhere.
        """
        self._require_reset()
        rgb, depth_buffer, seg = self._render(self._ego_camera(width, height), width, height, segmentation=True)
        assert seg is not None  # asked for
        depth = (FAR_M * NEAR_M / (FAR_M - (FAR_M - NEAR_M) * depth_buffer)).astype(np.float32)
        semantic = np.zeros(seg.shape, dtype=np.int32)
        for body, sid in self._semantic.items():
            semantic[seg == body] = sid
        return rgb, depth, semantic

    def _lower_walls(self, top: float | None) -> None:
        """Show walls with their tops at `top` metres (None: full height). Presentation only."""
        h = self.scenario.house.wall_height
        top = h if top is None else min(max(top, 0.05), h)
        for body, (x, y), orientation in self._walls:
            pybullet.resetBasePositionAndOrientation(body, [x, y, top - h / 2], orientation,
                                                     physicsClientId=self._client)

    def chase_camera_matrices(self, width: int, height: int, distance: float = 3.2, height_m: float = 2.2,
                              pitch_deg: float = -22.0, hfov_deg: float = 78.0,
                              wall_cutaway: float | None = None) -> tuple[list, list]:
        """The view and projection matrices (pybullet's column-major lists) that
        :meth:`render_chase` with the same arguments uses at the current pose, so that overlays
        can project world points into the chase image."""
        self._require_reset()
        return self._chase_camera(width, height, distance, height_m, pitch_deg, hfov_deg,
                                  avoid_walls=wall_cutaway is None)

    def render_chase(self, width: int, height: int, distance: float = 3.2, height_m: float = 2.2,
                     pitch_deg: float = -22.0, hfov_deg: float = 78.0,
                     wall_cutaway: float | None = None) -> np.ndarray:
        """The third-person chase camera (defaults: docs/design.md §8.6): for people, never for the agent.

        Args:
            width, height: image size in pixels.
            distance: metres behind the agent (pulled in front of a wall in between).
            height_m: camera height above the floor (m).
            pitch_deg: camera pitch (deg, negative looks down).
            hfov_deg: horizontal field of view (deg).
            wall_cutaway: if given, walls are drawn only up to this height (m) in this image, a
                dollhouse view for people; the agent's camera always sees full walls.

        Returns:
            rgb, uint8 (height, width, 3).
        """
        self._require_reset()
        camera = self._chase_camera(width, height, distance, height_m, pitch_deg, hfov_deg,
                                    avoid_walls=wall_cutaway is None)
        if wall_cutaway is None:
            return self._render(camera, width, height, segmentation=False)[0]
        self._lower_walls(wall_cutaway)
        try:
            return self._render(camera, width, height, segmentation=False)[0]
        finally:
            self._lower_walls(None)


def _corners(parts) -> np.ndarray:
    """The 8 corners of the parts' local bounding box, homogeneous, shape (4, 8)."""
    lo, hi = assets.local_bounds(parts)
    return np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                     for z in (lo[2], hi[2])]).T


def _view(eye: Sequence[float], yaw: float, pitch: float) -> list:
    """The view matrix of a camera at `eye` facing `yaw` (rad) and `pitch` (rad, up positive).

    Looking straight down or up (pitch ±90°) the world's vertical is the viewing direction and
    cannot be the image's up; the agent's heading is then (the image's top points forward).
    """
    direction = (math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), math.sin(pitch))
    target = [eye[i] + direction[i] for i in range(3)]
    up = [0.0, 0.0, 1.0] if abs(math.cos(pitch)) > 1e-6 else \
        [-math.copysign(1.0, pitch) * math.cos(yaw), -math.copysign(1.0, pitch) * math.sin(yaw), 0.0]
    return pybullet.computeViewMatrix(list(eye), target, up)


def sub_projection(proj: Sequence[float], width: int, height: int, window: tuple[int, int, int, int]) -> list:
    """Projection matrix that renders pixel window (col0, row0, col1, row1) of the full image.

    Clip coordinates are scaled and shifted so the window's NDC range maps to [-1, 1]; integer
    pixel positions of the window coincide with those of the full image.
    """
    c0, r0, c1, r1 = window
    x0, x1 = 2 * c0 / width - 1, 2 * c1 / width - 1
    y0, y1 = 1 - 2 * r1 / height, 1 - 2 * r0 / height
    m = np.array([[2 / (x1 - x0), 0, 0, -(x1 + x0) / (x1 - x0)],
                  [0, 2 / (y1 - y0), 0, -(y1 + y0) / (y1 - y0)],
                  [0, 0, 1, 0],
                  [0, 0, 0, 1]])
    return list((m @ np.reshape(proj, (4, 4)).T).T.flatten())


def _projection(vfov_deg: float, width: int, height: int) -> list:
    return pybullet.computeProjectionMatrixFOV(vfov_deg, width / height, NEAR_M, FAR_M)
