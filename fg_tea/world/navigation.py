"""Navigation: where can the agent go, how far is each site, and which poses does it pass through?

This module answers the travel-cost question of the planner (docs/design.md §8.2; the distance
d_j of eq. (12)) without any simulator (the poses of each frame along a path are :mod:`fg_tea.env.motion`'s):

1. an occupancy grid of the floor plan (walls with doorway gaps, furniture boxes, everything
   outside the floor bounds blocked), inflated by the agent radius;
2. 8-connected Dijkstra distance fields from every site's vantage cell, computed once per reset
   with ``scipy.sparse.csgraph``, so a geodesic distance query is a table lookup (diagonal steps
   may not cut the corner of a blocked cell);
3. shortest paths by following the Dijkstra predecessors, then string-pulling them to corner
   points with an exact line-of-sight test over the grid cells a segment crosses;
4. a load-time check that each vantage lies on free floor and is reachable from the start, which
   raises :class:`~fg_tea.common.errors.InputError` naming the site and the nearest usable free cell.

Geodesic grid distance is never shorter than the Euclidean distance (an 8-connected path is at
least as long as the straight line); Euclidean distance is kept as the ablation
``EnvConfig.distance == "euclidean"`` in the adapters. Pure numpy/scipy: no simulator import.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, Sequence

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from fg_tea.common.errors import InputError
from fg_tea.world.scenario import House, Scenario

Point = tuple[float, float]


class GridConfig(Protocol):
    """What the grid needs of the embodiment (:class:`fg_tea.env.base.EnvConfig` has both)."""

    @property
    def grid_resolution(self) -> float: ...  # m per grid cell

    @property
    def agent_radius(self) -> float: ...  # m, the inflation of every obstacle


@dataclass(frozen=True)
class Box2D:
    """An oriented rectangle on the floor: centre (m), half extents (m) and the unit long axis."""

    center: Point
    half: Point
    axis: Point

    def distance(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Euclidean distance (m) from points (x, y) to the rectangle; 0 inside it."""
        dx, dy = x - self.center[0], y - self.center[1]
        u = dx * self.axis[0] + dy * self.axis[1]
        v = -dx * self.axis[1] + dy * self.axis[0]
        return np.hypot(np.maximum(np.abs(u) - self.half[0], 0.0), np.maximum(np.abs(v) - self.half[1], 0.0))


def wall_boxes(house: House) -> list[Box2D]:
    """The solid pieces of every wall, doorway gaps cut out, as oriented rectangles.

    A wall's pieces extend half a thickness past the wall's own ends so corners close, but not
    into its doorways.
    """
    boxes = []
    t = house.wall_thickness
    for wall in house.walls:
        (x0, y0), (x1, y1) = wall.start, wall.end
        length = math.hypot(x1 - x0, y1 - y0)
        ux, uy = (x1 - x0) / length, (y1 - y0) / length
        cuts = sorted((d.at - d.width / 2, d.at + d.width / 2) for d in wall.doorways)
        pieces, s = [], -t / 2
        for a, b in cuts:
            if a > s:
                pieces.append((s, a))
            s = max(s, b)
        if length + t / 2 > s:
            pieces.append((s, length + t / 2))
        for a, b in pieces:
            mid = (a + b) / 2
            boxes.append(Box2D((x0 + ux * mid, y0 + uy * mid), ((b - a) / 2, t / 2), (ux, uy)))
    return boxes


def furniture_boxes(house: House) -> list[Box2D]:
    """Every furniture footprint as an axis-aligned rectangle."""
    return [Box2D(f.center, (f.size[0] / 2, f.size[1] / 2), (1.0, 0.0)) for f in house.furniture]


