"""Statistics, each written once: entropy, interval estimates (Student-t, Wilson, the percentile
bootstrap), and what replication needs (t-test p-values, Holm's adjustment, Bonferroni intervals,
the pairs a difference needs).

**Entropy** (:func:`entropy`): H(p) = -sum p log p in nats with 0 log 0 = 0 (docs/design.md eqs.
7, 22), over a whole distribution or along an axis, for the belief, the planners and the log.

Every mean the package or an experiment script reports with an uncertainty goes through here,
so one sample gets one answer everywhere.

**Student-t** (:func:`t_interval`): ``mean ± t_{(1+c)/2, n-1} · s / sqrt(n)`` with the sample
standard deviation s (ddof = 1) and the quantile from ``scipy.stats.t.ppf``. None, empty strings
and NaN are dropped first. With no value everything is NaN; with **one value the mean is that
value and both bounds are NaN** (one value says nothing about the spread, so no interval is
claimed); :meth:`Interval.fmt` then prints the mean alone. ``scipy.stats.t.interval`` computes
the same bounds but in another order of operations (``loc + ppf · scale``), which moves the
last bit of about a third of them; the formula above is kept so committed tables reproduce.

**Wilson** (:func:`wilson_interval`): a proportion, for which the t-interval collapses to a point
when every trial succeeds: ``(p + z²/2n ± z sqrt(p(1-p)/n + z²/4n²)) / (1 + z²/n)``.

**Bootstrap** (:func:`resample_indices`, :func:`bootstrap_interval`, :func:`bootstrap_ratio`):
percentile intervals from resampling the units (worlds, households) with replacement, drawn
from ``numpy.random.default_rng(seed)``. ``scipy.stats.bootstrap(..., method="percentile")``
draws the same indices but asks ``numpy.percentile`` for ``100 · (1 - c) / 2`` =
2.5000000000000022, which moves the last bit of the lower bound; the resampling below is kept so
committed tables reproduce bit for bit. As for the t-interval, a single unit gives its value
with NaN bounds (every resample would be that unit: no spread is measured).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Sequence, TypeVar

import numpy as np

#: The 0.975 quantile of the standard normal (z for a two-sided 95 % interval).
Z95 = 1.959963984540054
#: Resamples of :func:`bootstrap_interval` and :func:`bootstrap_ratio` unless told otherwise.
BOOTSTRAP_RESAMPLES = 4000

T = TypeVar("T")


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
        """``mean [low, high]`` (``mean`` alone when the bounds are undefined, ``–`` without a mean)."""
        if self.n == 0 or math.isnan(self.mean):
            return "–"
        if math.isnan(self.low):
            return f"{self.mean:.{digits}f}"
        return f"{self.mean:.{digits}f} [{self.low:.{digits}f}, {self.high:.{digits}f}]"


def _missing(v: Any) -> bool:
    return v is None or (isinstance(v, str) and v == "") or (isinstance(v, float) and math.isnan(v))


def t_interval(values: Iterable[Any], confidence: float = 0.95) -> Interval:
    """Mean and two-sided Student-t confidence interval of a sample.

    Args:
        values: the sample; None, "" and NaN are dropped, the rest converted with ``float``.
        confidence: the coverage, in (0, 1).

    Returns:
        ``mean ± t_{(1+c)/2, n-1} s / sqrt(n)``; NaN bounds for n = 1, all NaN for n = 0.
    """
    from scipy import stats

    x = np.array([float(v) for v in values if not _missing(v)], dtype=float)
    n = len(x)
    if n == 0:
        return Interval(math.nan, math.nan, math.nan, 0)
    mean = float(x.mean())
    if n < 2:
        return Interval(mean, math.nan, math.nan, n)
    half = float(stats.t.ppf(0.5 + confidence / 2, n - 1) * x.std(ddof=1) / math.sqrt(n))
    return Interval(mean, mean - half, mean + half, n)


def wilson_interval(successes: int, n: int, z: float = Z95) -> Interval:
    """A proportion with its Wilson score interval (z = 1.96 for 95 %), from
    ``scipy.stats.binomtest(...).proportion_ci(method="wilson")``."""
    from scipy import stats

    if n == 0:
        return Interval(math.nan, math.nan, math.nan, 0)
    confidence = 2.0 * float(stats.norm.cdf(z)) - 1.0
    ci = stats.binomtest(int(successes), int(n)).proportion_ci(confidence, method="wilson")
    return Interval(successes / n, float(ci.low), float(ci.high), n)


def _percentiles(draws: Any, confidence: float) -> tuple[float, float]:
    tail = round(50 * (1 - confidence), 10)  # percent in each tail: 2.5 exactly for 0.95
    lo, hi = np.percentile(draws, [tail, 100 - tail])
    return float(lo), float(hi)


def resample_indices(n: int, resamples: int, seed: int = 0) -> np.ndarray:
    """``resamples`` rows of n unit indices drawn with replacement, shape (resamples, n)."""
    return np.random.default_rng(seed).integers(0, n, size=(resamples, n))


def bootstrap_interval(d: np.ndarray, resamples: int = BOOTSTRAP_RESAMPLES, seed: int = 0,
                       confidence: float = 0.95) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of `d` (one value, or one paired difference,
    per unit)."""
    d = np.asarray(d, dtype=float)
    if len(d) < 2:
        return math.nan, math.nan
    draws = d[resample_indices(len(d), resamples, seed)].mean(axis=1)
    return _percentiles(draws, confidence)


