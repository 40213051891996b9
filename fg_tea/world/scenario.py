"""Scenario: what is this house — geometry, semantic sites, objects, priors and hidden truth.

A scenario is a JSON file (schema version 2: site priors docs/design.md §3.1, sites §8.1, room
vantages §5; version 1 with one target object still loads). It is parsed once, at the boundary,
into frozen dataclasses; every fault is an :class:`~fg_tea.common.errors.InputError` naming the file,
the JSON path and what is wrong.

Coordinates are metres, z up. A site's ``position`` is the point on its surface where objects
stand (z = surface height); its ``vantage_position`` is the floor point from which the agent
inspects it. A site on furniture is that box's top (docs/design.md §8.1): its surface height is
the box's height (within :data:`SURFACE_TOLERANCE`). Furniture boxes stand on the floor inside its
bounds, no taller than the walls, with colour channels in [0, 1], and may touch but not overlap.
Hidden truth (``true_site``, ``hidden_state_truth``, ``consumable``) is read only by the
environment.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

from fg_tea.common.errors import InputError
from fg_tea.common.inputs import Reader, read_json
from fg_tea.world.consumables import Consumable, read_consumable

SCHEMA_VERSIONS = (1, 2)
#: Farthest a site's vantage point may stand from the site (horizontal distance, m). Chosen
#: generously, a little over three times the farthest vantage of the bundled houses (1.2 m): the
#: agent inspects a surface from where it can see objects a few centimetres across, so a vantage
#: farther than a room's width away is a typo, not a choice.
MAX_VANTAGE_DISTANCE = 4.0
#: Bernoulli task states the belief engine holds jointly in its state block (a scenario with more
#: is refused before any belief is built).
MAX_STATES = 20
#: How far (m) a site's surface height may differ from the top of its furniture. The site is the
#: furniture's top (docs/design.md §8.1), where objects are put and looked for; 1 cm absorbs
#: rounding in hand-written files, far below any object's height (the teabag's is ~2 cm).
SURFACE_TOLERANCE = 0.01
#: Overlap (m) below which two furniture footprints count as touching, not overlapping.
TOUCH_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Doorway:
    """A gap in a wall, `at` metres from the wall's start along it, `width` metres wide."""

    at: float
    width: float


@dataclass(frozen=True)
class Wall:
    """A straight wall from `start` to `end` (x, y), with doorways cut into it."""

    start: tuple[float, float]
    end: tuple[float, float]
    doorways: tuple[Doorway, ...] = ()


@dataclass(frozen=True)
class Furniture:
    """An axis-aligned box standing on the floor; its top can carry a semantic site."""

    name: str
    center: tuple[float, float]
    size: tuple[float, float, float]
    color: tuple[float, float, float, float] = (0.55, 0.42, 0.3, 1.0)

    @property
    def height(self) -> float:
        return self.size[2]


@dataclass(frozen=True)
class House:
    """The floor plan: outer bounds, walls with doorways and furniture boxes."""

    floor_min: tuple[float, float]
    floor_max: tuple[float, float]
    wall_height: float
    wall_thickness: float
    walls: tuple[Wall, ...]
    furniture: tuple[Furniture, ...]

    def furniture_named(self, name: str) -> Furniture:
        for item in self.furniture:
            if item.name == name:
                return item
        raise KeyError(name)


@dataclass(frozen=True)
class Site:
    """A semantic site: a surface where objects may be, and where to stand to inspect it.

    `affordances` maps object category -> non-negative plausibility weight a_ic (docs/design.md eq. (2)).
    """

    name: str
    room: str
    position: tuple[float, float, float]
    vantage: tuple[float, float]
    affordances: Mapping[str, float]
    capacity: int | None = None
    furniture: str | None = None


@dataclass(frozen=True)
class RoomVantage:
    """A declared floor point (a doorway or the room's centre) from which one look, a *room
    glance*, covers every site of `room` (see docs/design.md §5)."""

    name: str
    room: str
    position: tuple[float, float]


@dataclass(frozen=True)
class Viewpoint:
    """Where an inspection is made from, and which sites one look there covers.

    ``kind`` is ``"site"`` (the close vantage of one site; its name is the site's name) or
    ``"room"`` (a room glance from a :class:`RoomVantage`, covering every site of the room).
    ``sites`` are the sites in view, in scenario order.
    """

    name: str
    kind: str
    position: tuple[float, float]
    sites: tuple[str, ...]
    room: str


