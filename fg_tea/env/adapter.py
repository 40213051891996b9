"""The environment adapter over the hidden truth: where the agent walks and what it sees.

This module answers *given a task verb, what happens in the house, and what does the agent get
back?* (docs/design.md §8). :class:`TruthBackedAdapter` implements the
:class:`~fg_tea.env.base.EnvAdapter` contract over :class:`~fg_tea.env.truth.TeaTruth` and the
floor plan: walking (:mod:`fg_tea.env.motion`), looking (eqs. 28-29, with the pixel counts a
subclass supplies), reading states (eqs. 23-24), and carrying out actions with their effects
(:class:`~fg_tea.env.verbs.ActionVerbs`, the verbs' half of the adapter); its subclasses are the
PyBullet house and the fake house."""

from __future__ import annotations

import abc
import math
from typing import Any, Mapping, Sequence

import numpy as np

from fg_tea.env.company import company_from_alone, facing_offsets
from fg_tea.env.base import EnvAdapter, EnvConfig
from fg_tea.env.motion import held_position, motion_of
from fg_tea.env.truth import TeaTruth
from fg_tea.env.verbs import ActionVerbs
from fg_tea.world.interface import InspectionResult, Pose, StateReading
from fg_tea.world.scenario import ObjectSpec, Scenario
from fg_tea.world.relative import start_layout


#: Lateral spacing (m) of the deterministic slots on a surface, perpendicular to the view direction.
SLOT_SPACING_M = 0.16


#: Edge margin (m) kept between a slot and the edge of its furniture top.
SLOT_MARGIN_M = 0.06


