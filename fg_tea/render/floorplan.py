"""What does this house look like from above, and where can the agent look from?

A top-down floor plan drawn from the :class:`~fg_tea.world.scenario.Scenario` alone (no simulator):
floor, walls with their doorway gaps, furniture boxes, every site (numbered dot and name), every
site vantage (the site's number) and room vantage (a labelled diamond, with lines to the sites
its glance covers), room names at the centroid of their sites, the start pose, and the objects'
true sites. The true sites are environment truth: the plan is a tool for people checking a house,
never an input to the agent.

:class:`MiniMap` is the same plan drawn small and without labels, for the video overlays: it
marks the agent, its field of view, the current viewpoint and the sites that look covers.

Images are RGB uint8. World x runs right and world y runs up in every image.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import cv2
import numpy as np

from fg_tea.world.navigation import wall_boxes
from fg_tea.world.scenario import Scenario

FONT = cv2.FONT_HERSHEY_SIMPLEX
#: Pixels per metre of the floor plan for houses up to PLAN_MAX_SIDE_PX / PLAN_PX_PER_M metres;
#: chosen so a 15-character site name (about 90 px) spans about one metre, the usual spacing
#: between neighbouring sites.
PLAN_PX_PER_M = 80.0
#: Longest side (px) of the drawn floor; larger houses get fewer pixels per metre.
PLAN_MAX_SIDE_PX = 2800

# Colours (RGB).
FLOOR = (236, 236, 230)
OUTSIDE = (255, 255, 255)
WALL = (60, 60, 66)
SITE = (30, 90, 200)
VANTAGE = (110, 110, 110)
ROOM_VANTAGE = (0, 150, 170)
TRUTH = (205, 30, 60)
START = (20, 140, 60)
ROOM_TEXT = (150, 150, 160)
CLOSE_LOOK = (255, 200, 40)
ROOM_GLANCE = (60, 220, 255)
FOUND = (70, 220, 90)

Rect = tuple[int, int, int, int]  # x0, y0, x1, y1 (pixels, exclusive ends)


@dataclass(frozen=True)
class PlanTransform:
    """World (m) -> image pixels: column = left + (x - x_min) * scale, row = top + (y_max - y) * scale."""

    x_min: float
    y_max: float
    scale: float  # pixels per metre
    left: int
    top: int

    def px(self, x: float, y: float) -> tuple[int, int]:
        """The pixel (column, row) of world point (x, y) in metres."""
        return (int(round(self.left + (x - self.x_min) * self.scale)),
                int(round(self.top + (self.y_max - y) * self.scale)))


@dataclass
class FloorPlan:
    """A drawn floor plan and where each label went.

    Attributes:
        image: RGB uint8 (rows, columns, 3).
        transform: world -> pixel mapping.
        site_labels: site name -> the label's pixel box (x0, y0, x1, y1).
        vantage_labels: site name -> the box of its vantage's number label.
        room_vantage_labels: room-vantage name -> label box.
        room_labels: room name -> label box.
        truth_labels: object name -> label box of the object at its true site.
    """

    image: np.ndarray
    transform: PlanTransform
    site_labels: dict[str, Rect] = field(default_factory=dict)
    vantage_labels: dict[str, Rect] = field(default_factory=dict)
    room_vantage_labels: dict[str, Rect] = field(default_factory=dict)
    room_labels: dict[str, Rect] = field(default_factory=dict)
    truth_labels: dict[str, Rect] = field(default_factory=dict)


# ----------------------------------------------------------------------------- label placement
def _overlap(a: Rect, b: Rect) -> int:
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    return w * h if w > 0 and h > 0 else 0


class LabelPlacer:
    """Greedy label placement: each label takes the free spot nearest its anchor.

    Candidate spots lie on rings of growing radius in eight directions around the anchor; the cost
    of a spot is its overlap (px^2) with labels and markers already placed, plus a heavy charge
    for pixels outside the image, plus a small charge per pixel of distance. Labels placed first
    win, so callers place the most important ones first.

    Args:
        width, height: image size in pixels.
    """

    def __init__(self, width: int, height: int) -> None:
        self.width, self.height = width, height
        self.taken: list[Rect] = []

    def block(self, rect: Rect) -> None:
        """Mark a region (e.g. a marker) that labels should avoid."""
        self.taken.append(rect)

    def _cost(self, rect: Rect, distance: float, avoid: Sequence[Rect] = ()) -> float:
        x0, y0, x1, y1 = rect
        inside = max(0, min(x1, self.width) - max(x0, 0)) * max(0, min(y1, self.height) - max(y0, 0))
        outside = (x1 - x0) * (y1 - y0) - inside
        return (sum(_overlap(rect, t) for t in self.taken) + sum(_overlap(rect, t) for t in avoid)
                + 50.0 * outside + 0.5 * distance)

    def place(self, size: tuple[int, int], anchor: tuple[int, int], gap: int = 5,
              rings: Sequence[float] = (1, 2.5, 4.5, 7), avoid: Sequence[Rect] = ()) -> tuple[Rect, bool]:
        """Choose a box of `size` (w, h) px near `anchor` and reserve it.

        Args:
            size: (width, height) of the box in pixels.
            anchor: the point (column, row) the label names.
            gap: distance (px) of the first ring from the anchor; later rings are multiples.
            rings: ring radii in units of `gap`.
            avoid: extra regions to avoid for this label only.

        Returns:
            (x0, y0, x1, y1) of the box, and whether it sits beyond the first ring (a leader line
            helps the reader then).
        """
        w, h = size
        ax, ay = anchor
        best, best_cost, best_far = None, math.inf, False
        for ring, r in enumerate(rings):
            d = int(gap * r)
            spots = [(ax + d, ay - h // 2), (ax - d - w, ay - h // 2), (ax - w // 2, ay - d - h),
                     (ax - w // 2, ay + d), (ax + d, ay - d - h), (ax + d, ay + d),
                     (ax - d - w, ay - d - h), (ax - d - w, ay + d)]
            for x, y in spots:
                rect = (x, y, x + w, y + h)
                cost = self._cost(rect, d, avoid)
                if cost < best_cost:
                    best, best_cost, best_far = rect, cost, ring > 0
                if cost <= 0.5 * d:  # free: the first free spot on the nearest ring wins
                    self.taken.append(rect)
                    return rect, ring > 0
        assert best is not None  # every ring offers spots
        self.taken.append(best)
        return best, best_far


def _label(img: np.ndarray, placer: LabelPlacer, text: str, anchor: tuple[int, int], scale: float,
           colour, background=(255, 255, 255), thickness: int = 1, alpha: float = 0.78,
           gap: int = 5, avoid: Sequence[Rect] = (), rings: Sequence[float] = (1, 2.5, 4.5, 7),
           leader: bool = True) -> Rect:
    (tw, th), base = cv2.getTextSize(text, FONT, scale, thickness)
    rect, far = placer.place((tw + 4, th + base + 3), anchor, gap, rings, avoid)
    x0, y0, x1, y1 = rect
    if far and leader:
        cx, cy = min(max(anchor[0], x0), x1 - 1), min(max(anchor[1], y0), y1 - 1)
        cv2.line(img, anchor, (cx, cy), tuple(int(c * 0.6) for c in colour), 1, cv2.LINE_AA)
    if background is not None:
        cx0, cy0 = max(x0, 0), max(y0, 0)
        cx1, cy1 = min(x1, img.shape[1]), min(y1, img.shape[0])
        if cx1 > cx0 and cy1 > cy0:
            region = img[cy0:cy1, cx0:cx1].astype(np.float32)
            img[cy0:cy1, cx0:cx1] = (region * (1 - alpha) + np.array(background) * alpha).astype(np.uint8)
    cv2.putText(img, text, (x0 + 2, y1 - base - 1), FONT, scale, colour, thickness, cv2.LINE_AA)
    return rect


# ----------------------------------------------------------------------------- geometry drawing
def _fit(scenario: Scenario, width: int, height: int, margin: int) -> PlanTransform:
    (x0, y0), (x1, y1) = scenario.house.floor_min, scenario.house.floor_max
    scale = min((width - 2 * margin) / (x1 - x0), (height - 2 * margin) / (y1 - y0))
    left = int((width - (x1 - x0) * scale) / 2)
    top = int((height - (y1 - y0) * scale) / 2)
    return PlanTransform(x0, y1, scale, left, top)


def _draw_house(img: np.ndarray, scenario: Scenario, t: PlanTransform, outline: bool = True,
                floor=FLOOR, wall=WALL, shade: float = 1.0) -> None:
    """Floor, furniture boxes and walls (with doorway gaps) onto `img` in place.

    Args:
        floor, wall: RGB colours.
        shade: furniture colours are multiplied by this (a dark mini-map uses < 1).
    """
    house = scenario.house
    (x0, y0), (x1, y1) = house.floor_min, house.floor_max
    cv2.rectangle(img, t.px(x0, y1), t.px(x1, y0), floor, -1)
    for f in house.furniture:
        (cx, cy), (sx, sy) = f.center, f.size[:2]
        colour = tuple(int(255 * shade * min(max(c, 0.0), 1.0)) for c in f.color[:3])
        a, b = t.px(cx - sx / 2, cy + sy / 2), t.px(cx + sx / 2, cy - sy / 2)
        cv2.rectangle(img, a, b, colour, -1)
        if outline:
            cv2.rectangle(img, a, b, (90, 80, 70), 1)
    for box in wall_boxes(house):
        (cx, cy), (hu, hv), (ux, uy) = box.center, box.half, box.axis
        corners = [(cx + su * hu * ux - sv * hv * uy, cy + su * hu * uy + sv * hv * ux)
                   for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        poly = np.array([t.px(x, y) for x, y in corners], dtype=np.int32)
        cv2.fillPoly(img, [poly], wall, cv2.LINE_AA)
        if t.scale * 2 * hv < 2:  # thinner than 2 px: keep walls visible
            cv2.polylines(img, [poly], True, wall, 1, cv2.LINE_AA)


def _diamond(img: np.ndarray, centre: tuple[int, int], r: int, colour, thickness: int = -1) -> None:
    x, y = centre
    pts = np.array([(x, y - r), (x + r, y), (x, y + r), (x - r, y)], dtype=np.int32)
    if thickness < 0:
        cv2.fillPoly(img, [pts], colour, cv2.LINE_AA)
    else:
        cv2.polylines(img, [pts], True, colour, thickness, cv2.LINE_AA)


def _arrow(img: np.ndarray, t: PlanTransform, x: float, y: float, yaw_deg: float, length_m: float,
           colour, thickness: int = 2) -> None:
    yaw = math.radians(yaw_deg)
    tip = t.px(x + length_m * math.cos(yaw), y + length_m * math.sin(yaw))
    cv2.arrowedLine(img, t.px(x, y), tip, colour, thickness, cv2.LINE_AA, tipLength=0.35)


def room_centroids(scenario: Scenario) -> dict[str, tuple[float, float]]:
    """Room name -> mean (x, y) in metres of its sites' surface positions."""
    out: dict[str, list[tuple[float, float]]] = {}
    for s in scenario.sites:
        out.setdefault(s.room, []).append(s.position[:2])
    return {room: (float(np.mean([p[0] for p in pts])), float(np.mean([p[1] for p in pts])))
            for room, pts in out.items()}


