"""What a generated house is made of: room and furniture types, their affordance weights, the
objects it may hold, and the rectangles, doorways, pieces and rooms the generator lays out.

:mod:`fg_tea.world.housegen` draws houses from these (docs/how-to/new-house.md); the numbers here are
hand-set plausibilities (kettles on kitchen counters, teabags on pantry shelves), not fitted to
any house. Pure Python and numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

ROOM_TYPES = ("kitchen", "pantry", "dining", "living", "study", "bedroom", "hall")
CATEGORIES = ("mug", "kettle", "teabag", "milk", "sugar")
DEFAULT_OBJECTS = ("mug", "kettle", "teabag")
#: Objects the tea task needs; every generated house holds them.
REQUIRED_OBJECTS = ("mug", "kettle", "teabag")
MIN_ROOMS, MAX_ROOMS = 3, 10

WALL_HEIGHT = 2.4
WALL_THICKNESS = 0.1
DOOR_WIDTH = 1.0
#: Extra-door probability for a shared wall outside the spanning tree.
EXTRA_DOOR_P = 0.25
#: Agent radius and grid resolution of the navigator's defaults (fg_tea.env.base.EnvConfig).
AGENT_RADIUS, GRID = 0.22, 0.05
#: Vantage clearance (m) from furniture footprints and from wall faces.
CLEAR_FURNITURE, CLEAR_WALL = 0.32, 0.35
#: Gap (m) kept between two pieces of furniture, and between a piece and its wall.
GAP_PIECES, GAP_WALL = 0.10, 0.03
#: A doorway keeps this strip free of furniture: its width plus 2 x side, and depth into the room.
DOOR_CLEAR_SIDE, DOOR_CLEAR_DEPTH = 0.15, 1.1
#: How far inside a doorway (m) a door vantage stands.
DOOR_VANTAGE_DEPTH = 0.75
#: Distance (m) from a site position to its vantage.
VANTAGE_RANGE = (1.0, 1.3)
MAX_ROOM_ATTEMPTS = 60
#: Floor plans tried before a seed is given up on: a plan whose room cannot be furnished or
#: reached in MAX_ROOM_ATTEMPTS draws is replaced by the next plan of the same seed.
MAX_PLAN_ATTEMPTS = 20

# Room-type and furniture-type affordance weights per category (mug, kettle, teabag, milk, sugar):
# kettles on kitchen counters, teabags and sugar on pantry/kitchen shelves, mugs on kitchen and
# dining surfaces, milk in the kitchen. Hand-set plausibilities, not fitted to any house.
ROOM_WEIGHTS: dict[str, tuple[float, ...]] = {
    "kitchen": (1.0, 1.0, 0.8, 1.0, 0.9),
    "pantry": (0.4, 0.3, 1.0, 0.5, 1.0),
    "dining": (0.7, 0.15, 0.3, 0.3, 0.5),
    "living": (0.3, 0.03, 0.1, 0.05, 0.05),
    "study": (0.2, 0.02, 0.05, 0.02, 0.02),
    "bedroom": (0.1, 0.01, 0.03, 0.01, 0.01),
    "hall": (0.05, 0.02, 0.05, 0.02, 0.02),
}


@dataclass(frozen=True)
class FurnitureType:
    """Size ranges (m) of one kind of furniture, its affordance weights and colour."""

    length: tuple[float, float]
    depth: tuple[float, float]
    height: tuple[float, float]
    weights: tuple[float, ...]  # per CATEGORIES
    color: tuple[float, float, float]


FURNITURE_TYPES: dict[str, FurnitureType] = {
    "counter": FurnitureType((1.6, 2.4), (0.6, 0.6), (0.90, 0.94),
                             (0.5, 0.9, 0.4, 0.6, 0.6), (0.78, 0.76, 0.72)),
    "side_counter": FurnitureType((0.9, 1.4), (0.6, 0.6), (0.90, 0.94),
                                  (0.4, 0.6, 0.3, 0.5, 0.4), (0.74, 0.72, 0.68)),
    "kitchen_table": FurnitureType((1.0, 1.4), (0.7, 0.8), (0.74, 0.78),
                                   (0.5, 0.2, 0.2, 0.4, 0.4), (0.66, 0.5, 0.32)),
    "cupboard": FurnitureType((0.7, 1.1), (0.45, 0.5), (0.85, 1.0),
                              (0.5, 0.2, 0.5, 0.2, 0.5), (0.6, 0.5, 0.4)),
    "shelf": FurnitureType((0.6, 1.0), (0.35, 0.45), (0.95, 1.05),
                           (0.3, 0.1, 0.6, 0.1, 0.5), (0.55, 0.42, 0.3)),
    "pantry_shelf": FurnitureType((0.9, 1.3), (0.4, 0.5), (0.98, 1.05),
                                  (0.2, 0.15, 0.9, 0.3, 0.8), (0.52, 0.4, 0.28)),
    "dining_table": FurnitureType((1.3, 1.6), (0.8, 0.9), (0.74, 0.78),
                                  (0.6, 0.1, 0.2, 0.4, 0.4), (0.62, 0.45, 0.28)),
    "sideboard": FurnitureType((0.9, 1.4), (0.45, 0.5), (0.80, 0.90),
                               (0.5, 0.1, 0.4, 0.1, 0.4), (0.45, 0.33, 0.25)),
    "cabinet": FurnitureType((0.6, 1.0), (0.4, 0.5), (0.75, 0.95),
                             (0.4, 0.05, 0.3, 0.05, 0.2), (0.5, 0.4, 0.36)),
    "side_table": FurnitureType((0.5, 0.6), (0.5, 0.6), (0.50, 0.65),
                                (0.4, 0.02, 0.05, 0.02, 0.02), (0.58, 0.48, 0.36)),
    "console_table": FurnitureType((1.0, 1.4), (0.4, 0.45), (0.75, 0.82),
                                   (0.3, 0.05, 0.1, 0.02, 0.05), (0.35, 0.3, 0.28)),
    "coffee_table": FurnitureType((0.9, 1.2), (0.6, 0.7), (0.45, 0.50),
                                  (0.6, 0.05, 0.1, 0.05, 0.05), (0.5, 0.36, 0.24)),
    "bookshelf": FurnitureType((0.8, 1.2), (0.35, 0.45), (0.95, 1.05),
                               (0.2, 0.02, 0.1, 0.01, 0.02), (0.4, 0.4, 0.45)),
    "desk": FurnitureType((1.0, 1.4), (0.6, 0.7), (0.72, 0.76),
                          (0.6, 0.02, 0.1, 0.01, 0.02), (0.42, 0.36, 0.3)),
    "nightstand": FurnitureType((0.45, 0.55), (0.4, 0.45), (0.50, 0.60),
                                (0.6, 0.01, 0.05, 0.01, 0.01), (0.6, 0.52, 0.42)),
    "dresser": FurnitureType((0.9, 1.3), (0.5, 0.55), (0.80, 0.95),
                             (0.2, 0.01, 0.05, 0.01, 0.01), (0.5, 0.44, 0.4)),
    "shoe_cabinet": FurnitureType((0.8, 1.1), (0.35, 0.4), (0.45, 0.55),
                                  (0.1, 0.05, 0.05, 0.01, 0.01), (0.36, 0.34, 0.32)),
}

#: Per room type: (label, furniture type) always placed, then optional extras in seeded order.
ROOM_FURNITURE: dict[str, tuple[tuple[tuple[str, str], ...], tuple[tuple[str, str], ...]]] = {
    "kitchen": ((("counter", "counter"), ("table", "kitchen_table")),
                (("cupboard", "cupboard"), ("shelf", "shelf"), ("side_counter", "side_counter"))),
    "pantry": ((("shelf", "pantry_shelf"), ("cupboard", "cupboard")),
               (("shelf", "pantry_shelf"), ("counter", "side_counter"), ("rack", "shelf"))),
    "dining": ((("table", "dining_table"), ("sideboard", "sideboard")),
               (("cabinet", "cabinet"), ("side_table", "side_table"), ("console", "console_table"))),
    "living": ((("coffee_table", "coffee_table"), ("side_table", "side_table")),
               (("bookshelf", "bookshelf"), ("console", "console_table"), ("sideboard", "sideboard"))),
    "study": ((("desk", "desk"), ("bookshelf", "bookshelf")),
              (("side_table", "side_table"), ("cabinet", "cabinet"), ("shelf", "shelf"))),
    "bedroom": ((("nightstand", "nightstand"), ("dresser", "dresser")),
                (("nightstand", "nightstand"), ("desk", "desk"), ("shelf", "shelf"))),
    "hall": ((("console", "console_table"), ("shoe_cabinet", "shoe_cabinet")),
             (("shelf", "shelf"), ("side_table", "side_table"), ("cabinet", "cabinet"))),
}

#: How many rooms of each non-kitchen type a house may have, and the draw weight of each type.
ROOM_LIMITS = {"pantry": 1, "dining": 1, "hall": 1, "living": 2, "study": 2, "bedroom": 3}
ROOM_DRAW = {"pantry": 1.0, "dining": 1.2, "hall": 0.6, "living": 1.2, "study": 0.8, "bedroom": 1.0}

#: Object entries: mug, kettle and teabag as in scenarios/default_apartment.json.
OBJECT_TEMPLATES: dict[str, dict] = {
    "mug": {"asset": "mug", "affordances": ["graspable", "container", "fillable"],
            "state_priors": {"contains_water": 0.02, "water_hot": 0.01, "tea_brewed": 0.01, "served": 0.01}},
    "kettle": {"asset": "kettle", "affordances": ["graspable", "fillable", "pourable", "heatable"],
               "state_priors": {"contains_water": 0.35, "water_hot": 0.01}},
    "teabag": {"asset": "teabag", "affordances": ["graspable", "steepable"], "state_priors": {"steeped": 0.02}},
    "milk": {"asset": "milk", "affordances": ["graspable", "pourable"], "state_priors": {}},
    # Sugar is spooned into the mug by POUR (make_tea_milk_sugar), which needs "pourable", as in
    # scenarios/milk_sugar_apartment.json.
    "sugar": {"asset": "sugar", "affordances": ["graspable", "pourable"], "state_priors": {}},
}
SEMANTIC_IDS = {"mug": 9001, "kettle": 9002, "teabag": 9003, "milk": 9004, "sugar": 9005}


# ---------------------------------------------------------------------------------- geometry
@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle [x0, x1] x [y0, y1] (m)."""

    x0: float
    y0: float
    x1: float
    y1: float

    def distance(self, p: tuple[float, float]) -> float:
        dx = max(self.x0 - p[0], 0.0, p[0] - self.x1)
        dy = max(self.y0 - p[1], 0.0, p[1] - self.y1)
        return math.hypot(dx, dy)

    def overlaps(self, other: "Rect", gap: float = 0.0) -> bool:
        return not (self.x1 + gap <= other.x0 or other.x1 + gap <= self.x0 or
                    self.y1 + gap <= other.y0 or other.y1 + gap <= self.y0)

    def grown(self, d: float) -> "Rect":
        return Rect(self.x0 - d, self.y0 - d, self.x1 + d, self.y1 + d)

    def crosses(self, a: tuple[float, float], b: tuple[float, float]) -> bool:
        """Whether the segment a-b meets the rectangle (Liang-Barsky clipping)."""
        t0, t1 = 0.0, 1.0
        dx, dy = b[0] - a[0], b[1] - a[1]
        for p, q in ((-dx, a[0] - self.x0), (dx, self.x1 - a[0]), (-dy, a[1] - self.y0), (dy, self.y1 - a[1])):
            if abs(p) < 1e-12:
                if q < 0:
                    return False
            else:
                t = q / p
                if p < 0:
                    t0 = max(t0, t)
                else:
                    t1 = min(t1, t)
                if t0 > t1:
                    return False
        return True

    @property
    def center(self) -> tuple[float, float]:
        return ((self.x0 + self.x1) / 2, (self.y0 + self.y1) / 2)


