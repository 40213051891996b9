"""The camera file: what the environment's camera reports (docs/design.md §1.3, §3.4, §8.4).

A camera file configures the world's side of detection, and nothing of the agent's: which
detector the camera runs (``"visibility"``, a draw from P(seen | n pixels), eq. 30; or
``"threshold"``, seen iff n >= ``min_visible_pixels``, eq. 29), its visibility curve, and eq. 29's
site association (an object is reported at the inspected site only if it stands within
``site_association_radius`` of it). What the agent *assumes* about its detector is the model's
``[perception]`` table; the two agree for the bundled pairs and may differ on purpose (a
mis-specified agent).

Bundled cameras live in the top-level ``cameras/`` folder (``fg-tea list`` shows them)::

    name = "visibility"
    description = "..."

    [camera]
    detector = "visibility"          # "visibility" | "threshold"
    min_visible_pixels = 25          # threshold detector only
    site_association = true
    site_association_radius = 0.45   # metres

    [camera.visibility]              # visibility detector only (docs/design.md §3.4)
    half_pixels = 50
    slope = 3.0
    max_probability = 0.95

When no camera is named, an episode uses the bundled camera of the detector its model assumes
(:func:`default_camera`), so that a model runs in the world it describes unless told otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from fg_tea.common.errors import InputError
from fg_tea.common.inputs import Reader, read_toml
from fg_tea.common.resources import bundled_names, resolve_camera
from fg_tea.env.base import EnvConfig
from fg_tea.world.detectors import Detector, detector_kind, detector_names
from fg_tea.world.visibility import VisibilityCurve, read_curve

#: The EnvConfig fields a camera file sets; nothing else configures them.
CAMERA_FIELDS = ("min_visible_pixels", "site_association", "site_association_radius", "camera_curve")


@dataclass(frozen=True)
class Camera:
    """A camera file, read and checked.

    Attributes:
        name: the camera's name (``name`` in the file).
        detector: ``"visibility"`` or ``"threshold"``.
        min_visible_pixels: the threshold detector's pixel count (eq. 29).
        site_association: eq. 29's object_at_site check (False only in the ablation).
        site_association_radius: metres within which an object counts as at a site.
        curve: the visibility detector's curve; None for the threshold detector.
        source: the file it was read from ("" when built in code).
    """

    name: str
    detector: str = "visibility"
    min_visible_pixels: int = 25
    site_association: bool = True
    site_association_radius: float = 0.45
    curve: VisibilityCurve | None = None
    description: str = ""
    source: str = ""

    @property
    def kind(self) -> Detector:
        """The registered kind of :attr:`detector` (:mod:`fg_tea.world.detectors`)."""
        return detector_kind(self.detector, self.source or f"<camera {self.name}>", "camera.detector")

    def env_config(self, base: EnvConfig | None = None, **overrides: Any) -> EnvConfig:
        """`base` (default :class:`EnvConfig`) with this camera's fields, then `overrides`.

        Raises:
            InputError: an override that sets a camera field (say it in a camera file), or one
                that would have no effect with this camera's detector: ``detection_miss_rate``
                drops would-be detections of the threshold detector only, and
                ``min_visible_pixels`` is the threshold detector's alone.
        """
        where = self.source or f"<camera {self.name}>"
        for key in overrides:
            if key in CAMERA_FIELDS and key != "min_visible_pixels":
                raise InputError(where, key, "is set by the camera file, not by an override")
        fields = {"min_visible_pixels": self.min_visible_pixels,
                  "site_association": self.site_association,
                  "site_association_radius": self.site_association_radius,
                  "camera_curve": self.curve if self.kind.curve else None}
        config = replace(base or EnvConfig(), **{**fields, **overrides})
        if not self.kind.miss_rate:
            for key, what in (("detection_miss_rate", "drops would-be detections of"),
                              ("min_visible_pixels", "is the pixel threshold of")):
                if key in overrides and overrides[key] not in (None, 0, 0.0, self.min_visible_pixels):
                    raise InputError(where, key, f"has no effect with camera {self.name!r}: it "
                                     f"{what} the threshold detector, and this camera's {self.detector} "
                                     "detector draws each detection from its curve (docs/design.md "
                                     "§3.4); use --camera threshold")
        return config


def parse_camera(data: dict, file: str | Path = "<camera>") -> Camera:
    """Validate a parsed camera document and build a :class:`Camera`.

    Raises:
        InputError: naming the file, the key and the fault.
    """
    r = Reader(data, file)
    name = r.req("name", str)
    if not name.strip():
        raise r.fail("a camera name must not be empty", "name")
    c = r.child("camera")
    detector = c.choice("detector", detector_names())
    pixels = c.opt("min_visible_pixels", int, 25)
    if pixels < 1:
        raise c.fail(f"must be at least 1 pixel, got {pixels}", "min_visible_pixels")
    detector_kind(detector).check_camera(c)
    curve_r = c.child("visibility", required=False)
    curve = read_curve(curve_r) if curve_r is not None else None
    camera = Camera(name=name, detector=detector, min_visible_pixels=pixels,
                    site_association=c.opt("site_association", bool, True),
                    site_association_radius=c.positive("site_association_radius", 0.45),
                    curve=curve, description=r.opt("description", str, ""), source=str(file))
    r.finish()
    return camera


def load_camera(ref: str | Path | Camera) -> Camera:
    """A camera from a path or a bundled name (``"visibility"``, ``"threshold"``, ...).

    Raises:
        InputError: a missing or malformed file (one line: file, key, fault), or a bare name
            that is no file and no bundled camera ("did you mean").
    """
    if isinstance(ref, Camera):
        return ref
    path = resolve_camera(ref)
    return parse_camera(read_toml(path), path)


def default_camera(detector: str) -> str:
    """The bundled camera an agent that assumes `detector` runs with when none is named."""
    return detector_kind(detector).default_camera


def camera_names() -> list[str]:
    """The bundled cameras' names."""
    return bundled_names("cameras")


__all__ = ["CAMERA_FIELDS", "Camera", "parse_camera", "load_camera", "default_camera", "camera_names"]