# ----------------------------------------------------------------------------- the floor plan
def draw_floor_plan(scenario: Scenario, px_per_m: float | None = None, show_truth: bool = True,
                    font_scale: float = 0.4) -> FloorPlan:
    """Draw the scenario's floor plan, labelled for checking a house.

    Args:
        scenario: the house.
        px_per_m: pixels per metre (default: PLAN_PX_PER_M, fewer for houses whose longer side
            would exceed PLAN_MAX_SIDE_PX).
        show_truth: mark each object's true site (environment truth; for people only).
        font_scale: OpenCV font scale of site labels (0.4 is about 8 px tall letters).

    Returns:
        The image and every label's pixel box.
    """
    house = scenario.house
    (x0, y0), (x1, y1) = house.floor_min, house.floor_max
    fw, fh = x1 - x0, y1 - y0
    scale = px_per_m or min(PLAN_PX_PER_M, PLAN_MAX_SIDE_PX / max(fw, fh))
    margin = int(max(50, 0.8 * scale))
    title_h, legend_h = 28, 44
    width = int(math.ceil(fw * scale)) + 2 * margin
    height = int(math.ceil(fh * scale)) + 2 * margin + title_h + legend_h
    img = np.full((height, width, 3), OUTSIDE, np.uint8)
    t = PlanTransform(x0, y1, scale, margin, margin + title_h)
    _draw_house(img, scenario, t)
    plan = FloorPlan(img, t)
    placer = LabelPlacer(width, height - legend_h)
    placer.block((0, 0, width, title_h))
    r = max(3, int(round(0.06 * scale)))
    numbers = {s.name: i + 1 for i, s in enumerate(scenario.sites)}

    # Room vantages: lines to the sites their glance covers (drawn under everything else).
    for v in scenario.room_vantages:
        p = t.px(*v.position)
        for s in scenario.sites:
            if s.room == v.room:
                cv2.line(img, p, t.px(*s.position[:2]), (150, 210, 220), 1, cv2.LINE_AA)
    # Site vantages: a thin line from the vantage to its site.
    for s in scenario.sites:
        cv2.line(img, t.px(*s.vantage), t.px(*s.position[:2]), (185, 185, 185), 1, cv2.LINE_AA)

    # Markers first, so that labels avoid all of them.
    for s in scenario.sites:
        p = t.px(*s.position[:2])
        cv2.circle(img, p, r, SITE, -1, cv2.LINE_AA)
        cv2.circle(img, p, r, (255, 255, 255), 1, cv2.LINE_AA)
        placer.block((p[0] - r, p[1] - r, p[0] + r + 1, p[1] + r + 1))
        q = t.px(*s.vantage)
        cv2.drawMarker(img, q, VANTAGE, cv2.MARKER_TILTED_CROSS, 2 * r, 1, cv2.LINE_AA)
        placer.block((q[0] - r, q[1] - r, q[0] + r + 1, q[1] + r + 1))
    for v in scenario.room_vantages:
        p = t.px(*v.position)
        _diamond(img, p, r + 2, ROOM_VANTAGE)
        placer.block((p[0] - r - 2, p[1] - r - 2, p[0] + r + 3, p[1] + r + 3))
    truth: dict[str, list[str]] = {}
    if show_truth:
        for o in scenario.objects:
            truth.setdefault(o.true_site, []).append(o.name)
        for site in truth:
            p = t.px(*scenario.site(site).position[:2])
            cv2.circle(img, p, r + 4, TRUTH, 2, cv2.LINE_AA)
            placer.block((p[0] - r - 5, p[1] - r - 5, p[0] + r + 6, p[1] + r + 6))
    sx, sy = scenario.start_position
    _arrow(img, t, sx, sy, scenario.start_yaw_deg, 0.6, START, 2)
    sp = t.px(sx, sy)
    placer.block((sp[0] - r - 2, sp[1] - r - 2, sp[0] + r + 3, sp[1] + r + 3))
    cv2.circle(img, sp, r + 1, START, -1, cv2.LINE_AA)

    # Labels, most important first: sites, truth, room vantages, rooms, vantage numbers, start.
    for s in scenario.sites:
        plan.site_labels[s.name] = _label(img, placer, f"{numbers[s.name]} {s.name}",
                                          t.px(*s.position[:2]), font_scale, SITE, gap=r + 3)
    for site, names in truth.items():
        anchor = t.px(*scenario.site(site).position[:2])
        for name in names:
            plan.truth_labels[name] = _label(img, placer, f"{name} (true)", anchor, font_scale * 0.95,
                                             TRUTH, gap=r + 6)
    for v in scenario.room_vantages:
        plan.room_vantage_labels[v.name] = _label(img, placer, f"{v.name} (glance: {v.room})",
                                                  t.px(*v.position), font_scale * 0.95, ROOM_VANTAGE,
                                                  gap=r + 4)
    furniture = []
    for f in house.furniture:
        (cx, cy), (fx, fy) = f.center, f.size[:2]
        (a, b), (c, d) = t.px(cx - fx / 2, cy + fy / 2), t.px(cx + fx / 2, cy - fy / 2)
        furniture.append((a, b, c + 1, d + 1))
    for room, (cx, cy) in room_centroids(scenario).items():
        plan.room_labels[room] = _label(img, placer, room.replace("_", " ").upper(), t.px(cx, cy),
                                        font_scale * 1.25, ROOM_TEXT, background=None, gap=8,
                                        thickness=2, avoid=furniture, rings=(1, 3, 6, 10, 15),
                                        leader=False)
    for s in scenario.sites:
        plan.vantage_labels[s.name] = _label(img, placer, str(numbers[s.name]), t.px(*s.vantage),
                                             font_scale * 0.8, VANTAGE, gap=r + 1)
    _label(img, placer, "start", sp, font_scale * 0.9, START, gap=r + 3)

    # Title and legend.
    title = (f"{scenario.name}: {len(scenario.sites)} sites, {len(scenario.rooms)} rooms, "
             f"{len(scenario.room_vantages)} room vantages, {fw:g} x {fh:g} m")
    cv2.putText(img, title, (10, 20), FONT, 0.55, (30, 30, 30), 1, cv2.LINE_AA)
    _legend(img, height - legend_h + 6, r, scale, show_truth)
    return plan


