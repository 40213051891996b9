"""The house's boxes (walls, furniture) drawn as PyBullet's TinyRenderer draws them, at a fraction
of its cost.

TinyRenderer spends about 0.2 microseconds on every pixel a triangle covers (it computes
barycentric coordinates, reads the depth buffer and shades each one) and most of a video frame's
CPU went there (experiments/results/video/tinyrenderer.md). The walls and furniture are axis-aligned
boxes of one colour each, and a flat face under a directional light has one colour, so a box face
is a polygon of one colour. :class:`BoxPainter` draws them the way TinyRenderer decides what a
pixel shows:

* a face is drawn when it faces the camera (TinyRenderer culls back faces by the same test);
* it is clipped against the near plane as TinyRenderer clips a triangle (z > -w in clip space),
  projected with the same viewport, and covers the pixels whose integer coordinates lie inside
  it or on its edge (TinyRenderer tests each pixel's barycentric coordinates for >= 0); the
  image is then flipped vertically, as TinyRenderer flips its buffer;
* where faces overlap, the nearer wins: boxes that do not overlap (:func:`disjoint` cuts the
  overlaps out first, which leaves their union and so every visible surface the same) are
  painted far to near, an order that a separating plane between any two of them gives.

Each pixel gets the number of the face it shows (0: none), and a table gives each face's colour,
measured from TinyRenderer once per colour and direction (:func:`face_colours`). The pixels equal
TinyRenderer's but for the rare pixel on an edge, where its single-precision arithmetic and this
double-precision one may round differently (tests/test_video_boxes.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

#: A pixel this close to a face's edge (pixels) is on it, and so inside: TinyRenderer keeps a pixel
#: whose barycentric coordinates are >= 0, and an edge through a pixel exactly (a camera looking
#: along an axis at a box's corner) must not be lost to rounding here.
TIE_PX = 1e-4

#: Face directions, in the order of a box's face table: +x, -x, +y, -y, +z, -z.
DIRECTIONS = ((0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0), (2, 1.0), (2, -1.0))


@dataclass(frozen=True)
class Box:
    """An axis-aligned box: its low and high corners (m) and its colour (RGBA, 0-1)."""

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    rgba: tuple[float, float, float, float]


def disjoint(boxes: Sequence[Box]) -> list[Box]:
    """The same union of boxes as boxes that do not overlap: each box loses what earlier boxes
    already fill (cut into up to six boxes around it). Faces the cuts make lie on an earlier
    box's face and look into it, so they are never the nearer surface."""
    kept: list[Box] = []
    for box in boxes:
        pieces = [box]
        for other in kept:
            pieces = [q for p in pieces for q in _subtract(p, other)]
        kept.extend(pieces)
    return kept


def _subtract(a: Box, b: Box) -> list[Box]:
    lo, hi = list(a.lo), list(a.hi)
    if any(min(hi[k], b.hi[k]) <= max(lo[k], b.lo[k]) for k in range(3)):
        return [a]  # no overlap (touching is not overlapping)
    out = []
    for k in range(3):
        if lo[k] < b.lo[k]:
            piece_hi = list(hi)
            piece_hi[k] = b.lo[k]
            out.append(Box(tuple(lo), tuple(piece_hi), a.rgba))  # type: ignore[arg-type]
            lo[k] = b.lo[k]
        if hi[k] > b.hi[k]:
            piece_lo = list(lo)
            piece_lo[k] = b.hi[k]
            out.append(Box(tuple(piece_lo), tuple(hi), a.rgba))  # type: ignore[arg-type]
            hi[k] = b.hi[k]
    return out  # what is left, [lo, hi], lies inside b


def face_colours(boxes: Sequence[Box], shade: Callable[[tuple, tuple], Sequence[int] | np.ndarray]) -> np.ndarray:
    """Each box's six face colours (n, 6, 3) uint8, from `shade(rgba, normal)` (TinyRenderer's
    colour of a face of that colour facing that way), asked once per colour and direction."""
    seen: dict[tuple, np.ndarray] = {}
    table = np.zeros((len(boxes), 6, 3), np.uint8)
    for i, box in enumerate(boxes):
        for f, (axis, sign) in enumerate(DIRECTIONS):
            normal = tuple(sign if k == axis else 0.0 for k in range(3))
            key = (tuple(box.rgba), normal)
            if key not in seen:
                seen[key] = np.asarray(shade(tuple(box.rgba), normal), np.uint8)[:3]
            table[i, f] = seen[key]
    return table