@dataclass
class Door:
    """A doorway between rooms `a` and `b` on a wall from `start` to `end` (centreline points)."""

    a: int
    b: int
    start: tuple[float, float]
    end: tuple[float, float]
    at: float | None = None  # metres from start; None: no doorway on this wall

    @property
    def point(self) -> tuple[float, float]:
        assert self.at is not None, "only a wall with a doorway has its point"
        length = math.dist(self.start, self.end)
        t = self.at / length
        return (self.start[0] + t * (self.end[0] - self.start[0]), self.start[1] + t * (self.end[1] - self.start[1]))


@dataclass
class Piece:
    """One placed piece of furniture and its site."""

    name: str
    kind: str
    rect: Rect
    center: tuple[float, float]  # rounded; the rect is built from it and `size`
    size: tuple[float, float]
    height: float
    vantage: tuple[float, float]
    capacity: int | None

    @property
    def site(self) -> tuple[float, float, float]:
        return (self.center[0], self.center[1], self.height)


@dataclass
class Room:
    name: str
    kind: str
    rect: Rect  # wall centrelines
    pieces: list[Piece] = field(default_factory=list)
    vantages: list[tuple[str, tuple[float, float]]] = field(default_factory=list)

    @property
    def inner(self) -> Rect:
        h = WALL_THICKNESS / 2
        return Rect(self.rect.x0 + h, self.rect.y0 + h, self.rect.x1 - h, self.rect.y1 - h)


def snap(x: float, step: float = 0.01) -> float:
    """Round to a multiple of `step` (and never -0.0), for stable bytes."""
    return round(round(x / step) * step, 4) + 0.0


def snapped_uniform(rng: np.random.Generator, lo: float, hi: float, step: float) -> float:
    return snap(float(rng.uniform(lo, hi)), step)
