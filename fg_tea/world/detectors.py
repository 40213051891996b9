"""Detector kinds: what a detector is, in one class per kind (docs/design.md §3.4).

A detector kind says, for both sides of the agent/environment boundary,

- how the agent's look probabilities are computed from expected pixel counts
  (:meth:`Detector.slot_probability`, :meth:`Detector.look_tables`,
  :meth:`Detector.max_probability`);
- what the camera needs (:attr:`Detector.curve`: it draws each detection from a visibility curve;
  :attr:`Detector.pixel_threshold`: it reports an object iff it covers ``min_visible_pixels``;
  :attr:`Detector.miss_rate`: the environment drops would-be detections at a miss rate);
- what the files must say (:meth:`Detector.check_camera` for a camera file,
  :meth:`Detector.check_perception` for a model's ``[perception]`` table,
  :meth:`Detector.check_model` for a model file as a whole).

The two built-in kinds are ``"threshold"`` (eq. 29) and ``"visibility"`` (eq. 30). A new kind is
a subclass registered with :func:`register_detector`; the model and camera files then accept its
name (docs/how-to/add-a-detector.md). :func:`detector_kind` turns a name into its object; a name
no kind is registered under is one :class:`~fg_tea.common.errors.InputError` naming the file and
the field.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from fg_tea.common.errors import InputError

if TYPE_CHECKING:
    from fg_tea.common.inputs import Reader


class Detector:
    """One detector kind. Subclasses set the class attributes and override what differs.

    Attributes:
        name: the kind's name in model and camera files (``detector = "..."``).
        curve: the kind draws detections from a visibility curve, which the model assumes in
            ``[perception.visibility]`` and the camera sets in ``[camera.visibility]``.
        pixel_threshold: the camera reports an object iff it covers ``min_visible_pixels``, so that
            key is meaningful in camera and model files.
        miss_rate: the environment's ``detection_miss_rate`` drops would-be detections of this kind
            (False: the curve draws every miss).
        pixel_free: a close look at a site needs no expected pixel counts (with no room glances,
            the agent's model is one close look per site: ``Model.close_looks_only``).
        company: ``[perception] facing_tolerance`` and ``occlusion`` may be combined with it.
        default_camera: the bundled camera an agent assuming this kind runs with when none is named.
    """

    name: str = ""
    curve: bool = False
    pixel_threshold: bool = False
    miss_rate: bool = False
    pixel_free: bool = False
    company: bool = False
    default_camera: str = ""

    def max_probability(self, model: Any) -> float:
        """The best detection probability the agent assumes (a clear close look)."""
        return 1.0 - model.miss_likelihood

    def slot_probability(self, model: Any, category: str, slots: np.ndarray, view_kind: str) -> float:
        """P(seen) of an object of `category` at one in-view site, from the expected pixel counts of
        the site's placement slots (each slot equally likely, eq. 33); `view_kind` is ``"site"``
        (a close look) or ``"room"`` (a glance)."""
        raise NotImplementedError

    def look_tables(self, model: Any, view_kind: str, prob: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(P(seen), P(not seen)) per object and in-view site of one look, from `prob`."""
        return prob, 1.0 - prob

    def check_camera(self, camera: "Reader") -> None:
        """Refuse, in one line naming the key, a ``[camera]`` table this kind cannot use."""

    def check_perception(self, perception: "Reader", curve_here: bool) -> None:
        """Refuse, in one line naming the key, a model's ``[perception]`` table this kind cannot use;
        `curve_here`: the model file itself writes ``[perception.visibility]`` (not a parent)."""

    def check_model(self, data: Mapping[str, Any]) -> tuple[str, str] | None:
        """(key path, fault) of a whole model document (its merged data) this kind cannot use, or
        None."""
        return None


class ThresholdDetector(Detector):
    """Eq. 29: seen iff the object covers ``min_visible_pixels``; the agent assumes a close look
    shows it with 1 - mu and a room glance with (1 - mu) times the share of slots over the
    threshold."""

    name = "threshold"
    pixel_threshold = True
    miss_rate = True
    pixel_free = True
    default_camera = "threshold"

    def slot_probability(self, model: Any, category: str, slots: np.ndarray, view_kind: str) -> float:
        if view_kind == "room":
            return (1.0 - model.miss_likelihood) * float(np.mean(slots >= model.min_visible_pixels))
        return 1.0 - model.miss_likelihood

    def look_tables(self, model: Any, view_kind: str, prob: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if view_kind == "site":  # eq. 29's close look: mu exactly, not 1 - (1 - mu)
            mu = model.miss_likelihood
            return np.full(prob.shape, 1.0 - mu), np.full(prob.shape, mu)
        return prob, 1.0 - prob

    def check_camera(self, camera: "Reader") -> None:
        if camera.child("visibility", required=False) is not None:
            raise camera.fail("has no effect with the threshold detector; remove it or use "
                              "detector = \"visibility\"", "visibility")

    def check_perception(self, perception: "Reader", curve_here: bool) -> None:
        if curve_here:
            raise perception.fail("has no effect with detector = \"threshold\" (an object is seen iff "
                                  "it covers min_visible_pixels); remove it, or assume the visibility "
                                  "detector", "visibility")


class VisibilityDetector(Detector):
    """Eq. 30: each detection a draw from P(seen | n pixels), the visibility curve
    (:class:`~fg_tea.world.visibility.VisibilityCurve`)."""

    name = "visibility"
    curve = True
    company = True
    default_camera = "visibility"

    def max_probability(self, model: Any) -> float:
        assert model.detection_curve is not None  # the visibility detector has its curve
        return float(model.detection_curve.max_probability)

    def slot_probability(self, model: Any, category: str, slots: np.ndarray, view_kind: str) -> float:
        curve = model.detection_curve
        assert curve is not None  # the visibility detector has its curve
        return float(np.mean([curve.probability(category, n) for n in slots]))

    def check_camera(self, camera: "Reader") -> None:
        if camera.has("min_visible_pixels"):
            raise camera.fail("has no effect with the visibility detector (it draws each detection from "
                              "[camera.visibility]); remove it or use detector = \"threshold\"",
                              "min_visible_pixels")
        if camera.child("visibility", required=False) is None:
            raise camera.fail("missing: the visibility detector draws each detection from this curve "
                              "(half_pixels, slope, max_probability; the bundled cameras/visibility.toml "
                              "has one)", "visibility")

    def check_perception(self, perception: "Reader", curve_here: bool) -> None:
        if perception.has("min_visible_pixels"):
            raise perception.fail("has no effect with detector = \"visibility\" (the agent assumes the "
                                  "curve of [perception.visibility]); remove it, or assume the "
                                  "threshold detector", "min_visible_pixels")

    def check_model(self, data: Mapping[str, Any]) -> tuple[str, str] | None:
        perception = data.get("perception")
        if not isinstance(perception, dict) or "visibility" not in perception:
            return ("$.perception.visibility", "missing: detector = \"visibility\" needs the curve the agent assumes "
                    "(half_pixels, slope, max_probability; the bundled models/factorised.toml has "
                    "one), or there would be no telling which curve it assumes")
        return None


_REGISTRY: dict[str, Detector] = {}


def register_detector(kind: type[Detector] | Detector) -> Detector:
    """Register a detector kind (a :class:`Detector` subclass or instance) under its ``name``;
    usable as a class decorator. Returns the registered instance.

    Raises:
        ValueError: no name, or the name of another registered kind.
    """
    instance = kind() if isinstance(kind, type) else kind
    name = instance.name
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"detector kind {type(instance).__name__}: set a non-empty name")
    if name in _REGISTRY and type(_REGISTRY[name]) is not type(instance):
        raise ValueError(f"detector kind {name!r} is already registered "
                         f"({type(_REGISTRY[name]).__name__})")
    _REGISTRY[name] = instance
    return instance


def unregister_detector(name: str) -> None:
    """Remove a registered kind (tests registering a toy kind); the built-in kinds stay."""
    if name in ("threshold", "visibility"):
        raise ValueError(f"detector kind {name!r} is built in")
    _REGISTRY.pop(name, None)


def detector_names() -> tuple[str, ...]:
    """The registered kinds' names, built-in first, then in registration order."""
    return tuple(_REGISTRY)


def detector_kind(name: str, file: str = "<detector>", field: str = "detector") -> Detector:
    """The registered kind called `name`.

    Raises:
        InputError: no kind is registered under `name` (naming `file` and `field`).
    """
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise InputError(file, field, f"unknown detector {name!r}; registered: "
                                      f"{', '.join(_REGISTRY)}") from None


register_detector(ThresholdDetector)
register_detector(VisibilityDetector)

__all__ = ["Detector", "ThresholdDetector", "VisibilityDetector", "register_detector", "unregister_detector",
           "detector_names", "detector_kind"]