class BoxPainter:
    """Draws a fixed set of boxes from any camera, as TinyRenderer would.

    Args:
        boxes: the boxes (overlapping ones are made disjoint first).
        shade: TinyRenderer's colour of a face: ``shade(rgba, normal) -> (r, g, b)``.
    """

    def __init__(self, boxes: Sequence[Box], shade: Callable[[tuple, tuple], Sequence[int] | np.ndarray]) -> None:
        self.boxes = disjoint(boxes)
        self.lo = np.array([b.lo for b in self.boxes], float).reshape(-1, 3)
        self.hi = np.array([b.hi for b in self.boxes], float).reshape(-1, 3)
        self.colours = face_colours(self.boxes, shade)
        corners = [[(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
                   for lo, hi in zip(self.lo, self.hi)]
        self._corners = np.concatenate([np.array(corners).reshape(-1, 8, 3), np.ones((len(self.boxes), 8, 1))],
                                       axis=2)
        #: Faces' corners (n, 6, 4, 3), each face counter-clockwise seen from outside.
        self._faces = np.array([[_face(lo, hi, axis, sign) for axis, sign in DIRECTIONS]
                                for lo, hi in zip(self.lo, self.hi)]).reshape(-1, 6, 4, 3)

    def paint(self, view: Sequence[float], proj: Sequence[float], width: int, height: int
              ) -> tuple[np.ndarray, np.ndarray]:
        """The face each pixel shows and the faces' colours.

        Args:
            view, proj: the camera (pybullet's column-major lists).
            width, height: the image size.

        Returns:
            ids: (height, width), the row of `colours` each pixel shows (uint8 when there are
                at most 256 rows, else int32; the last painted, the nearest, where faces overlap).
            colours: uint8 (faces drawn + 1, 3); row 0 (no box) is white, TinyRenderer's empty pixel.
        """
        v = np.reshape(np.asarray(view, float), (4, 4)).T
        m = np.reshape(np.asarray(proj, float), (4, 4)).T @ v
        eye = np.linalg.inv(v)[:3, 3]
        order = np.array(self._order(eye, self._in_view(m)), int)
        # Faces towards the camera (TinyRenderer culls the others), in painting order.
        facing = np.stack([eye[axis] > self.hi[order, axis] if sign > 0 else eye[axis] < self.lo[order, axis]
                           for axis, sign in DIRECTIONS], axis=1)
        box, face = np.nonzero(facing)
        box = order[box]
        polygons, kept = _project(m, self._faces[box, face], width, height)
        colours = np.concatenate([np.full((1, 3), 255, np.uint8), self.colours[box[kept], face[kept]]])
        ids = np.zeros(height * width, np.uint8 if len(colours) <= 256 else np.int32)
        if len(polygons):
            rows, x0, x1, polygon = _spans(polygons, width, height)
            length = x1 - x0 + 1
            keep = length > 0
            rows, x0, length, polygon = rows[keep], x0[keep], length[keep], polygon[keep]
            if len(rows):
                # The pixels of every span, in painting order: a running sum of steps of one that
                # jumps to each span's first pixel (TinyRenderer flips its image vertically).
                starts = (height - 1 - rows) * width + x0
                first = np.cumsum(length) - length
                steps = np.ones(int(length.sum()), np.int32)
                steps[first] = starts - np.concatenate([[0], starts[:-1] + length[:-1] - 1])
                ids[np.cumsum(steps, dtype=np.int32)] = np.repeat((polygon + 1).astype(ids.dtype), length)
        return ids.reshape(height, width), colours

    def _in_view(self, m: np.ndarray) -> np.ndarray:
        """Indices of boxes not wholly outside one plane of the view volume (or behind the camera)."""
        clip = self._corners @ m.T  # (n, 8, 4)
        x, y, z, w = clip[..., 0], clip[..., 1], clip[..., 2], clip[..., 3]
        out = ((x > w).all(1) | (x < -w).all(1) | (y > w).all(1) | (y < -w).all(1) | (z < -w).all(1)
               | (w < 0).all(1))
        return np.flatnonzero(~out)

    def _order(self, eye: np.ndarray, boxes: np.ndarray) -> list[int]:
        """`boxes` far to near: a box comes after every box it may hide.

        Box j cannot hide box i when a plane separates them with the camera on i's side: rays to
        i then never reach j. Disjoint boxes always have such a plane for one of the two.
        """
        lo, hi = self.lo[boxes], self.hi[boxes]
        safe = np.zeros((len(boxes), len(boxes)), bool)  # safe[i, j]: j cannot hide i
        for k in range(3):
            below = hi[:, None, k] <= lo[None, :, k]  # i below j along k
            above = lo[:, None, k] >= hi[None, :, k]
            safe |= below & (eye[k] <= lo[None, :, k])
            safe |= above & (eye[k] >= hi[None, :, k])
        hides = ~safe
        np.fill_diagonal(hides, False)
        # hides[i, j]: j may hide i, so i is painted first. Depth-first topological order.
        after = [np.flatnonzero(row) for row in hides]
        done = np.zeros(len(boxes), bool)
        visiting = np.zeros(len(boxes), bool)
        order: list[int] = []
        for start in np.argsort(-np.linalg.norm((lo + hi) / 2 - eye, axis=1)):
            _visit(int(start), after, done, visiting, order)
        return [int(boxes[i]) for i in reversed(order)]


def _visit(node: int, after: list[np.ndarray], done: np.ndarray, visiting: np.ndarray, order: list[int]) -> None:
    """Append `node` after every node that must be painted after it (reversed post-order)."""
    stack = [(node, 0)]
    while stack:
        n, k = stack.pop()
        if k == 0:
            if done[n] or visiting[n]:
                continue  # painted already, or a cycle (boxes that overlap): left as reached
            visiting[n] = True
        successors = after[n]
        while k < len(successors) and (done[successors[k]] or visiting[successors[k]]):
            k += 1
        if k < len(successors):
            stack.append((n, k + 1))
            stack.append((int(successors[k]), 0))
            continue
        visiting[n] = False
        done[n] = True
        order.append(n)


def _face(lo: np.ndarray, hi: np.ndarray, axis: int, sign: float) -> list[tuple[float, float, float]]:
    """The four corners of a box face, counter-clockwise seen from outside."""
    u, w = (axis + 1) % 3, (axis + 2) % 3
    plane = hi[axis] if sign > 0 else lo[axis]
    square = [(lo[u], lo[w]), (hi[u], lo[w]), (hi[u], hi[w]), (lo[u], hi[w])]
    if sign < 0:
        square.reverse()
    corners = []
    for a, b in square:
        p = [0.0, 0.0, 0.0]
        p[axis], p[u], p[w] = plane, a, b
        corners.append((p[0], p[1], p[2]))
    return corners


def _project(m: np.ndarray, faces: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Faces' corners (n, 4, 3) in TinyRenderer's pixel coordinates (before its vertical flip),
    clipped against the near plane (z > -w) as it clips triangles.

    Returns:
        polygons: (k, 5, 2), each convex polygon's corners, its last one repeated to fill five.
        kept: the indices of the `k` faces something is left of.
    """
    clip = np.concatenate([faces, np.ones(faces.shape[:2] + (1,))], axis=2) @ m.T  # (n, 4, 4)
    inside = (clip[..., 3] > 0) & (clip[..., 2] > -clip[..., 3])
    scale = np.array([width / 2, height / 2])
    whole = inside.all(axis=1)
    polygons = np.empty((len(faces), 5, 2))
    polygons[:, :4] = (clip[..., :2] / clip[..., 3:4] + 1) * scale
    polygons[:, 4] = polygons[:, 3]
    kept = whole.copy()
    for k in np.flatnonzero(~whole & inside.any(axis=1)):
        corners, flags, cut = list(clip[k]), list(inside[k]), []
        for i in range(4):
            a, b = corners[i], corners[(i + 1) % 4]
            if flags[i]:
                cut.append(a)
            if flags[i] != flags[(i + 1) % 4]:
                da, db = a[2] + a[3], b[2] + b[3]
                cut.append((a * db - b * da) / (db - da))
        if len(cut) >= 3:
            c = np.array(cut + [cut[-1]] * (5 - len(cut)))
            polygons[k] = (c[:, :2] / c[:, 3:4] + 1) * scale
            kept[k] = True
    index = np.flatnonzero(kept)
    return polygons[index], index


def _spans(pts: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rows and [x0, x1] column spans of the integer points inside (or on) convex polygons
    (n, corners, 2; a repeated corner adds an edge of no length), in the polygons' order:
    (row, x0, x1, polygon index), for all polygons at once."""
    nxt = np.concatenate([pts[:, 1:], pts[:, :1]], axis=1)
    area = np.sum(pts[:, :, 0] * nxt[:, :, 1] - nxt[:, :, 0] * pts[:, :, 1], axis=1)
    good = np.abs(area) > 0.02  # twice the area in pixels: TinyRenderer drops degenerate triangles
    sign = np.where(area >= 0, 1.0, -1.0)
    y0 = np.maximum(np.ceil(pts[:, :, 1].min(axis=1) - TIE_PX), 0)
    y1 = np.minimum(np.floor(pts[:, :, 1].max(axis=1) + TIE_PX), height - 1)
    count = np.where(good, np.maximum(y1 - y0 + 1, 0), 0).astype(np.int64)
    poly = np.repeat(np.arange(len(pts)), count)
    rows = np.repeat(y0, count) + (np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count))
    # Edge k: inside where s * ((x1 - x0) * (y - y0) - (y1 - y0) * (x - x0)) >= 0, i.e. a x + c >= 0.
    p0, p1, s = pts[poly], nxt[poly], sign[poly][:, None]
    dx, dy = p1[:, :, 0] - p0[:, :, 0], p1[:, :, 1] - p0[:, :, 1]
    a = -s * dy
    c = s * (dx * (rows[:, None] - p0[:, :, 1]) + dy * p0[:, :, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = -c / a
    lower = np.where(a > 0, bound, -np.inf).max(axis=1)
    upper = np.where(a < 0, bound, np.inf).min(axis=1)
    ok = np.where(a == 0, c >= -TIE_PX, True).all(axis=1)
    x0 = np.maximum(np.ceil(lower - TIE_PX), 0)
    x1 = np.where(ok, np.minimum(np.floor(upper + TIE_PX), width - 1), -1)
    return rows.astype(np.int64), x0.astype(np.int64), x1.astype(np.int64), poly