def _legend(img: np.ndarray, y: int, r: int, scale: float, show_truth: bool) -> None:
    x = 14
    fs = 0.42
    row = y + 12

    def item(draw, text: str) -> None:
        nonlocal x
        draw((x + 8, row - 4))
        cv2.putText(img, text, (x + 20, row), FONT, fs, (40, 40, 40), 1, cv2.LINE_AA)
        x += 28 + cv2.getTextSize(text, FONT, fs, 1)[0][0]

    item(lambda p: cv2.circle(img, p, r, SITE, -1, cv2.LINE_AA), "site (n name)")
    item(lambda p: cv2.drawMarker(img, p, VANTAGE, cv2.MARKER_TILTED_CROSS, 2 * r, 1, cv2.LINE_AA),
         "n: where the agent stands to look at site n")
    item(lambda p: _diamond(img, p, r + 2, ROOM_VANTAGE), "room vantage (one glance covers the room)")
    x, row = 14, row + 20
    if show_truth:
        item(lambda p: cv2.circle(img, p, r + 4, TRUTH, 2, cv2.LINE_AA),
             "true site of an object (for people; the agent does not know it)")
    item(lambda p: cv2.arrowedLine(img, (p[0] - 6, p[1]), (p[0] + 8, p[1]), START, 2, cv2.LINE_AA,
                                   tipLength=0.4), "start pose")
    bar = int(round(scale))
    cv2.line(img, (x + 2, row - 4), (x + 2 + bar, row - 4), (40, 40, 40), 2)
    for end in (x + 2, x + 2 + bar):
        cv2.line(img, (end, row - 8), (end, row), (40, 40, 40), 2)
    cv2.putText(img, "1 m", (x + bar + 8, row), FONT, fs, (40, 40, 40), 1, cv2.LINE_AA)


