"""House generator: what does a plausible house of N rooms look like, with sites, priors and objects?

This module answers "give me a fresh, valid house" for experiments that must not be tuned to one
floor plan (see docs/design.md, "Scenarios"). :func:`generate_house` returns a schema-2 scenario
document (the format of ``scenarios/default_apartment.json`` plus ``room_vantages``), built from
a seed alone:

1. **Floor plan.** Rectangular rooms on a two-row grid of ceil(N / 2) columns (column widths
   3.4-4.6 m, row depths 3.4-4.4 m); with an odd room count one seeded column holds a single tall
   room spanning both rows (three rooms: two stacked rooms and a tall one). Rooms that share a wall
   are adjacent; a random spanning tree of the adjacency graph gets a 1.0 m doorway on each shared
   wall (so every room is reachable), and every other shared wall gets one with probability 0.25.
2. **Rooms.** The first room is the kitchen; the others are drawn from pantry, dining, living,
   study, bedroom and hall (each type a bounded number of times).
3. **Furniture.** Each room gets 4 or 5 pieces from its type's catalogue (the first two always:
   a kitchen always has a counter and a table), standing against a wall, never in front of a
   doorway, never overlapping. Each top is a semantic site: surface heights 0.45-1.05 m, the site
   position the centre of the top, the vantage 1.0-1.3 m straight out from it on free floor,
   clear of every wall and piece of furniture, with a clear line of sight to its site. Tops
   shorter than 1.0 m carry a capacity (1 below 0.7 m, else 2).
4. **Room vantages.** ``<room>_centre`` (the free point nearest the room centre that sees every
   site of the room past all other furniture) and, for some rooms, ``<room>_door`` (0.75 m inside
   a doorway, when it too sees every site).
5. **Check.** The floor is rasterised with :class:`~fg_tea.world.navigation.OccupancyGrid` (the
   navigator's own grid, agent radius 0.22 m, 0.05 m cells); every site vantage, room vantage and
   the start must be free and in the start's 4-connected free component (the navigator's 8-moves
   never cut corners, so this is exactly its reachability). A room that fails is refurnished with
   the next seeded attempt.
6. **Priors and objects.** Affordance weight of category c at a site = room-type weight x
   furniture-type weight x a seeded jitter in [0.8, 1.25] (a floor of 0.002 keeps every site
   possible); objects are placed by drawing from that prior, capacities respected.

Clearances (0.32 m from furniture, 0.35 m from walls for vantages; 0.1 m between pieces) are the
agent radius (0.22 m) plus one to two grid cells, chosen so a rounded point never lands in a cell
the navigator inflates. Every random stream is ``numpy.random.default_rng([seed, rooms, part,
...])``, so one seed and room count give one house, and the same bytes from :func:`house_json`.
Pure Python and numpy (scipy through the grid); no simulator import.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from typing import Any

import numpy as np

from fg_tea.world.house_parts import (
    AGENT_RADIUS, CATEGORIES, CLEAR_FURNITURE, CLEAR_WALL, DEFAULT_OBJECTS, DOOR_CLEAR_DEPTH,
    DOOR_CLEAR_SIDE, DOOR_VANTAGE_DEPTH, DOOR_WIDTH, Door, EXTRA_DOOR_P, FURNITURE_TYPES,
    GAP_PIECES, GAP_WALL, GRID, MAX_PLAN_ATTEMPTS, MAX_ROOMS, MAX_ROOM_ATTEMPTS, MIN_ROOMS,
    OBJECT_TEMPLATES, Piece, REQUIRED_OBJECTS, ROOM_DRAW, ROOM_FURNITURE, ROOM_LIMITS, ROOM_TYPES,
    ROOM_WEIGHTS, Rect, Room, SEMANTIC_IDS, VANTAGE_RANGE, WALL_HEIGHT, WALL_THICKNESS,
    snap, snapped_uniform,
)


# ---------------------------------------------------------------------------------- layout
def _layout(rooms: int, rng: np.random.Generator) -> list[Rect]:
    """Room rectangles (wall centrelines) of a two-row grid; an odd count has one tall room."""
    cols = (rooms + 1) // 2
    tall = int(rng.integers(cols)) if rooms % 2 else -1
    widths = [snapped_uniform(rng, 3.4, 4.6, 0.1) for _ in range(cols)]
    depths = [snapped_uniform(rng, 3.4, 4.4, 0.1) for _ in range(2)]
    xs = np.concatenate([[0.0], np.cumsum(widths)])
    rects = []
    for c in range(cols):
        x0, x1 = snap(float(xs[c])), snap(float(xs[c + 1]))
        if c == tall:
            rects.append(Rect(x0, 0.0, x1, snap(depths[0] + depths[1])))
        else:
            rects.append(Rect(x0, 0.0, x1, depths[0]))
            rects.append(Rect(x0, depths[0], x1, snap(depths[0] + depths[1])))
    return rects


def _shared_walls(rects: list[Rect]) -> list[Door]:
    """Every wall two rooms share (positive overlap), as a Door without a doorway yet."""
    walls = []
    for i, a in enumerate(rects):
        for j in range(i + 1, len(rects)):
            b = rects[j]
            for x in ({a.x1} & {b.x0}) | ({a.x0} & {b.x1}):
                lo, hi = max(a.y0, b.y0), min(a.y1, b.y1)
                if hi - lo > 2.0:
                    walls.append(Door(i, j, (x, lo), (x, hi)))
            for y in ({a.y1} & {b.y0}) | ({a.y0} & {b.y1}):
                lo, hi = max(a.x0, b.x0), min(a.x1, b.x1)
                if hi - lo > 2.0:
                    walls.append(Door(i, j, (lo, y), (hi, y)))
    return walls


def _doors(rects: list[Rect], rng: np.random.Generator) -> list[Door]:
    """Shared walls with doorways on a random spanning tree plus some extra doors."""
    walls = _shared_walls(rects)
    order = rng.permutation(len(walls))
    parent = list(range(len(rects)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for k in order:
        w = walls[int(k)]
        ra, rb = find(w.a), find(w.b)
        extra = float(rng.random()) < EXTRA_DOOR_P
        if ra != rb or extra:
            parent[ra] = rb
            length = math.dist(w.start, w.end)
            w.at = snapped_uniform(rng, 0.9, length - 0.9, 0.05)
    if len({find(i) for i in range(len(rects))}) != 1:
        raise RuntimeError("house generator: rooms are not connected (a bug)")
    return walls


def _room_types(rooms: int, rng: np.random.Generator) -> list[str]:
    kinds = ["kitchen"]
    used = {k: 0 for k in ROOM_LIMITS}
    for _ in range(rooms - 1):
        names = [k for k in ROOM_DRAW if used[k] < ROOM_LIMITS[k]]
        w = np.array([ROOM_DRAW[k] for k in names])
        kind = names[int(rng.choice(len(names), p=w / w.sum()))]
        used[kind] += 1
        kinds.append(kind)
    return kinds


def _room_names(kinds: list[str]) -> list[str]:
    seen: dict[str, int] = {}
    names = []
    for kind in kinds:
        seen[kind] = seen.get(kind, 0) + 1
        names.append(kind if seen[kind] == 1 else f"{kind}_{seen[kind]}")
    return names


# ---------------------------------------------------------------------------------- furnishing
def _door_zones(room: Room, index: int, doors: list[Door]) -> list[tuple[Door, Rect, tuple[float, float]]]:
    """For each doorway of the room: the door, the strip kept free of furniture, the inward normal."""
    zones = []
    c = room.rect.center
    for d in doors:
        if d.at is None or index not in (d.a, d.b):
            continue
        px, py = d.point
        half = DOOR_WIDTH / 2 + DOOR_CLEAR_SIDE
        if d.start[0] == d.end[0]:  # vertical wall
            n = (1.0 if c[0] > px else -1.0, 0.0)
            x_in = px + n[0] * DOOR_CLEAR_DEPTH
            zones.append((d, Rect(min(px, x_in), py - half, max(px, x_in), py + half), n))
        else:
            n = (0.0, 1.0 if c[1] > py else -1.0)
            y_in = py + n[1] * DOOR_CLEAR_DEPTH
            zones.append((d, Rect(px - half, min(py, y_in), px + half, max(py, y_in)), n))
    return zones


def _clear(p: tuple[float, float], inner: Rect, boxes: list[Rect]) -> bool:
    """Whether a vantage at `p` keeps its clearance from the room's walls and every box."""
    if min(p[0] - inner.x0, inner.x1 - p[0], p[1] - inner.y0, inner.y1 - p[1]) < CLEAR_WALL:
        return False
    return all(b.distance(p) >= CLEAR_FURNITURE for b in boxes)


