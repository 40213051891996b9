"""Do the project's statistics give the numbers the libraries give?

Wilson intervals come from scipy; Holm's adjustment and the pairs a paired t-test needs are
written in fg_tea/common/stats.py (statsmodels is not a core dependency, docs/design.md §11) and
are checked here against statsmodels, which the test install has.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fg_tea.common.stats import Z95, holm, pairs_needed, wilson_interval

statsmodels = pytest.importorskip("statsmodels")


def test_wilson_matches_the_closed_form():
    for n in (1, 2, 7, 40, 1000):
        for k in range(0, n + 1, max(1, n // 9)):
            p = k / n
            centre = (p + Z95 ** 2 / (2 * n)) / (1 + Z95 ** 2 / n)
            half = Z95 * math.sqrt(p * (1 - p) / n + Z95 ** 2 / (4 * n * n)) / (1 + Z95 ** 2 / n)
            got = wilson_interval(k, n)
            assert got.mean == p and got.n == n
            assert got.low == pytest.approx(centre - half, abs=1e-12)
            assert got.high == pytest.approx(centre + half, abs=1e-12)
    assert math.isnan(wilson_interval(0, 0).mean)


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_holm_is_statsmodels_holm():
    from statsmodels.stats.multitest import multipletests

    rng = np.random.default_rng(7)
    for _ in range(40):  # statsmodels takes about 15 ms a call
        p = rng.uniform(0, 0.3, size=int(rng.integers(1, 15)))
        assert holm(list(p)) == pytest.approx(list(multipletests(p, method="holm")[1]), abs=1e-15)
    assert math.isnan(holm([0.01, math.nan])[1])


@pytest.mark.parametrize("sd,delta", [(1, 0.5), (3, 1), (10, 1), (2, 0.2), (5, 0.3), (1.5, 2.0)])
def test_pairs_needed_is_statsmodels_power_rounded_up(sd, delta):
    from statsmodels.stats.power import TTestPower

    exact = TTestPower().solve_power(effect_size=delta / sd, alpha=0.05, power=0.8)
    assert pairs_needed(sd, delta) == max(2, math.ceil(exact))