VIEWPOINT_KINDS = ("site", "room")


@dataclass(frozen=True)
class ObjectSpec:
    """A task object. `true_site` and `hidden_state_truth` are environment truth, never beliefs.

    `relative_to` is ``(relation, anchor)`` for an object placed ``beside`` or ``inside`` another
    (:mod:`fg_tea.world.relative`; its `true_site` is then the anchor's), else None. `consumable`
    is its count of uses and the verb that takes one (:mod:`fg_tea.world.consumables`; hidden
    truth too), else None.
    """

    name: str
    category: str
    true_site: str
    semantic_id: int
    affordances: frozenset[str]
    asset: str
    state_priors: Mapping[str, float]
    hidden_state_truth: Mapping[str, bool]
    relative_to: tuple[str, str] | None = None
    consumable: Consumable | None = None


@dataclass(frozen=True)
class Scenario:
    """A validated house and its objects (:func:`load_scenario`). Site order is the order of
    belief vectors.

    Attributes:
        name, description: from the file (``fg-tea list`` shows the description).
        sites: every site (name, room, position, vantage), in the order of belief vectors;
            ``site_names`` lists their names, ``rooms`` the rooms in order.
        objects: every object with its location prior and state priors; ``object_names``.
        house: the floor plan (walls, doorways, furniture) the simulator builds.
        start_position, start_yaw_deg: the agent's start pose.
        preparation_site: where the tea is made.
        room_vantages: the room glances' viewpoints.
        source: the file read (or the bundled name).
    """

    name: str
    schema_version: int
    description: str
    sites: tuple[Site, ...]
    objects: tuple[ObjectSpec, ...]
    house: House
    start_position: tuple[float, float]
    start_yaw_deg: float
    preparation_site: str
    source: str = ""
    room_vantages: tuple[RoomVantage, ...] = ()
    _site_index: Mapping[str, int] = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_site_index",
                           MappingProxyType({s.name: i for i, s in enumerate(self.sites)}))

    @property
    def site_names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.sites)

    @property
    def object_names(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.objects)

    @property
    def rooms(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(s.room for s in self.sites))

    @property
    def viewpoints(self) -> tuple[Viewpoint, ...]:
        """Every viewpoint: one close look per site (scenario order), then every room glance."""
        close = tuple(Viewpoint(s.name, "site", s.vantage, (s.name,), s.room) for s in self.sites)
        glances = tuple(Viewpoint(v.name, "room", v.position,
                                  tuple(s.name for s in self.sites if s.room == v.room), v.room)
                        for v in self.room_vantages)
        return close + glances

    def viewpoint(self, name: str) -> Viewpoint:
        for v in self.viewpoints:
            if v.name == name:
                return v
        raise KeyError(f"no viewpoint named {name!r} in scenario {self.name!r}")

    def site(self, name: str) -> Site:
        return self.sites[self.site_index(name)]

    def site_index(self, name: str) -> int:
        try:
            return self._site_index[name]
        except KeyError:
            raise KeyError(f"no site named {name!r} in scenario {self.name!r}") from None

    def object(self, name: str) -> ObjectSpec:
        for spec in self.objects:
            if spec.name == name:
                return spec
        raise KeyError(f"no object named {name!r} in scenario {self.name!r}")


def _frozen(mapping: dict) -> Mapping:
    return MappingProxyType(dict(mapping))


