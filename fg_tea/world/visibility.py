"""The visibility detector: how likely is an object to be seen, given how many pixels it covers?

This module answers one question for both sides of the agent/environment boundary (see
docs/design.md §3.4): the probability that the detector reports an object
that stands in the camera's view, as a function of the number of segmentation pixels n it covers,

    P(seen | n) = p_max / (1 + (n_50 / n) ** s)        for n > 0,     P(seen | 0) = 0,

a logistic curve in log-pixels with half-probability pixel count n_50 (where P = p_max / 2),
slope s (per unit of ln n) and asymptote p_max (the best a clear close look achieves). Each
object category may declare its own n_50 and s.

The environment draws every detection from this curve with the pixel count it really rendered;
the agent evaluates the same family of curves (its own assumed parameters) at the pixel count it
*expects* for a category on a site from a viewpoint, computed from the house geometry alone.
Nothing here imports a simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Mapping

if TYPE_CHECKING:
    from fg_tea.common.inputs import Reader

#: Smallest half-probability pixel count n_50: a count of pixels, so below one pixel every object
#: in view would be seen with P near p_max, whatever its size or distance.
MIN_HALF_PIXELS = 1.0
#: Smallest slope s: at 0.1, P(seen) changes less than two-fold from 1 to 10^6 pixels; a flatter
#: curve no longer depends on how much of the object the camera sees.
MIN_SLOPE = 0.1


@dataclass(frozen=True)
class CurveParams:
    """n_50 (pixels, > 0) and slope s (> 0) of one category's curve."""

    half_pixels: float
    slope: float


@dataclass(frozen=True)
class VisibilityCurve:
    """P(seen | n pixels) per object category (eq. 30 with a declared visibility curve).

    Attributes:
        half_pixels: n_50, the pixel count at which P(seen) = max_probability / 2 (default curve).
        slope: s, per unit of ln(pixels) (default curve).
        max_probability: p_max in (0, 1], the asymptote for a large, clear view.
        categories: category -> :class:`CurveParams` overriding the default curve.
    """

    half_pixels: float = 150.0
    slope: float = 2.0
    max_probability: float = 0.95
    categories: Mapping[str, CurveParams] = field(default_factory=lambda: MappingProxyType({}))

    def params(self, category: str) -> CurveParams:
        """The curve parameters used for `category`."""
        return self.categories.get(category) or CurveParams(self.half_pixels, self.slope)

    def probability(self, category: str, pixels: float) -> float:
        """P(seen | `pixels`) for an object of `category`, in [0, max_probability]."""
        n = float(pixels)
        if not n > 0.0:
            return 0.0
        c = self.params(category)
        # p_max / (1 + (n50 / n)^s), written through exp/log so huge ratios cannot overflow.
        z = c.slope * (math.log(c.half_pixels) - math.log(n))
        if z > 700.0:
            return 0.0
        return self.max_probability / (1.0 + math.exp(z))

    def to_json(self) -> dict:
        return {"half_pixels": self.half_pixels, "slope": self.slope,
                "max_probability": self.max_probability,
                "categories": {k: {"half_pixels": v.half_pixels, "slope": v.slope}
                               for k, v in sorted(self.categories.items())}}



def read_curve(r: "Reader", base: VisibilityCurve | None = None) -> VisibilityCurve:
    """A visibility curve read from a model's or a camera's table: ``half_pixels``, ``slope``,
    ``max_probability`` and ``categories`` (each category inherits what it does not set).

    Args:
        r: the reader of the table (``[perception.visibility]`` or ``[camera.visibility]``).
        base: the curve whose values are kept where the table is silent (default: the defaults).
    """
    d = base or VisibilityCurve()
    half, slope = _half_pixels(r, d.half_pixels), _slope(r, d.slope)
    categories = dict(d.categories)
    cats = r.child("categories", required=False)
    if cats is not None:
        for name in cats.names():
            c = cats.child(name)
            # A category inherits what it does not set: its own earlier values, else this
            # curve's (so half_pixels alone keeps the curve's slope).
            default = categories.get(name) or CurveParams(half, slope)
            categories[name] = CurveParams(_half_pixels(c, default.half_pixels),
                                           _slope(c, default.slope))
    max_p = r.probability("max_probability", d.max_probability)
    if max_p <= 0:
        raise r.fail("max_probability must be positive, or nothing is ever seen", "max_probability")
    return VisibilityCurve(half, slope, max_p, MappingProxyType(categories))

def _half_pixels(r: "Reader", default: float) -> float:
    half = r.positive("half_pixels", default)
    if half < MIN_HALF_PIXELS:
        raise r.fail(f"must be at least {MIN_HALF_PIXELS:g} pixel, got {half:g} (n_50 counts "
                     "pixels: below one, every object in view is seen as if it filled the image)",
                     "half_pixels")
    return half


def _slope(r: "Reader", default: float) -> float:
    slope = r.positive("slope", default)
    if slope < MIN_SLOPE:
        raise r.fail(f"must be at least {MIN_SLOPE:g}, got {slope:g} (a flatter curve hardly "
                     "depends on the pixel count: P(seen) would be the same near and far)", "slope")
    return slope


__all__ = ["MIN_HALF_PIXELS", "MIN_SLOPE", "CurveParams", "VisibilityCurve", "read_curve"]
