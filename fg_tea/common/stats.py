"""Statistics used across fg_tea, each written once: entropy, Student-t and Wilson intervals.

- :func:`entropy`: H(p) = -sum p log p in nats, with 0 log 0 = 0 (docs/design.md eqs. 7, 22),
  over a whole distribution or along an axis, for the belief, the planners and the log alike;
- :func:`t_interval`: a mean and its two-sided Student-t interval (``scipy.stats.t``), NaN bounds
  for fewer than two values (a single value has a mean but no interval);
- :func:`wilson_interval`: a proportion's Wilson score interval.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable

import numpy as np

#: The standard normal's 97.5 % quantile (two-sided 95 %).
Z95 = 1.959963984540054
_TINY = np.finfo(float).tiny


def entropy(p: Any, axis: int | tuple[int, ...] | None = None) -> Any:
    """Shannon entropy in nats, -sum p log p with 0 log 0 = 0 (eq. 7; eq. 22 for [1 - p, p]).

    Args:
        p: probabilities (any shape); entries are never negative.
        axis: the axis (or axes) a distribution runs along; None sums over the whole array and
            returns a float.
    """
    p = np.asarray(p, dtype=float)
    logs = np.maximum(p, _TINY)        # p log(tiny) = 0 for p = 0
    np.log(logs, out=logs)
    logs *= p
    total = -logs.sum(axis=axis)
    return float(total) if axis is None else total


@dataclass(frozen=True)
class Interval:
    """A mean with its confidence interval. Fields are NaN when undefined."""

    mean: float
    low: float
    high: float
    n: int

    def fmt(self, digits: int = 2) -> str:
        """``mean [low, high]`` (or ``mean`` alone when the interval is undefined)."""
        if self.n == 0 or math.isnan(self.mean):
            return "–"
        if math.isnan(self.low):
            return f"{self.mean:.{digits}f}"
        return f"{self.mean:.{digits}f} [{self.low:.{digits}f}, {self.high:.{digits}f}]"


def _number(v: Any) -> bool:
    """Whether `v` is a value of the sample: None, "" (an empty CSV cell) and NaN are not."""
    return not (v is None or v == "" or math.isnan(float(v)))


def t_interval(values: Iterable[Any], confidence: float = 0.95) -> Interval:
    """Mean and two-sided Student-t confidence interval of a sample.

    Args:
        values: the sample (None, empty strings and NaN are dropped).
        confidence: the coverage, in (0, 1).

    Returns:
        The interval ``mean ± t_{(1+c)/2, n-1} s / sqrt(n)``; NaN bounds for n < 2, all NaN for n = 0.
    """
    from scipy import stats

    x = np.array([float(v) for v in values if _number(v)], dtype=float)
    n = len(x)
    if n == 0:
        return Interval(math.nan, math.nan, math.nan, 0)
    mean = float(x.mean())
    if n < 2:
        return Interval(mean, math.nan, math.nan, n)
    half = float(stats.t.ppf(0.5 + confidence / 2, n - 1) * x.std(ddof=1) / math.sqrt(n))
    return Interval(mean, mean - half, mean + half, n)


def wilson_interval(successes: int, n: int, z: float = Z95) -> Interval:
    """The Wilson score interval of a proportion (the mean is successes / n)."""
    if n <= 0:
        return Interval(math.nan, math.nan, math.nan, 0)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return Interval(p, centre - half, centre + half, n)


__all__ = ["Interval", "Z95", "entropy", "t_interval", "wilson_interval"]
