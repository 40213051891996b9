"""The contract between the agent side and the environment: what is asked, what comes back.

The task layer says *what* should happen as an :class:`ActionRequest` (a verb from :data:`VERBS`,
an object, a site, a destination, a truth effect); the environment decides *how* and reports
observations: :class:`InspectionResult` (detections and pixel counts, eqs. 28-29),
:class:`StateReading` (a noisy reading, eqs. 23-24) and :class:`ActionResult` (success or a
machine-readable failure). None of these carries hidden truth. Both sides import this module; the
agent side imports nothing else of the environment.

Every result also carries `motion`: the agent pose at each rendered frame of the movement it took,
and :class:`ActionResult` carries `placements`: where objects stand after it, so a renderer can
replay an episode from its log (presentation only; the agent never reads them).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

VERBS = ("SEARCH", "INSPECT", "PICK", "NAVIGATE", "PLACE", "INSERT", "FILL", "POUR", "USE", "WAIT")


@dataclass(frozen=True)
class Pose:
    """Agent pose on the floor: position in metres, yaw in degrees (0 = +x, counter-clockwise)."""

    x: float
    y: float
    yaw_deg: float

    def as_list(self) -> list[float]:
        return [round(self.x, 5), round(self.y, 5), round(self.yaw_deg, 4)]


@dataclass(frozen=True)
class InspectionResult:
    """What one look from a viewpoint observed [28-30].

    `viewpoint` is the viewpoint looked from (a site's name for its close look). `detections` has an
    entry only for objects the inspection considered: True = seen at one of the sites in view (which
    one is in `found_at`), False = looked and not seen. `pixel_counts` gives n_o for the same
    objects: the pixels o covered in the image that faced the in-view site o stands at (0 if it
    stands at none). `view_pixels` spreads the same counts over every in-view site (object ->
    site -> pixels). `kind` is ``"site"`` (close look) or ``"room"`` (room glance); `sites` are
    the sites in view.
    """

    viewpoint: str
    detections: Mapping[str, bool]
    pixel_counts: Mapping[str, int]
    reachable: bool = True
    distance: float = 0.0
    frames: int = 0
    motion: tuple[tuple[float, float, float], ...] = ()
    image_size: tuple[int, int] = (0, 0)
    kind: str = "site"
    sites: tuple[str, ...] = ()
    found_at: Mapping[str, str] = field(default_factory=dict)
    view_pixels: Mapping[str, Mapping[str, int]] = field(default_factory=dict)


@dataclass(frozen=True)
class StateReading:
    """A noisy binary reading of a hidden state, e.g. ``kettle.contains_water`` [23, 24]."""

    state: str
    value: bool
    sensitivity: float
    specificity: float
    distance: float = 0.0
    frames: int = 0
    motion: tuple[tuple[float, float, float], ...] = ()


@dataclass(frozen=True)
class ActionRequest:
    """A practical action as the environment needs it: verb, object, where, onto or into what.

    `site` is where the agent believes the object is (for PICK, INSPECT) or where to go (NAVIGATE,
    PLACE); the environment checks it against truth and reports failure rather than correcting it.
    """

    verb: str
    object: str
    site: str | None = None
    destination: str | None = None
    effect: str | None = None  # name of the truth effect: fill, boil, pour, steep, serve


@dataclass(frozen=True)
class ActionResult:
    """Outcome of a practical action. `ok` False carries a machine-readable `reason`."""

    ok: bool
    reason: str = ""
    distance: float = 0.0
    frames: int = 0
    motion: tuple[tuple[float, float, float], ...] = ()
    placements: Mapping[str, tuple[float, float, float]] = field(default_factory=dict)


def logged_viewpoint(event: Mapping[str, Any]) -> str:
    """The viewpoint of a logged ``decision`` or ``observation``: its ``viewpoint``, or, in logs
    written before that key was the only one, its ``site`` (docs/design.md §9)."""
    return str(event["viewpoint"] if "viewpoint" in event else event["site"])