def _read_house(r: Reader) -> House:
    floor = r.child("floor")
    floor_min = floor.vector("min", 2)
    floor_max = floor.vector("max", 2)
    if not (floor_max[0] > floor_min[0] and floor_max[1] > floor_min[1]):
        raise floor.fail("max must exceed min in x and y")
    wall_height = r.positive("wall_height", 2.5)
    walls = []
    for w in r.items("walls"):
        start, end = w.vector("from", 2), w.vector("to", 2)
        length = ((end[0] - start[0]) ** 2 + (end[1] - start[1]) ** 2) ** 0.5
        if length <= 0:
            raise w.fail("wall has zero length")
        doors = []
        for d in w.items("doorways", required=False):
            at, width = d.positive("at", allow_zero=True), d.positive("width")
            if at - width / 2 < -1e-9 or at + width / 2 > length + 1e-9:
                raise d.fail(f"doorway [{at - width / 2:.2f}, {at + width / 2:.2f}] m lies outside "
                             f"the wall (length {length:.2f} m)")
            doors.append(Doorway(at, width))
        walls.append(Wall(start, end, tuple(doors)))
    furniture: list[Furniture] = []
    seen: set[str] = set()
    for f in r.items("furniture"):
        name = f.req("name", str)
        if name in seen:
            raise f.fail(f"duplicate furniture name {name!r}", "name")
        seen.add(name)
        size = f.vector("size", 3)
        if min(size) <= 0:
            raise f.fail("sizes must be positive", "size")
        raw_color = f.data.get("color") if isinstance(f.data, dict) else None
        channels = 4 if isinstance(raw_color, list) and len(raw_color) == 4 else 3
        color = f.vector("color", channels, required=False, default=(0.55, 0.42, 0.3))
        for i, c in enumerate(color):
            if not 0.0 <= c <= 1.0:
                raise InputError(f.file, f"{f.path}.color[{i}]", f"colour channel {c:g} is outside [0, 1]")
        rgba = (color[0], color[1], color[2], color[3] if len(color) == 4 else 1.0)
        center = f.vector("center", 2)
        if size[2] > wall_height:
            raise f.fail(f"{size[2]:g} m tall: taller than the walls ({wall_height:g} m)", "size")
        lo = (center[0] - size[0] / 2, center[1] - size[1] / 2)
        hi = (center[0] + size[0] / 2, center[1] + size[1] / 2)
        if lo[0] < floor_min[0] - TOUCH_TOLERANCE or lo[1] < floor_min[1] - TOUCH_TOLERANCE or \
                hi[0] > floor_max[0] + TOUCH_TOLERANCE or hi[1] > floor_max[1] + TOUCH_TOLERANCE:
            raise f.fail(f"footprint x [{lo[0]:g}, {hi[0]:g}], y [{lo[1]:g}, {hi[1]:g}] lies outside "
                         f"the floor (x [{floor_min[0]:g}, {floor_max[0]:g}], "
                         f"y [{floor_min[1]:g}, {floor_max[1]:g}])")
        item = Furniture(name, center, size, rgba)
        for other in furniture:  # boxes may touch, never overlap (docs/design.md §8.1)
            if _overlap(item, other) > TOUCH_TOLERANCE:
                raise f.fail(f"footprint overlaps furniture {other.name!r}")
        furniture.append(item)
    return House(floor_min, floor_max, wall_height, r.positive("wall_thickness", 0.1),
                 tuple(walls), tuple(furniture))


def _overlap(a: Furniture, b: Furniture) -> float:
    """The smaller of the x and y overlaps (m) of two footprints; <= 0 when they do not overlap."""
    return min(min(a.center[k] + a.size[k] / 2, b.center[k] + b.size[k] / 2)
               - max(a.center[k] - a.size[k] / 2, b.center[k] - b.size[k] / 2) for k in (0, 1))


def _read_site(s: Reader, house: House) -> Site:
    name = s.req("name", str)
    weights = s.mapping("affordances", float, required=True)
    for category, w in weights.items():
        if w < 0:
            raise InputError(s.file, f"{s.path}.affordances.{category}", f"negative weight {w}")
    capacity = s.opt("capacity", int, None)
    if capacity is not None and capacity < 1:
        raise s.fail(f"capacity must be at least 1, got {capacity}", "capacity")
    furniture = s.opt("furniture", str, None)
    position = s.vector("position", 3)
    if position[2] < 0:
        raise s.fail(f"surface height {position[2]:g} m is below the floor (z = 0)", "position")
    if position[2] > house.wall_height:
        raise s.fail(f"surface height {position[2]:g} m is above the walls ({house.wall_height:g} m)",
                     "position")
    if furniture is not None:
        try:
            box = house.furniture_named(furniture)
        except KeyError:
            raise s.fail(f"furniture {furniture!r} is referenced but not defined in house.furniture",
                         "furniture") from None
        half = (box.size[0] / 2, box.size[1] / 2)
        if abs(position[0] - box.center[0]) > half[0] + 1e-6 or abs(position[1] - box.center[1]) > half[1] + 1e-6:
            raise s.fail(f"position lies off the top of furniture {furniture!r}", "position")
        if abs(position[2] - box.height) > SURFACE_TOLERANCE:
            raise s.fail(f"surface height {position[2]:g} m is not the top of furniture {furniture!r} "
                         f"({box.height:g} m; at most {SURFACE_TOLERANCE:g} m apart)", "position")
    raw = s.req("vantage_position", list)
    full = s.vector("vantage_position", 3 if len(raw) == 3 else 2)
    vantage = (full[0], full[1])
    reach = ((vantage[0] - position[0]) ** 2 + (vantage[1] - position[1]) ** 2) ** 0.5
    if reach > MAX_VANTAGE_DISTANCE:
        raise s.fail(f"vantage is {reach:.2f} m from the site; at most {MAX_VANTAGE_DISTANCE:g} m, "
                     "or the camera cannot resolve objects on it", "vantage_position")
    room = s.req("room", str)
    if not room.strip():
        raise s.fail("a room name must not be empty", "room")
    return Site(name, room, position, vantage, _frozen(weights), capacity, furniture)


