"""Replication statistics (fg_tea.common.stats): Holm, Bonferroni, t-test p-values, power."""

from __future__ import annotations

import math

import numpy as np
import pytest


def test_holm_adjusts_step_down_and_keeps_nan():
    from fg_tea.common.stats import holm

    assert holm([0.01, 0.04, 0.03, math.nan])[:3] == pytest.approx([0.03, 0.06, 0.06])
    assert math.isnan(holm([0.01, 0.04, 0.03, math.nan])[3])
    assert holm([0.5, 0.9]) == [1.0, 1.0] and holm([]) == []


def test_pairs_needed_gives_the_power_it_promises():
    """Simulated: a t-test on pairs_needed(sd, delta) draws of N(delta, sd) rejects ~80 % of the time."""
    from fg_tea.common.stats import pairs_needed, t_test_p

    n = pairs_needed(2.0, 0.5)
    rng = np.random.default_rng(0)
    power = np.mean([t_test_p(rng.normal(0.5, 2.0, n)) < 0.05 for _ in range(2000)])
    assert 0.76 <= power <= 0.84, (n, power)
    assert pairs_needed(0.0, 1.0) is None and pairs_needed(1.0, float("nan")) is None


def test_a_bonferroni_interval_is_wider_and_a_t_test_p_matches_scipy():
    from scipy import stats as sps

    from fg_tea.common.stats import bonferroni_interval, t_interval, t_test_p

    x = [0.3, -0.2, 1.1, 0.7, 0.4, 0.0]
    one, five = t_interval(x), bonferroni_interval(x, 5)
    assert five.low < one.low < one.high < five.high and five.mean == one.mean
    assert t_test_p(x) == pytest.approx(sps.ttest_1samp(x, 0.0).pvalue)
    assert t_test_p([0.0, 0.0, 0.0]) == 1.0 and math.isnan(t_test_p([1.0]))