def _sees(p: tuple[float, float], piece: Piece, others: list[Piece]) -> bool:
    """Whether the sight line from `p` to the piece's site passes no other piece."""
    target = piece.center
    return not any(o is not piece and o.rect.grown(0.02).crosses(p, target) for o in others)


def _place_piece(room: Room, label: str, kind: str, zones: list[Rect], rng: np.random.Generator,
                 tries: int = 40) -> Piece | None:
    spec = FURNITURE_TYPES[kind]
    inner = room.inner
    for _ in range(tries):
        length = snapped_uniform(rng, *spec.length, 0.05)
        depth = snapped_uniform(rng, *spec.depth, 0.05)
        height = snapped_uniform(rng, *spec.height, 0.01)
        side = int(rng.integers(4))  # 0: south wall, 1: north, 2: west, 3: east
        along = (inner.x0, inner.x1) if side < 2 else (inner.y0, inner.y1)
        lo, hi = along[0] + 0.05 + length / 2, along[1] - 0.05 - length / 2
        if hi < lo:
            continue
        c = snapped_uniform(rng, lo, hi, 0.05)
        dist = snapped_uniform(rng, *VANTAGE_RANGE, 0.05)
        if side == 0:
            y0 = inner.y0 + GAP_WALL
            rect, normal = Rect(c - length / 2, y0, c + length / 2, y0 + depth), (0.0, 1.0)
        elif side == 1:
            y1 = inner.y1 - GAP_WALL
            rect, normal = Rect(c - length / 2, y1 - depth, c + length / 2, y1), (0.0, -1.0)
        elif side == 2:
            x0 = inner.x0 + GAP_WALL
            rect, normal = Rect(x0, c - length / 2, x0 + depth, c + length / 2), (1.0, 0.0)
        else:
            x1 = inner.x1 - GAP_WALL
            rect, normal = Rect(x1 - depth, c - length / 2, x1, c + length / 2), (-1.0, 0.0)
        cx, cy = snap(rect.center[0]), snap(rect.center[1])
        sx, sy = snap(rect.x1 - rect.x0), snap(rect.y1 - rect.y0)
        rect = Rect(cx - sx / 2, cy - sy / 2, cx + sx / 2, cy + sy / 2)
        vantage = (snap(cx + normal[0] * dist), snap(cy + normal[1] * dist))
        if any(rect.overlaps(p.rect, GAP_PIECES) for p in room.pieces):
            continue
        if any(rect.overlaps(z) for z in zones):
            continue
        boxes = [p.rect for p in room.pieces] + [rect]
        if not _clear(vantage, inner, boxes):
            continue
        if any(rect.distance(p.vantage) < CLEAR_FURNITURE for p in room.pieces):
            continue
        capacity = None if length >= 1.0 else (1 if length < 0.7 else 2)
        piece = Piece("", kind, rect, (cx, cy), (sx, sy), height, vantage, capacity)
        everyone = room.pieces + [piece]
        if not _sees(vantage, piece, everyone) or not all(_sees(p.vantage, p, everyone) for p in room.pieces):
            continue
        piece.name = label
        return piece
    return None