def _read_object(o: Reader, site_names: set[str]) -> ObjectSpec:
    """One object; its site is checked by :func:`fg_tea.world.relative.resolve` (with the others,
    as a placement relative to another object needs them)."""
    from fg_tea.world.relative import read_placement

    name = o.req("name", str)
    relative_to = read_placement(o)
    true_site = o.req("true_site", str) if relative_to is None else o.opt("true_site", str, "")
    affordances = o.opt("affordances", list, [])
    for i, a in enumerate(affordances):
        if not isinstance(a, str):
            raise InputError(o.file, f"{o.path}.affordances[{i}]", "expected a string")
    priors_r = o.child("state_priors", required=False)
    priors = {}
    if priors_r is not None:
        for key in priors_r.names():
            priors[key] = priors_r.probability(key)
    truth = o.mapping("hidden_state_truth", bool)
    for key in truth:
        if key not in priors:
            raise InputError(o.file, f"{o.path}.hidden_state_truth.{key}",
                             f"state {key!r} has hidden truth but no entry in state_priors")
    return ObjectSpec(
        name=name,
        category=o.opt("category", str, name),
        true_site=true_site,
        semantic_id=o.req("semantic_id", int),
        affordances=frozenset(affordances),
        asset=o.opt("asset", str, o.opt("category", str, name)),
        state_priors=_frozen(priors),
        hidden_state_truth=_frozen(truth),
        relative_to=relative_to,
        consumable=read_consumable(o),
    )


def parse_scenario(data: object, file: str | Path = "<scenario>") -> Scenario:
    """Validate a parsed scenario document and build a :class:`Scenario`.

    Raises:
        InputError: naming the file, the JSON path and the fault.
    """
    r = Reader(data, file)
    if not isinstance(data, dict):
        raise r.fail("a scenario must be a JSON object")
    version = r.req("schema_version", int)
    if version not in SCHEMA_VERSIONS:
        raise r.fail(f"unknown schema version {version} (known: {', '.join(map(str, SCHEMA_VERSIONS))})",
                     "schema_version")
    house = _read_house(r.child("house"))

    sites, names, site_readers = [], set(), []
    for s in r.items("sites"):
        site = _read_site(s, house)
        if site.name in names:
            raise s.fail(f"duplicate site name {site.name!r}", "name")
        names.add(site.name)
        sites.append(site)
        site_readers.append(s)
    if not sites:
        raise r.fail("a scenario needs at least one site", "sites")

    if version == 1:
        objects_r = [r.child("target")]
    else:
        objects_r = list(r.items("objects"))
        if not objects_r:
            raise r.fail("a scenario needs at least one object", "objects")
    objects, obj_names, ids = [], set(), set()
    for o in objects_r:
        spec = _read_object(o, names)
        if spec.name in obj_names:
            raise o.fail(f"duplicate object name {spec.name!r}", "name")
        if spec.semantic_id in ids:
            raise o.fail(f"duplicate semantic id {spec.semantic_id}", "semantic_id")
        obj_names.add(spec.name)
        ids.add(spec.semantic_id)
        objects.append(spec)
    from fg_tea.world.relative import resolve

    objects = resolve(objects, objects_r, names)

    n_states = sum(len(spec.state_priors) for spec in objects)
    if n_states > MAX_STATES:
        raise r.fail(f"the objects declare {n_states} task states; an exact belief holds at most "
                     f"{MAX_STATES}", "objects")
    for spec, o in zip(objects, objects_r):
        total = sum(site.affordances.get(spec.category, 0.0) for site in sites)
        if total <= 0:
            raise o.fail(f"every site's affordance weight for category {spec.category!r} is zero "
                         "or missing, so the location prior has no information", "category")

    room_vantages: list[RoomVantage] = []
    rooms = {site.room for site in sites}
    for v in r.items("room_vantages", required=False):
        name = v.req("name", str)
        if name in names or any(name == x.name for x in room_vantages):
            raise v.fail(f"duplicate viewpoint name {name!r} (site and room-vantage names share "
                         "one namespace)", "name")
        room = v.req("room", str)
        if room not in rooms:
            raise v.fail(f"room {room!r} has no site", "room")
        room_vantages.append(RoomVantage(name, room, v.vector("position", 2)))
    from fg_tea.world.rooms import room_fault

    misnamed = room_fault(house, sites, room_vantages)  # a site's room is the walled room it is in
    if misnamed is not None:
        raise site_readers[misnamed[0]].fail(misnamed[1], "room")

    start = r.child("start_pose")
    prep = r.opt("preparation_site", str, sites[0].name)
    if prep not in names:
        raise r.fail(f"site {prep!r} is referenced but not defined in sites", "preparation_site")
    name = r.req("name", str)
    if not name.strip():
        raise r.fail("a scenario name must not be empty", "name")
    scenario = Scenario(
        name=name,
        schema_version=version,
        description=r.opt("description", str, ""),
        sites=tuple(sites),
        objects=tuple(objects),
        house=house,
        start_position=start.vector("position", 2),
        start_yaw_deg=start.opt("yaw_deg", float, 0.0),
        preparation_site=prep,
        source=str(file),
        room_vantages=tuple(room_vantages),
    )
    r.finish()
    return scenario


