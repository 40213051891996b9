"""Does each site's ``room`` name the room it stands in? (docs/design.md §8.1)

A house's walls enclose its rooms: the parts of the floor that are apart once every doorway is
closed. A site's ``room`` is the name of the room the site stands in, so in a house whose walls
enclose two or more rooms holding sites,

- the sites of one walled room all give it the same name (one room, one name), and
- the sites that give a name all stand in one walled room (one name, one room).

A name that breaks either rule names no room of the house: a typo (``"kitchn"``), a room that is
not there (``"garage"``), or another room's name. The room decides what a room glance covers and
which factors are same-room ones (docs/design.md §5, §4), so it is refused when the scenario is
read. A house without walls, or whose sites all stand in one walled space, has one floor: its
room names are labels only, and any are accepted.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

#: Grid spacing (m) on which the walls are drawn to find the rooms. Walls are drawn half a cell
#: thicker than they are, so a wall of any thickness is closed on the grid.
RESOLUTION = 0.1


def _rooms_grid(house) -> tuple[np.ndarray, tuple[float, float]]:
    """The walled rooms of `house` as a label grid (0 on walls and outside), and its origin.

    Each wall is drawn whole, doorways closed: every cell whose centre is within half the wall's
    thickness, plus half a cell, of the segment from the wall's start to its end.
    """
    from scipy import ndimage

    x0, y0 = house.floor_min
    cols = max(1, int(np.ceil((house.floor_max[0] - x0) / RESOLUTION - 1e-9)))
    rows = max(1, int(np.ceil((house.floor_max[1] - y0) / RESOLUTION - 1e-9)))
    gx, gy = np.meshgrid(x0 + (np.arange(cols) + 0.5) * RESOLUTION,
                         y0 + (np.arange(rows) + 0.5) * RESOLUTION)
    reach = house.wall_thickness / 2 + RESOLUTION / 2
    wall = np.zeros(gx.shape, dtype=bool)
    for w in house.walls:
        (ax, ay), (bx, by) = w.start, w.end
        dx, dy = bx - ax, by - ay
        along = np.clip(((gx - ax) * dx + (gy - ay) * dy) / max(dx * dx + dy * dy, 1e-12), 0.0, 1.0)
        wall |= np.hypot(gx - (ax + along * dx), gy - (ay + along * dy)) <= reach
    labels, _ = ndimage.label(~wall)  # 4-connected: a wall drawn on the grid is never crossed
    return labels, (float(x0), float(y0))


def _room_at(labels: np.ndarray, origin: tuple[float, float], xy: Sequence[float]) -> int:
    col = int(np.floor((xy[0] - origin[0]) / RESOLUTION))
    row = int(np.floor((xy[1] - origin[1]) / RESOLUTION))
    if 0 <= row < labels.shape[0] and 0 <= col < labels.shape[1]:
        return int(labels[row, col])
    return 0


def room_fault(house, sites, vantages=()) -> tuple[int, str] | None:
    """The first site whose ``room`` names no walled room of `house`, and why; None if none.

    Args:
        house: the scenario's :class:`~fg_tea.world.scenario.House`.
        sites: its :class:`~fg_tea.world.scenario.Site` list, in file order.
        vantages: its :class:`~fg_tea.world.scenario.RoomVantage` list. A room vantage that stands
            in a walled room settles which of two names the room's sites give is its name, when
            both are given by as many sites.

    Returns:
        (index of the site in `sites`, the fault) or None. A site is placed by its surface
        position, or by its vantage point when the position lies on a wall; a site whose both
        points lie on walls is not placed (the navigation checks refuse a vantage on a wall).
    """
    if not house.walls or len(sites) < 2:
        return None
    labels, origin = _rooms_grid(house)
    where: dict[int, int] = {}
    for i, site in enumerate(sites):
        room = _room_at(labels, origin, site.position[:2]) or _room_at(labels, origin, site.vantage)
        if room:
            where[i] = room
    if len(set(where.values())) < 2:  # one floor: names are labels only
        return None
    glanced = {(v.room, _room_at(labels, origin, v.position)) for v in vantages}
    by_room: dict[int, list[int]] = {}
    for i, room in where.items():
        by_room.setdefault(room, []).append(i)
    for room, members in sorted(by_room.items(), key=lambda kv: kv[1][0]):  # one room, one name
        here: dict[str, list[int]] = {}
        for i in members:
            here.setdefault(sites[i].room, []).append(i)
        if len(here) < 2:
            continue

        def weight(name: str) -> tuple[int, bool, int]:
            elsewhere = sum(1 for i, r in where.items() if sites[i].room == name and r != room)
            return len(here[name]), (name, room) in glanced, -elsewhere

        ranked = sorted(here, key=lambda n: (weight(n), -here[n][0]), reverse=True)
        name, odd = ranked[0], ranked[-1]
        i = here[odd][-1]
        sites_of = ", ".join(repr(sites[j].name) for j in here[name][:3]) + \
            (", ..." if len(here[name]) > 3 else "")
        if weight(name) == weight(odd):
            return i, (f"room {odd!r} and room {name!r} are one walled room: site "
                       f"{sites[i].name!r} and {sites_of} stand in it; give a room one name")
        used = any(sites[j].room == odd and r != room for j, r in where.items())
        what = (f"room {odd!r} is not the room the site stands in" if used
                else f"room {odd!r} names no room of the house")
        return i, (f"{what}: the site stands in the room of {sites_of} (named {name!r}); the "
                   "walls enclose each room, and the sites of one room give it one name")
    by_name: dict[str, list[int]] = {}
    for i in where:
        by_name.setdefault(sites[i].room, []).append(i)
    for name, members in by_name.items():  # one name, one room
        rooms = [where[i] for i in members]
        if len(set(rooms)) > 1:  # the site blamed is the first outside the room most of them are in
            most = max(rooms, key=lambda r: (rooms.count(r), -rooms.index(r)))
            first = next(j for j in members if where[j] == most)
            i = next(j for j in members if where[j] != most)
            return i, (f"room {name!r} names two walled rooms: site {sites[first].name!r} stands "
                       "in another room than this site, with walls between; give each room its "
                       "own name")
    return None


__all__ = ["RESOLUTION", "room_fault"]