def _room_vantages(room: Room, zones: list[tuple[Door, Rect, tuple[float, float]]],
                   rng: np.random.Generator) -> list[tuple[str, tuple[float, float]]]:
    """``<room>_centre`` near the centre and maybe ``<room>_door``; each sees every site."""
    inner, boxes = room.inner, [p.rect for p in room.pieces]

    def ok(p: tuple[float, float]) -> bool:
        return _clear(p, inner, boxes) and all(_sees(p, piece, room.pieces) for piece in room.pieces)

    out = []
    cx, cy = room.rect.center
    offsets = sorted(((dx, dy) for dx in np.arange(-1.2, 1.21, 0.1) for dy in np.arange(-1.2, 1.21, 0.1)),
                     key=lambda o: (round(math.hypot(*o), 6), round(o[0], 3), round(o[1], 3)))
    for dx, dy in offsets:
        p = (snap(cx + dx), snap(cy + dy))
        if ok(p):
            out.append((f"{room.name}_centre", p))
            break
    door_p = None
    if zones:
        d, _, n = zones[int(rng.integers(len(zones)))]
        px, py = d.point
        p = (snap(px + n[0] * DOOR_VANTAGE_DEPTH), snap(py + n[1] * DOOR_VANTAGE_DEPTH))
        if ok(p):
            door_p = p
    want_door = float(rng.random()) < 0.5
    if door_p is not None and (want_door or not out):
        out.append((f"{room.name}_door", door_p))
    return out