class OccupancyGrid:
    """A floor-plan grid: cell (row, col) has centre (x0 + (col + 0.5) r, y0 + (row + 0.5) r).

    Attributes:
        free: bool (rows, cols); True where the agent's centre may be (obstacles inflated by the
            agent radius).
        blocked: bool (rows, cols); True where a cell centre lies inside a wall or furniture box
            (not inflated).
        walls: bool (rows, cols); like `blocked`, walls only (used to keep cameras inside rooms).
    """

    def __init__(self, house: House, resolution: float, agent_radius: float) -> None:
        if resolution <= 0:
            raise ValueError(f"grid resolution must be positive, got {resolution}")
        self.house = house
        self.resolution = float(resolution)
        self.agent_radius = float(agent_radius)
        self.origin = (float(house.floor_min[0]), float(house.floor_min[1]))
        span_x = house.floor_max[0] - house.floor_min[0]
        span_y = house.floor_max[1] - house.floor_min[1]
        self.cols = int(math.ceil(span_x / resolution - 1e-9))
        self.rows = int(math.ceil(span_y / resolution - 1e-9))
        xs = self.origin[0] + (np.arange(self.cols) + 0.5) * resolution
        ys = self.origin[1] + (np.arange(self.rows) + 0.5) * resolution
        gx, gy = np.meshgrid(xs, ys)
        walls_d = np.full(gx.shape, np.inf)
        for box in wall_boxes(house):
            walls_d = np.minimum(walls_d, box.distance(gx, gy))
        furn_d = np.full(gx.shape, np.inf)
        for box in furniture_boxes(house):
            furn_d = np.minimum(furn_d, box.distance(gx, gy))
        # distance to the floor boundary (everything outside the floor bounds is blocked)
        edge_d = np.minimum.reduce([gx - house.floor_min[0], house.floor_max[0] - gx,
                                    gy - house.floor_min[1], house.floor_max[1] - gy])
        self.walls = walls_d <= 0.0
        self.blocked = self.walls | (furn_d <= 0.0)
        self.free = (walls_d >= agent_radius) & (furn_d >= agent_radius) & (edge_d >= agent_radius)

    # --- coordinates -----------------------------------------------------------------------

    def cell(self, xy: Sequence[float]) -> tuple[int, int]:
        """(row, col) of the cell containing floor point `xy` (may lie outside the grid)."""
        return (int(math.floor((xy[1] - self.origin[1]) / self.resolution)),
                int(math.floor((xy[0] - self.origin[0]) / self.resolution)))

    def center(self, row: int, col: int) -> Point:
        """Floor point (m) at the centre of cell (row, col)."""
        return (self.origin[0] + (col + 0.5) * self.resolution, self.origin[1] + (row + 0.5) * self.resolution)

    def inside(self, row: int, col: int) -> bool:
        return 0 <= row < self.rows and 0 <= col < self.cols

    def is_free(self, xy: Sequence[float]) -> bool:
        """Whether the agent's centre may stand at floor point `xy`."""
        r, c = self.cell(xy)
        return self.inside(r, c) and bool(self.free[r, c])

    def nearest(self, xy: Sequence[float], mask: np.ndarray) -> Point | None:
        """Centre of the `mask` cell nearest to `xy`, or None if `mask` is empty."""
        rows, cols = np.nonzero(mask)
        if rows.size == 0:
            return None
        cx = self.origin[0] + (cols + 0.5) * self.resolution
        cy = self.origin[1] + (rows + 0.5) * self.resolution
        i = int(np.argmin((cx - xy[0]) ** 2 + (cy - xy[1]) ** 2))
        return (float(cx[i]), float(cy[i]))

    # --- segments --------------------------------------------------------------------------

    def segment_cells(self, a: Sequence[float], b: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """Every cell the segment a-b passes through, in order (exact grid traversal).

        Returns:
            (rows, cols), int arrays; cells outside the grid are included as they are.
        """
        ax, ay = (a[0] - self.origin[0]) / self.resolution, (a[1] - self.origin[1]) / self.resolution
        bx, by = (b[0] - self.origin[0]) / self.resolution, (b[1] - self.origin[1]) / self.resolution
        ts = [np.array([0.0, 1.0])]
        for p, q in ((ax, bx), (ay, by)):
            if abs(q - p) > 1e-12:
                lines = np.arange(math.floor(min(p, q)) + 1, math.ceil(max(p, q)))
                ts.append((lines - p) / (q - p))
        t = np.unique(np.concatenate(ts))
        mid = (t[:-1] + t[1:]) / 2 if t.size > 1 else np.array([0.0])
        cols = np.floor(ax + mid * (bx - ax)).astype(np.int64)
        rows = np.floor(ay + mid * (by - ay)).astype(np.int64)
        return rows, cols

    def segment_free(self, a: Sequence[float], b: Sequence[float], mask: np.ndarray | None = None) -> bool:
        """Whether every cell the segment a-b crosses is set in `mask` (default: `free`)."""
        mask = self.free if mask is None else mask
        rows, cols = self.segment_cells(a, b)
        ok = (rows >= 0) & (rows < self.rows) & (cols >= 0) & (cols < self.cols)
        return bool(ok.all() and mask[rows, cols].all())

    def clear_fraction(self, a: Sequence[float], b: Sequence[float], mask: np.ndarray) -> float:
        """Fraction in [0, 1] of the segment a-b walked before the first `mask` cell (1: none hit)."""
        rows, cols = self.segment_cells(a, b)
        inside = (rows >= 0) & (rows < self.rows) & (cols >= 0) & (cols < self.cols)
        hit = ~inside
        hit[inside] = mask[rows[inside], cols[inside]]
        if not hit.any():
            return 1.0
        first = int(np.argmax(hit))
        r, c = int(rows[first]), int(cols[first])
        cx, cy = self.center(r, c)
        length = math.hypot(b[0] - a[0], b[1] - a[1]) or 1.0
        return max(0.0, min(1.0, (math.hypot(cx - a[0], cy - a[1]) - self.resolution) / length))


class Navigator:
    """Validated grid, distance fields and paths for one scenario (built once per reset).

    Args:
        scenario: the house and its sites.
        config: uses ``grid_resolution`` (m) and ``agent_radius`` (m).

    Raises:
        InputError: the start or a vantage point is not on free floor, or a vantage point is not
            reachable from the start; the message names the nearest usable free cell.
    """

    def __init__(self, scenario: Scenario, config: GridConfig) -> None:
        self.scenario = scenario
        self.grid = grid = OccupancyGrid(scenario.house, config.grid_resolution, config.agent_radius)
        self._node = np.full((grid.rows, grid.cols), -1, dtype=np.int64)
        free_r, free_c = np.nonzero(grid.free)
        self._node[free_r, free_c] = np.arange(free_r.size)
        self._node_rc = np.stack([free_r, free_c], axis=1)
        graph = self._graph()

        source = scenario.source or "<scenario>"
        start = scenario.start_position
        if not grid.is_free(start):
            near = grid.nearest(start, grid.free)
            raise InputError(source, "$.start_pose.position",
                             f"start ({start[0]:.2f}, {start[1]:.2f}) is not on free floor "
                             f"(inside a wall or furniture, or within the agent radius "
                             f"{grid.agent_radius:.2f} m of one); nearest free cell at {_fmt(near)}")
        # Targets: every viewpoint's floor point, site vantages first (target k = site k), then
        # the room vantages.
        self.vantages: list[Point] = [(float(v.position[0]), float(v.position[1]))
                                      for v in scenario.viewpoints]
        wheres = ([f"$.sites[{i}].vantage_position" for i in range(len(scenario.sites))]
                  + [f"$.room_vantages[{i}].position" for i in range(len(scenario.room_vantages))])
        start_node = self._node[grid.cell(start)]
        start_field = dijkstra(graph, directed=False, indices=[start_node])[0]
        reachable = np.zeros_like(grid.free)
        reachable[free_r, free_c] = np.isfinite(start_field)
        for where, site, v in zip(wheres, scenario.viewpoints, self.vantages):
            kind = "site" if site.kind == "site" else "room vantage"
            what = f"{kind} {site.name!r}: vantage ({v[0]:.2f}, {v[1]:.2f})"
            if not grid.is_free(v):
                raise InputError(source, where,
                                 f"{what} is not on free "
                                 f"floor (inside a wall or furniture, or within the agent radius "
                                 f"{grid.agent_radius:.2f} m of one); nearest free cell at "
                                 f"{_fmt(grid.nearest(v, reachable))}")
            if not reachable[grid.cell(v)]:
                raise InputError(source, where,
                                 f"{what} is not reachable "
                                 f"from the start ({start[0]:.2f}, {start[1]:.2f}); nearest free cell "
                                 f"reachable from the start at {_fmt(grid.nearest(v, reachable))}")
        sources = [int(self._node[grid.cell(v)]) for v in self.vantages]
        self.fields, self._pred = dijkstra(graph, directed=False, indices=sources, return_predecessors=True)
        self.reachable = reachable

    def _graph(self):
        grid, node = self.grid, self._node
        r = grid.resolution
        rows_a, cols_a, weights = [], [], []
        free = grid.free
        for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
            # a: cell (r, c); b: its neighbour (r + dr, c + dc); dr is never negative here
            r0, r1 = 0, grid.rows - dr
            c0, c1 = max(0, -dc), grid.cols - max(0, dc)
            a = free[r0:r1, c0:c1]
            b = free[r0 + dr:r1 + dr, c0 + dc:c1 + dc]
            ok = a & b
            if dr and dc:  # no corner cutting: both orthogonal neighbours must be free
                ok &= free[r0 + dr:r1 + dr, c0:c1] & free[r0:r1, c0 + dc:c1 + dc]
            rr, cc = np.nonzero(ok)
            rr, cc = rr + r0, cc + c0
            rows_a.append(node[rr, cc])
            cols_a.append(node[rr + dr, cc + dc])
            weights.append(np.full(rr.size, r * (math.sqrt(2.0) if dr and dc else 1.0)))
        n = int(free.sum())
        return coo_matrix((np.concatenate(weights), (np.concatenate(rows_a), np.concatenate(cols_a))),
                          shape=(n, n)).tocsr()

    def _node_at(self, xy: Sequence[float]) -> tuple[int, Point]:
        """Graph node of the free cell under `xy` (or the nearest reachable one) and its centre."""
        r, c = self.grid.cell(xy)
        if not (self.grid.inside(r, c) and self.reachable[r, c]):
            near = self.grid.nearest(xy, self.reachable)
            assert near is not None, "the start cell, at least, is reachable"
            r, c = self.grid.cell(near)
        return int(self._node[r, c]), self.grid.center(r, c)

    def distance(self, k: int, xy: Sequence[float]) -> float:
        """Geodesic distance (m) from floor point `xy` to site k's vantage point (a lookup).

        The grid distance between the two cells plus each point's offset from its cell centre;
        by the triangle inequality never less than the Euclidean distance. inf if unreachable.
        """
        node, c = self._node_at(xy)
        d = float(self.fields[k, node])
        if not math.isfinite(d):
            return math.inf
        v = self.vantages[k]
        v_node, cv = self._node_at(v)
        if node == v_node:
            return math.hypot(xy[0] - v[0], xy[1] - v[1])
        return d + math.hypot(xy[0] - c[0], xy[1] - c[1]) + math.hypot(v[0] - cv[0], v[1] - cv[1])

    def path(self, k: int, xy: Sequence[float]) -> list[Point] | None:
        """Corner points of a shortest path from `xy` to site k's vantage point, or None.

        Follows the Dijkstra predecessors cell by cell, then string-pulls: from each corner it
        keeps the farthest following point still in line of sight on the free grid.
        """
        node, _ = self._node_at(xy)
        if not math.isfinite(self.fields[k, node]):
            return None
        pred = self._pred[k]
        chain = [node]
        while pred[chain[-1]] >= 0:
            chain.append(int(pred[chain[-1]]))
        rc = self._node_rc[np.asarray(chain)]
        res, ox, oy = self.grid.resolution, self.grid.origin[0], self.grid.origin[1]
        pts = [(float(xy[0]), float(xy[1]))]
        pts += [(ox + (c + 0.5) * res, oy + (r + 0.5) * res) for r, c in rc[1:-1]]
        pts.append(self.vantages[k])
        corners = [pts[0]]
        i = 0
        while i < len(pts) - 1:
            j = i + 1
            while j + 1 < len(pts) and self.grid.segment_free(pts[i], pts[j + 1]):
                j += 1
            corners.append(pts[j])
            i = j
        return corners


def _fmt(p: Point | None) -> str:
    return "(none)" if p is None else f"({p[0]:.2f}, {p[1]:.2f})"


def path_length(points: Sequence[Point]) -> float:
    """Length (m) of a polyline."""
    return float(sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(points, points[1:])))