def bootstrap_ratio(x: np.ndarray, y: np.ndarray, resamples: int = BOOTSTRAP_RESAMPLES, seed: int = 0,
                    confidence: float = 0.95) -> tuple[float, float]:
    """Paired percentile bootstrap interval of mean(x) / mean(y) (units resampled together)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if len(x) < 2:
        return math.nan, math.nan
    idx = resample_indices(len(x), resamples, seed)
    return _percentiles(x[idx].mean(axis=1) / y[idx].mean(axis=1), confidence)


def bootstrap_statistic(units: Sequence[T], statistic: Callable[[list[T]], float],
                        resamples: int, seed: int = 0, confidence: float = 0.95) -> tuple[float, float, float]:
    """A statistic of whole units that does not vectorise (such as a calibration error of pooled
    records), with its percentile bootstrap interval.

    Resample r draws its n unit indices with its own ``rng.integers(0, n, n)`` call, in order.

    Returns:
        ``(statistic(units), low, high)``; all NaN without units, NaN bounds with one.
    """
    if not units:
        return math.nan, math.nan, math.nan
    point = float(statistic(list(units)))
    if len(units) < 2:
        return point, math.nan, math.nan
    rng = np.random.default_rng(seed)
    n = len(units)
    draws = [statistic([units[i] for i in rng.integers(0, n, n)]) for _ in range(resamples)]
    lo, hi = _percentiles(draws, confidence)
    return point, lo, hi


def t_test_p(values: Iterable[Any]) -> float:
    """Two-sided p-value of the one-sample t-test that the mean is 0 (``scipy.stats.ttest_1samp``);
    NaN below two values, 1.0 when every value is 0 (no difference at all)."""
    from scipy import stats

    x = np.array([float(v) for v in values if not _missing(v)], dtype=float)
    if len(x) < 2:
        return math.nan
    if not np.any(x):
        return 1.0
    if float(x.std(ddof=1)) == 0.0:
        return 0.0
    return float(stats.ttest_1samp(x, 0.0).pvalue)


def holm(pvalues: Sequence[float]) -> list[float]:
    """Holm's step-down adjustment of p-values for `len(pvalues)` tests (NaN stays NaN and is
    not counted): the family-wise error rate is at most the level at which they are read.

    Written here rather than taken from ``statsmodels.stats.multitest.multipletests`` (which gives
    the same numbers; ``tests/test_stats_libraries.py`` checks it) because statsmodels would bring
    pandas and patsy into the core install for eight lines (docs/design.md §11).
    """
    known = sorted((p, i) for i, p in enumerate(pvalues) if not math.isnan(p))
    m, out, running = len(known), [math.nan] * len(pvalues), 0.0
    for rank, (p, i) in enumerate(known):
        running = max(running, min(1.0, (m - rank) * p))
        out[i] = running
    return out


def bonferroni_interval(values: Iterable[Any], tests: int, confidence: float = 0.95) -> Interval:
    """A Student-t interval at coverage ``1 - (1 - confidence) / tests``: simultaneous coverage of
    at least `confidence` over `tests` intervals."""
    return t_interval(values, 1.0 - (1.0 - confidence) / max(int(tests), 1))


def pairs_needed(sd: float, delta: float, confidence: float = 0.95, power: float = 0.8) -> int | None:
    """Paired worlds a two-sided t-test at `confidence` needs to detect a mean difference `delta`
    with probability `power`, given the paired differences' standard deviation `sd`:
    ``n = ((t_{1-a/2, n-1} + t_{power, n-1}) sd / delta)^2``, solved by fixed-point iteration from
    the normal approximation. None when it cannot be said (sd or delta not positive and finite).
    It agrees with statsmodels' ``TTestPower.solve_power`` rounded up (checked in
    ``tests/test_stats_libraries.py``), which is not a core dependency (see :func:`holm`).
    """
    from scipy import stats

    if not (math.isfinite(sd) and math.isfinite(delta) and sd > 0 and delta > 0):
        return None
    a = 1.0 - confidence
    n = max(2, math.ceil(((stats.norm.ppf(1 - a / 2) + stats.norm.ppf(power)) * sd / delta) ** 2))
    for _ in range(20):
        nxt = max(2, math.ceil(((stats.t.ppf(1 - a / 2, n - 1) + stats.t.ppf(power, n - 1))
                                * sd / delta) ** 2))
        if nxt == n:
            break
        n = nxt
    return n


__all__ = ["Z95", "BOOTSTRAP_RESAMPLES", "Interval", "t_interval", "wilson_interval", "resample_indices",
           "bootstrap_interval", "bootstrap_ratio", "bootstrap_statistic", "entropy", "t_test_p",
           "holm", "bonferroni_interval", "pairs_needed"]