def _furnish(room: Room, index: int, doors: list[Door], rng: np.random.Generator) -> bool:
    """Place the room's furniture and vantages; False if a required part did not fit."""
    room.pieces, room.vantages = [], []
    zones = _door_zones(room, index, doors)
    zone_rects = [z for _, z, _ in zones]
    required, extras = ROOM_FURNITURE[room.kind]
    n = 4 + int(rng.random() < 0.5)
    chosen = list(required) + [extras[int(i)] for i in rng.permutation(len(extras))][: n - len(required)]
    labels: dict[str, int] = {}
    for label, kind in chosen:
        piece = _place_piece(room, label, kind, zone_rects, rng)
        if piece is None:
            if (label, kind) in required:
                return False
            continue
        labels[label] = labels.get(label, 0) + 1
        piece.name = f"{room.name}_{label}" + ("" if labels[label] == 1 else f"_{labels[label]}")
        room.pieces.append(piece)
    if len(room.pieces) < 3:
        return False
    room.vantages = _room_vantages(room, zones, rng)
    return bool(room.vantages)


# ---------------------------------------------------------------------------------- document
def _affordances(room: Room, piece: Piece, rng: np.random.Generator) -> dict[str, float]:
    jitter = rng.uniform(0.8, 1.25, size=len(CATEGORIES))
    w = np.array(ROOM_WEIGHTS[room.kind]) * np.array(FURNITURE_TYPES[piece.kind].weights) * jitter
    return {c: round(max(float(v), 0.002), 3) for c, v in zip(CATEGORIES, w)}


def _house_doc(rooms: list[Room], rects: list[Rect], doors: list[Door]) -> dict:
    width = max(r.x1 for r in rects)
    depth = max(r.y1 for r in rects)
    corners = [(0.0, 0.0), (width, 0.0), (width, depth), (0.0, depth)]
    walls = [{"from": list(corners[i]), "to": list(corners[(i + 1) % 4])} for i in range(4)]
    for d in doors:
        wall: dict = {"from": [d.start[0], d.start[1]], "to": [d.end[0], d.end[1]]}
        if d.at is not None:
            wall["doorways"] = [{"at": d.at, "width": DOOR_WIDTH}]
        walls.append(wall)
    furniture = []
    for room in rooms:
        for p in room.pieces:
            color = [*FURNITURE_TYPES[p.kind].color, 1]
            furniture.append({"name": p.name, "center": list(p.center), "size": [*p.size, p.height],
                              "color": color})
    return {"floor": {"min": [0, 0], "max": [width, depth]}, "wall_height": WALL_HEIGHT,
            "wall_thickness": WALL_THICKNESS, "walls": walls, "furniture": furniture}


def _unreachable_rooms(doc: dict, rooms: list[Room]) -> set[int]:
    """Rooms with a site vantage, room vantage or the start off the free floor or unreachable."""
    from scipy import ndimage

    from fg_tea.world.navigation import OccupancyGrid
    from fg_tea.world.scenario import parse_scenario

    scenario = parse_scenario(doc, "<generated house>")
    grid = OccupancyGrid(scenario.house, GRID, AGENT_RADIUS)
    labels, _ = ndimage.label(grid.free)  # 4-connected: the navigator never cuts a corner
    start = doc["start_pose"]["position"]
    r, c = grid.cell(start)
    home = labels[r, c] if grid.inside(r, c) else 0
    bad = set()
    for i, room in enumerate(rooms):
        points = [p.vantage for p in room.pieces] + [v for _, v in room.vantages]
        for p in points:
            r, c = grid.cell(p)
            if not (grid.inside(r, c) and grid.free[r, c] and home and labels[r, c] == home):
                bad.add(i)
    return bad