def write_floor_plan(scenario: Scenario, path: str | Path, **kwargs) -> FloorPlan:
    """Draw the floor plan (see :func:`draw_floor_plan`) and write it as a PNG, atomically."""
    from fg_tea.common.files import write_png

    plan = draw_floor_plan(scenario, **kwargs)
    write_png(Path(path), plan.image, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    return plan


# ----------------------------------------------------------------------------- the mini-map
class MiniMap:
    """A small unlabelled floor plan for the video, with the current look drawn on it.

    The static plan (floor, walls, furniture, site dots, room vantages) is drawn once per size;
    :meth:`render` adds the agent, its field of view and the current viewpoint.

    Args:
        scenario: the house.
        hfov_deg: the agent camera's horizontal field of view (deg), drawn as a wedge.
    """

    def __init__(self, scenario: Scenario, hfov_deg: float = 90.0) -> None:
        self.scenario = scenario
        self.hfov_deg = hfov_deg
        self.sites = {s.name: s.position[:2] for s in scenario.sites}
        self.positions = {v.name: v.position for v in scenario.viewpoints}
        (x0, y0), (x1, y1) = scenario.house.floor_min, scenario.house.floor_max
        self.aspect = (y1 - y0) / (x1 - x0)  # rows per column
        self._base: dict[tuple[int, int], tuple[np.ndarray, PlanTransform]] = {}

    def base(self, width: int, height: int) -> tuple[np.ndarray, PlanTransform]:
        """The static plan at (width, height) px, cached."""
        key = (width, height)
        if key not in self._base:
            img = np.full((height, width, 3), (28, 28, 32), np.uint8)
            t = _fit(self.scenario, width, height, max(2, width // 40))
            _draw_house(img, self.scenario, t, outline=False, floor=(66, 68, 76), wall=(215, 215, 220),
                        shade=0.75)
            r = max(1, int(round(min(width, height) / 90)))
            for v in self.scenario.room_vantages:
                _diamond(img, t.px(*v.position), r + 1, (0, 120, 140))
            for xy in self.sites.values():
                cv2.circle(img, t.px(*xy), r, (120, 180, 255), -1, cv2.LINE_AA)
            self._base[key] = (img, t)
        return self._base[key]

    def render(self, width: int, height: int, pose: Sequence[float] | None = None,
               viewpoint: str | None = None, kind: str = "site", covered: Iterable[str] = (),
               viewpoint_position: Sequence[float] | None = None,
               found: Mapping[str, str] | None = None) -> np.ndarray:
        """The mini-map at (width, height) px.

        Args:
            pose: the agent (x m, y m, yaw deg), drawn as a dot with its field-of-view wedge.
            viewpoint: the current viewpoint's name (its position comes from
                `viewpoint_position`, else from the scenario).
            kind: ``"site"`` (a close look: amber) or ``"room"`` (a room glance: cyan, with lines
                from the vantage to every covered site).
            covered: names of the sites the look covers (unknown names are ignored).
            found: object -> site where the look saw it (drawn green).
        """
        base, t = self.base(width, height)
        img = base.copy()
        r = max(2, int(round(min(width, height) / 45)))
        colour = ROOM_GLANCE if kind == "room" else CLOSE_LOOK
        covered = [c for c in covered if c in self.sites]
        vp = viewpoint_position if viewpoint_position is not None else self.positions.get(viewpoint or "")
        if pose is not None:
            x, y, yaw = (float(v) for v in pose[:3])
            reach = 2.5 * t.scale  # wedge radius: 2.5 m, about a room's half width
            centre = t.px(x, y)
            wedge = img.copy()
            # cv2 ellipse angles run clockwise in image rows-down coordinates: negate the yaw.
            cv2.ellipse(wedge, centre, (int(reach), int(reach)), 0.0, -yaw - self.hfov_deg / 2,
                        -yaw + self.hfov_deg / 2, (255, 255, 255), -1, cv2.LINE_AA)
            cv2.addWeighted(wedge, 0.3, img, 0.7, 0, dst=img)
        if vp is not None:
            p = t.px(*vp[:2])
            for c in covered:
                cv2.line(img, p, t.px(*self.sites[c]), colour, max(1, r // 3), cv2.LINE_AA)
            if kind == "room":
                _diamond(img, p, r + 2, colour)
            else:
                cv2.drawMarker(img, p, colour, cv2.MARKER_TILTED_CROSS, 2 * r + 2, max(1, r // 2), cv2.LINE_AA)
        for c in covered:
            cv2.circle(img, t.px(*self.sites[c]), r + 1, colour, max(1, r // 2), cv2.LINE_AA)
        for site in (found or {}).values():
            if site in self.sites:
                cv2.circle(img, t.px(*self.sites[site]), r, FOUND, -1, cv2.LINE_AA)
        if pose is not None:
            cv2.circle(img, t.px(pose[0], pose[1]), r, (255, 255, 255), -1, cv2.LINE_AA)
            _arrow(img, t, pose[0], pose[1], pose[2], 3 * r / t.scale, (255, 255, 255), max(1, r // 2))
        return img