def load_scenario(path: str | Path) -> Scenario:
    """Load and validate a scenario JSON file (a path, or the name of a bundled scenario)."""
    from fg_tea.common.resources import resolve_scenario

    path = resolve_scenario(path)
    return parse_scenario(read_json(path), path)


def keep_sites(doc: dict, per_room: int) -> dict:
    """A scenario document with only the first `per_room` sites of each room (the preparation
    site always kept; the furniture of the others stays, as obstacles without a site).

    For small houses of a generator's kind: ``fg-tea house --sites-per-room 2`` (a yardstick that
    must enumerate every look needs few viewpoints, docs/design.md §6.9). An object whose true
    site was dropped is moved to the kept site its category's prior rates highest, in site order
    on ties, and capacities are respected; nothing is random.

    Raises:
        ValueError: `per_room` below 1, or the kept sites cannot hold the objects.
    """
    if per_room < 1:
        raise ValueError(f"sites-per-room: expected 1 or more, got {per_room}")
    prep = doc.get("preparation_site")
    counts: dict[str, int] = {}
    kept: list[dict] = []
    for site in doc["sites"]:
        room = site["room"]
        if site["name"] == prep or counts.get(room, 0) < per_room - (1 if _holds(doc, room, prep, kept) else 0):
            kept.append(site)
            counts[room] = counts.get(room, 0) + 1
    names = [s["name"] for s in kept]
    load = {n: 0 for n in names}
    objects = []
    for obj in doc["objects"]:
        obj = dict(obj)
        if obj["true_site"] not in load:
            free = [s for s in kept if load[s["name"]] < s.get("capacity", 10 ** 9)]
            if not free:
                raise ValueError("sites-per-room: the kept sites cannot hold every object")
            obj["true_site"] = max(free, key=lambda s: s["affordances"].get(obj["category"], 0.0))["name"]
        load[obj["true_site"]] += 1
        objects.append(obj)
    import re

    text = re.sub(r"\d+ semantic sites", f"{len(kept)} semantic sites (the first {per_room} of each room)",
                  doc.get("description", ""), count=1)
    text = re.sub(r"(fg-tea house [^)]*?--seed \d+)", rf"\1 --sites-per-room {per_room}", text, count=1)
    return {**doc, "description": text, "sites": kept, "objects": objects}


def _holds(doc: dict, room: str, prep: str | None, kept: list) -> bool:
    """True when the preparation site is in `room` and not yet among `kept` (a place is saved
    for it)."""
    return any(s["name"] == prep and s["room"] == room for s in doc["sites"]) and \
        all(s["name"] != prep for s in kept)