def check_arguments(rooms: object, seed: object, objects: object) -> tuple[str, ...]:
    """Validate generator arguments; return the object names in canonical order.

    Raises:
        ValueError: naming the argument and the fault (callers wrap it in an InputError).
    """
    if isinstance(rooms, bool) or not isinstance(rooms, (int, np.integer)) or not MIN_ROOMS <= rooms <= MAX_ROOMS:
        raise ValueError(f"rooms: expected an integer from {MIN_ROOMS} to {MAX_ROOMS}, got {rooms!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed: expected a non-negative integer, got {seed!r}")
    if not isinstance(objects, Iterable):
        raise ValueError(f"objects: expected a list of names, got {objects!r}")
    names = list(objects)
    for name in names:
        if name not in CATEGORIES:
            raise ValueError(f"objects: unknown object {name!r} (known: {', '.join(CATEGORIES)})")
    if len(set(names)) != len(names):
        raise ValueError(f"objects: duplicate names in {names}")
    missing = [o for o in REQUIRED_OBJECTS if o not in names]
    if missing:
        raise ValueError(f"objects: the tea task needs {', '.join(missing)}")
    return tuple(c for c in CATEGORIES if c in names)


def generate_house(rooms: int, seed: int, objects=DEFAULT_OBJECTS, name: str | None = None) -> dict:
    """A schema-2 scenario document of a fresh house (see the module docstring).

    Args:
        rooms: number of rooms, 3-10; the first is the kitchen.
        seed: non-negative seed; with `rooms` it fixes the whole house.
        objects: object names among mug, kettle, teabag, milk, sugar (mug, kettle and teabag
            are required); the floor plan, furniture and priors do not depend on them.
        name: the scenario name (default ``generated_<rooms>r_seed<seed>``).

    Returns:
        A JSON-ready dict that :func:`fg_tea.world.scenario.parse_scenario` accepts and whose every
        vantage is free and reachable from the start on the navigator's grid.

    Raises:
        ValueError: bad arguments.
    """
    names = check_arguments(rooms, seed, objects)
    rooms, seed = int(rooms), int(seed)
    failures = []
    for plan in range(MAX_PLAN_ATTEMPTS):
        doc, why = _attempt_house(rooms, seed, plan, names, name)
        if doc is not None:
            return doc
        failures.append(why)
    raise RuntimeError(f"house generator: seed {seed} with {rooms} rooms gave no usable floor plan "
                       f"in {MAX_PLAN_ATTEMPTS} attempts (last: {failures[-1]})")


def _attempt_house(rooms: int, seed: int, plan: int, names: tuple[str, ...],
                   name: str | None) -> tuple[dict | None, str]:
    """One floor plan of the house: its document, or None and why a room could not be furnished
    or reached. Plan 0 draws from the streams every earlier house was drawn from (so those houses
    keep their bytes); plan k > 0 from streams that also carry k."""
    tail = [plan] if plan else []
    rng = np.random.default_rng([seed, rooms, 0] + tail)
    rects = _layout(rooms, rng)
    kitchen = int(rng.integers(len(rects)))
    rects = [rects[kitchen]] + rects[:kitchen] + rects[kitchen + 1:]
    doors = _doors(rects, rng)
    kinds = _room_types(rooms, rng)
    house = [Room(n, k, r) for n, k, r in zip(_room_names(kinds), kinds, rects)]
    start_room = 1 + int(rng.integers(rooms - 1))
    yaw = float(rng.choice([0.0, 90.0, 180.0, 270.0]))

    attempts = [0] * rooms
    todo = set(range(rooms))
    while True:
        for i in sorted(todo):
            while not _furnish(house[i], i, doors,
                               np.random.default_rng([seed, rooms, 1, i, attempts[i]] + tail)):
                attempts[i] += 1
                if attempts[i] >= MAX_ROOM_ATTEMPTS:
                    return None, (f"room {house[i].name!r} could not be furnished in "
                                  f"{MAX_ROOM_ATTEMPTS} attempts")
        start = house[start_room].vantages[0][1]
        doc = _document(house, rects, doors, names, seed, rooms, name, start, yaw)
        todo = _unreachable_rooms(doc, house)
        if not todo:
            return doc, ""
        for i in todo:
            attempts[i] += 1
            if attempts[i] >= MAX_ROOM_ATTEMPTS:
                return None, (f"room {house[i].name!r} has unreachable vantages after "
                              f"{MAX_ROOM_ATTEMPTS} attempts")