class TruthBackedAdapter(ActionVerbs, EnvAdapter):
    """Verb semantics shared by every adapter: truth, relations, failures, reasons.

    A subclass supplies geometry and perception through hooks: :meth:`_build` (reset the world),
    :meth:`_route` (the per-frame poses of a move to a floor point), :meth:`_distance` (travel
    distance for the planner), :meth:`_pixel_counts` (segmentation pixels per object, eq. 28),
    :meth:`_sync` (mirror object positions into the simulator after they change) and
    :meth:`_on_frames` (see every frame of motion, e.g. to render it).

    The practical verbs, their truth effects and failure reasons are
    :class:`~fg_tea.env.verbs.ActionVerbs`'s (:meth:`execute`).

    Randomness: one ``numpy.random.Generator`` seeded in :meth:`reset`; a state reading draws once,
    an action once for fault injection when its verb has a failure rate, an inspection once per
    would-be detection when ``config.detection_miss_rate`` is non-zero (a drop reads as a miss).
    """

    def __init__(self, scenario: Scenario, config: EnvConfig = EnvConfig()) -> None:
        if config.distance not in ("geodesic", "euclidean"):
            raise ValueError(f"EnvConfig.distance must be 'geodesic' or 'euclidean', got {config.distance!r}")
        if not 0.0 <= float(config.detection_miss_rate) <= 1.0:
            raise ValueError(f"EnvConfig.detection_miss_rate must lie in [0, 1], got "
                             f"{config.detection_miss_rate!r}")
        self.scenario = scenario
        self.config = config
        self._specs = {spec.name: spec for spec in scenario.objects}
        # Set by reset(); before it, _require_reset raises.
        self._rng: np.random.Generator
        self._truth: TeaTruth
        self._pose: Pose
        self._start: Pose | None = None  # agent pose when the current call began
        self._positions: dict[str, tuple[float, float, float]] = {}
        # Navigation targets: every viewpoint's floor point, sites' close vantages first (index k
        # of site k), then room vantages (scenario.viewpoints order).
        self._viewpoints = scenario.viewpoints
        self._target_of = {v.name: i for i, v in enumerate(self._viewpoints)}

    # --- hooks -----------------------------------------------------------------------------

    @abc.abstractmethod
    def _build(self) -> None:
        """Rebuild the world for a new episode (called by reset after truth and RNG exist)."""

    @abc.abstractmethod
    def _route(self, k: int) -> list[Pose] | None:
        """Per-frame poses from the current pose to target k's floor point; None if unreachable.

        Target k is viewpoint k of ``scenario.viewpoints`` (site k's close vantage for k < K).
        Must not change state: the caller moves the agent along the returned frames.
        """

    @abc.abstractmethod
    def _distance_from(self, goal: int, xy: Sequence[float]) -> float:
        """Planner travel distance (m) from floor point `xy` to target `goal`; inf if none."""

    def _walk_length(self, goal: int, xy: Sequence[float]) -> float:
        """Length (m) of the path :meth:`_route` would follow from `xy` to target `goal`.

        The default is :meth:`_distance_from`, exact for adapters that move in straight lines.
        """
        return self._distance_from(goal, xy)

    @abc.abstractmethod
    def _pixel_counts(self, k: int, objects: Sequence[str]) -> dict[str, int]:
        """Segmentation pixels n_o [28] of each object, looking at site k from the current pose."""

    @abc.abstractmethod
    def _expected_pixels(self, target: int, site: int, categories: Sequence[str]) -> dict[str, list[float]]:
        """Pixels an object of each category would cover standing alone at each placement slot of
        `site` (slots 0 .. :meth:`slot_count` - 1, in order), seen from target `target`'s floor
        point facing the site (house geometry only)."""

    def slot_count(self, site: str) -> int:
        """How many placement slots an object standing on `site` may occupy (>= 1).

        An object put on a site takes the site's first free slot (:meth:`_free_slot`): with m
        objects already there, one of slots 0 .. m (its arrival rank when none has left). At most
        every object stands on one site, and never more than the site's capacity, so the slots
        used are 0 .. S - 1 with S = min(number of objects, capacity). Known from the scenario
        alone (its object list and site capacities), not from where objects stand.
        """
        capacity = self.scenario.site(site).capacity
        n = len(self.scenario.objects)
        return max(1, min(n, capacity) if capacity is not None else n)

    def _sync(self) -> None:
        """Mirror `_positions` and the agent pose into the simulator (no-op without one)."""

    def _on_frames(self, frames: Sequence[Pose], start: Pose) -> None:
        """See the frames of a move or turn that started at `start` (renderers hook here)."""

    # --- EnvAdapter ------------------------------------------------------------------------

    def reset(self, seed: int) -> Pose:
        self._rng = np.random.default_rng(seed)
        self._truth = TeaTruth(self.scenario.objects)
        self._pose = Pose(float(self.scenario.start_position[0]), float(self.scenario.start_position[1]),
                          float(self.scenario.start_yaw_deg))
        self._build()
        slots, inside = start_layout(self.scenario)  # a slot for each standing object; containers
        self._truth.contained_in.update(inside)
        self._positions = {}
        for name, (site, slot) in slots.items():
            self._put(name, self._slot_position(site, slot))
        self._sync()
        return self._pose

    def agent_pose(self) -> Pose:
        self._require_reset()
        return self._pose

    def distance_to_site(self, site: str) -> float:
        self._require_reset()
        k = self._target_index(site)
        if self.config.distance == "euclidean":
            vx, vy = self._viewpoints[k].position
            return math.hypot(vx - self._pose.x, vy - self._pose.y)
        return self._distance_from(k, (self._pose.x, self._pose.y))

    def distance_between_sites(self, a: str, b: str) -> float:
        self._require_reset()
        ka, kb = self._target_index(a), self._target_index(b)
        start = self._viewpoints[ka].position
        if self.config.distance == "euclidean":
            vx, vy = self._viewpoints[kb].position
            return math.hypot(vx - start[0], vy - start[1])
        return self._distance_from(kb, start)

    def walking_distance(self, target: str, xy: Sequence[float]) -> float:
        return float(self._walk_length(self._target_index(target), xy))

    def inspect_viewpoint(self, viewpoint: str, objects: Sequence[str]) -> InspectionResult:
        self._require_reset()
        self._start = self._pose
        k = self._target_index(viewpoint)
        view = self._viewpoints[k]
        considered = tuple(dict.fromkeys(objects))
        for name in considered:
            self._spec(name)
        size = (self.config.ego_width, self.config.ego_height)
        frames, arrived = self._go_to(k)
        if not arrived:
            return InspectionResult(viewpoint, {}, {}, reachable=False, distance=self._travelled(frames),
                                    frames=len(frames), motion=motion_of(frames), image_size=size,
                                    kind=view.kind, sites=view.sites)
        in_view = [self._site_index(s) for s in view.sites]
        # Which in-view site each considered object stands at (eq. 29's association), if any.
        at_site = {name: next((j for j in in_view if self._associated(name, j)), None)
                   for name in considered}
        counts = {name: 0 for name in considered}
        for j in self._sweep_order(in_view):
            frames += self._face(self.scenario.sites[j].position)
            frames += [self._pose] * int(self.config.look_frames)  # hold still to take the image
            if view.kind == "site":
                # A close look counts every considered object in its one image, as eq. 28 reads.
                counts = self._pixel_counts(j, considered)
            else:
                here = [name for name in considered if at_site[name] == j]
                if here:
                    counts.update(self._pixel_counts(j, here))
        detections = self._detect(considered, counts, at_site)
        site_name = {name: self.scenario.sites[at].name for name in considered
                     if (at := at_site[name]) is not None}
        found_at = {name: site_name[name] for name in considered
                    if detections[name] and name in site_name}
        view_pixels = {name: {s: (int(counts[name]) if site_name.get(name) == s else 0)
                              for s in view.sites} for name in considered}
        return InspectionResult(viewpoint, detections, {n: int(counts[n]) for n in considered},
                                reachable=True, distance=self._travelled(frames), frames=len(frames),
                                motion=motion_of(frames), image_size=size, kind=view.kind,
                                sites=view.sites, found_at=found_at, view_pixels=view_pixels)

    def _sweep_order(self, sites: Sequence[int]) -> list[int]:
        """In-view sites in the order a glance faces them: each time the one needing the least turn."""
        from fg_tea.env.motion import wrap_deg

        left, order, yaw = list(sites), [], self._pose.yaw_deg
        while left:
            def turn(j: int) -> float:
                px, py, _ = self.scenario.sites[j].position
                return abs(wrap_deg(math.degrees(math.atan2(py - self._pose.y, px - self._pose.x)) - yaw))
            j = min(left, key=lambda j: (turn(j), j))
            px, py, _ = self.scenario.sites[j].position
            yaw = math.degrees(math.atan2(py - self._pose.y, px - self._pose.x))
            left.remove(j)
            order.append(j)
        return order

    def _detect(self, considered: Sequence[str], counts: Mapping[str, int],
                at_site: Mapping[str, int | None]) -> dict[str, bool]:
        """The detector's verdict per object (eqs. 29, 30), drawn from the episode's RNG.

        Threshold detector (``config.camera_curve`` None): seen iff n_o >= min_visible_pixels and
        o stands at an in-view site; then the optional injected misses, one draw per would-be
        detection in `considered` order. Visibility detector: one draw per object standing at an
        in-view site, seen with probability P(seen | n_o) of the camera's curve.
        """
        curve = self.config.camera_curve
        if curve is None:
            detections = {name: bool(counts[name] >= self.config.min_visible_pixels
                                     and (at_site[name] is not None
                                          or not self.config.site_association))
                          for name in considered}
            miss_rate = float(self.config.detection_miss_rate)
            if miss_rate > 0.0:
                # The pixel counts stay as rendered; only the detector's verdict is dropped.
                for name in considered:
                    if detections[name] and float(self._rng.random()) < miss_rate:
                        detections[name] = False
            return self._hide_unfindable(detections)
        detections = {}
        for name in considered:
            if at_site[name] is None:
                detections[name] = False
                continue
            p = curve.probability(self._specs[name].category, counts[name])
            detections[name] = bool(float(self._rng.random()) < p)
        return self._hide_unfindable(detections)

    def _hide_unfindable(self, detections: dict[str, bool]) -> dict[str, bool]:
        """``config.unfindable`` objects are never reported (after any draws, which stay as they were)."""
        for name in filter(None, (n.strip() for n in self.config.unfindable.split(","))):
            if name in detections:
                detections[name] = False
        return detections

    def expected_pixel_counts(self, categories: Sequence[str]) -> dict[str, dict[str, dict[str, list[float]]]]:
        """See :meth:`fg_tea.env.base.EnvAdapter.expected_pixel_counts` (house geometry only)."""
        self._require_reset()
        out: dict[str, dict[str, dict[str, list[float]]]] = {}
        for k, view in enumerate(self._viewpoints):
            out[view.name] = {s: self._expected_pixels(k, self._site_index(s), list(categories))
                              for s in view.sites}
        return out

    def company_pixel_counts(self, categories: Sequence[str]) -> dict[str, Any]:
        """See :meth:`fg_tea.env.base.EnvAdapter.company_pixel_counts` (house geometry only)."""
        self._require_reset()
        offsets = facing_offsets(self.config.face_tolerance_deg)
        return {"offsets_deg": offsets,
                "views": {view.name: {s: self._company_pixels(k, self._site_index(s), list(categories), offsets)
                                      for s in view.sites} for k, view in enumerate(self._viewpoints)}}

    def _company_pixels(self, target: int, site: int, cats: Sequence[str], offsets: Sequence[float]) -> dict:
        """A camera with no heading dependence or occlusion: the alone counts (PyBullet renders)."""
        return company_from_alone(self._expected_pixels(target, site, list(dict.fromkeys(cats))), cats, len(offsets))

    def observe_state(self, obj: str, state: str, site: str | None,
                      sensitivity: float, specificity: float) -> StateReading:
        self._require_reset()
        self._start = self._pose
        self._spec(obj)
        name = state if state.startswith(f"{obj}.") else f"{obj}.{state}"
        frames: list[Pose] = []
        if site is not None:
            k = self._site_index(site)
            frames, arrived = self._go_to(k)
            if not arrived:
                raise RuntimeError(f"site {site!r} became unreachable after the load-time check")
            frames += self._face(self.scenario.sites[k].position)
        frames += [self._pose] * int(self.config.look_frames)  # reading a state takes time too
        value = self._truth.read_state(name, sensitivity, specificity, self._rng)
        return StateReading(name, value, sensitivity, specificity, distance=self._travelled(frames),
                            frames=len(frames), motion=motion_of(frames))

    def truth_report(self) -> dict:
        self._require_reset()
        truth = self._truth
        report = {"states": dict(sorted(truth.states.items())), "sites": dict(sorted(truth.site_of.items())),
                  "held": truth.held, "contained_in": dict(sorted(truth.contained_in.items()))}
        if truth.uses_left:  # only a scenario with consumables has the key (older logs stay as they were)
            report["uses_left"] = dict(sorted(truth.uses_left.items()))
        return report

    def placements(self) -> Mapping[str, tuple[float, float, float]]:
        self._require_reset()
        return {name: (round(x, 4), round(y, 4), round(z, 4))
                for name, (x, y, z) in sorted(self._positions.items())}

    def move_object(self, name: str, site: str) -> None:
        """Environment-side setup: put object `name` (truth and body) on `site` at a free slot.

        For tests and counterfactual set-ups only; the agent side never calls it.
        """
        self._require_reset()
        self._spec(name)
        self._site_index(site)
        self._truth.contained_in.pop(name, None)
        if self._truth.held == name:
            self._truth.held = None
        self._truth.site_of[name] = None
        position = self._free_slot(site)
        self._truth.place(name, site)
        self._positions[name] = position
        self._sync()

    def _go_to_site(self, k: int) -> tuple[list[Pose], bool]:
        return self._go_to(k)

    def _go_to(self, k: int) -> tuple[list[Pose], bool]:
        """Walk to target k's floor point (site k's vantage for k < K); (frames, arrived)."""
        vx, vy = self._viewpoints[k].position
        if math.hypot(vx - self._pose.x, vy - self._pose.y) < 1e-9:
            return [], True
        frames = self._route(k)
        if frames is None:
            return [], False
        self._advance(frames)
        return frames, True

    def _advance(self, frames: list[Pose]) -> None:
        if frames:
            start = self._pose
            self._pose = frames[-1]
            self._carry()
            self._on_frames(frames, start)

    def _travelled(self, frames: Sequence[Pose]) -> float:
        """Path length (m) of `frames`, starting from the pose the current call began at."""
        total, prev = 0.0, self._start
        assert prev is not None, "set when the current call began"
        for pose in frames:
            total += math.hypot(pose.x - prev.x, pose.y - prev.y)
            prev = pose
        return float(total)

    def _face(self, target: Sequence[float]) -> list[Pose]:
        from fg_tea.env.motion import turn_frames

        yaw = math.degrees(math.atan2(target[1] - self._pose.y, target[0] - self._pose.x))
        frames = turn_frames(self._pose, yaw, self.config)
        self._advance(frames)
        return frames

    def _carry(self) -> None:
        """Move the held object (and its contents) to its riding position in front of the agent."""
        if self._truth.held is not None:
            self._put(self._truth.held, held_position(self._pose, self.config))

    def _put(self, obj: str, position: tuple[float, float, float]) -> None:
        """Stand `obj` at `position`, with whatever is inside it 3.5 cm above its base."""
        self._positions[obj] = position
        for inner in self._truth.contents_of(obj):
            self._positions[inner] = (position[0], position[1], position[2] + 0.035)

    def _occupants(self, site: str) -> list[str]:
        return sorted(o for o, s in self._truth.site_of.items()
                      if s == site and o not in self._truth.contained_in)

    def _free_slot(self, site: str) -> tuple[float, float, float]:
        """The first slot of `site` that no object standing there occupies."""
        occupants = self._occupants(site)
        taken = {self._positions[o][:2] for o in occupants}
        for slot in range(2 * len(occupants) + 1):
            position = self._slot_position(site, slot)
            if position[:2] not in taken:
                return position
        return self._slot_position(site, len(occupants))

    def _slot_position(self, site: str, slot: int) -> tuple[float, float, float]:
        """Deterministic stand point of the `slot`-th object on a site's surface (x, y, z in m).

        Slot 0 is the site position; further slots alternate right and left of it, perpendicular
        to the vantage's view direction, SLOT_SPACING_M apart, clipped to the furniture top.
        """
        s = self.scenario.site(site)
        px, py, pz = s.position
        dx, dy = px - s.vantage[0], py - s.vantage[1]
        norm = math.hypot(dx, dy) or 1.0
        ux, uy = -dy / norm, dx / norm
        offset = SLOT_SPACING_M * ((slot + 1) // 2) * (1 if slot % 2 else -1)
        x, y = px + ux * offset, py + uy * offset
        if s.furniture is not None:
            box = self.scenario.house.furniture_named(s.furniture)
            hx = max(box.size[0] / 2 - SLOT_MARGIN_M, 0.0)
            hy = max(box.size[1] / 2 - SLOT_MARGIN_M, 0.0)
            x = min(max(x, box.center[0] - hx), box.center[0] + hx)
            y = min(max(y, box.center[1] - hy), box.center[1] + hy)
        return (float(x), float(y), float(pz))

    def _associated(self, obj: str, k: int) -> bool:
        """Spatial association of eq. (29): the object stands within the radius of site k."""
        if not self.config.site_association:
            return True
        x, y, z = self._positions[obj]
        px, py, pz = self.scenario.sites[k].position
        return math.dist((x, y, z), (px, py, pz)) <= self.config.site_association_radius

    def _target_index(self, name: str) -> int:
        try:
            return self._target_of[name]
        except KeyError:
            raise ValueError(f"no site or viewpoint named {name!r} in scenario "
                             f"{self.scenario.name!r}") from None

    def _site_index(self, site: str) -> int:
        try:
            return self.scenario.site_index(site)
        except KeyError as exc:
            raise ValueError(str(exc.args[0])) from None

    def _spec(self, name: str) -> ObjectSpec:
        try:
            return self._specs[name]
        except KeyError:
            raise ValueError(f"no object named {name!r} in scenario {self.scenario.name!r}") from None

    def _require_reset(self) -> None:
        if not hasattr(self, "_truth"):
            raise RuntimeError("call reset(seed) before using the environment")