def _document(house: list[Room], rects: list[Rect], doors: list[Door], names: tuple[str, ...], seed: int,
              rooms: int, name: str | None, start: tuple[float, float], yaw: float) -> dict:
    aff_rng = np.random.default_rng([seed, rooms, 2])
    sites: list[dict[str, Any]] = []
    for room in house:
        for p in room.pieces:
            site: dict[str, Any] = {"name": p.name, "room": room.name, "furniture": p.name, "position": list(p.site),
                    "vantage_position": [p.vantage[0], p.vantage[1], 0.0],
                    "affordances": _affordances(room, p, aff_rng)}
            if p.capacity is not None:
                site["capacity"] = p.capacity
            sites.append(site)
    room_vantages = [{"name": n, "room": room.name, "position": list(v)} for room in house for n, v in room.vantages]
    dining = [p.name for r in house if r.kind == "dining" for p in r.pieces if p.kind == "dining_table"]
    prep = dining[0] if dining else next(p.name for p in house[0].pieces if p.kind == "kitchen_table")

    obj_rng = np.random.default_rng([seed, rooms, 4])
    load = {s["name"]: 0 for s in sites}
    objects = []
    for obj in names:
        template = OBJECT_TEMPLATES[obj]
        w = np.array([s["affordances"][obj] if load[s["name"]] < s.get("capacity", 10 ** 9) else 0.0
                      for s in sites])
        site = sites[int(obj_rng.choice(len(sites), p=w / w.sum()))]["name"]
        load[site] += 1
        entry = {"name": obj, "category": obj, "true_site": site, "semantic_id": SEMANTIC_IDS[obj],
                 "asset": template["asset"], "affordances": list(template["affordances"])}
        if template["state_priors"]:
            entry["state_priors"] = dict(template["state_priors"])
            entry["hidden_state_truth"] = {k: False for k in template["state_priors"]}
        objects.append(entry)

    kinds = ", ".join(r.name for r in house)
    label = name or f"generated_{rooms}r_seed{seed}"
    command = f"fg-tea house --rooms {rooms} --seed {seed}"
    if names != DEFAULT_OBJECTS:
        command += f" --objects {','.join(names)}"
    if name:
        command += f" --name {name}"
    description = (f"Generated house ({command}): {rooms} rooms ({kinds}), "
                   f"{len(sites)} semantic sites, {len(room_vantages)} room vantages. Objects placed "
                   f"from the house's own affordance priors; the kettle is empty.")
    return {
        "schema_version": 2,
        "name": label,
        "description": description,
        "preparation_site": prep,
        "start_pose": {"position": list(start), "yaw_deg": yaw},
        "house": _house_doc(house, rects, doors),
        "sites": sites,
        "room_vantages": room_vantages,
        "objects": objects,
    }


def house_json(doc: dict) -> str:
    """The document as text: fixed key order, one-space indent, trailing newline."""
    return json.dumps(doc, indent=1) + "\n"


def write_house(path, rooms: int, seed: int, objects=DEFAULT_OBJECTS, name: str | None = None) -> dict:
    """Generate a house and write it to `path` atomically; return the document."""
    from fg_tea.common.files import atomic_write_text

    doc = generate_house(rooms, seed, objects, name)
    atomic_write_text(path, house_json(doc))
    return doc


__all__ = ["generate_house", "house_json", "write_house", "check_arguments", "CATEGORIES",
           "DEFAULT_OBJECTS", "ROOM_TYPES", "MIN_ROOMS", "MAX_ROOMS"]
