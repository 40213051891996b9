"""The lower bound at any size (fg_tea/planning/limit_bound.py, docs/design.md §6.9)."""

from __future__ import annotations

import numpy as np
import pytest

from fg_tea.planning.bracket import search_limit
from fg_tea.planning.limit_bound import busy_bound, lower_bound

from limit_problems import make_problem, random_problem


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_bound_below_the_exact_limit_on_random_problems():
    rng = np.random.default_rng(7)
    checked, ratios = 0, []
    for trial in range(60):
        k = int(rng.integers(2, 5))
        m = int(rng.integers(1, 3))
        problem = random_problem(rng, k, m, k, perfect=bool(trial % 4 == 0), glance=bool(trial % 2))
        limit = search_limit(problem, tolerance=1e-3, max_cap=6)
        bound = lower_bound(problem)
        assert 0.0 < bound <= limit.lower * (1 + 1e-12) + 1e-12, (trial, bound, limit)
        ratios.append(bound / limit.lower)
        checked += 1
    assert checked == 60
    assert max(ratios) > 0.9  # not a trivial bound: on some problems it comes close to the limit


def test_bound_by_hand():
    # viewpoint 0 sees every site, viewpoint 1 only site 0; V* = 3.5 either way. Looks cost at
    # least 2.5 (viewpoint 0, arriving from 1) and 1.5: the busy-time sum is 2.5 / 2 for all the
    # mass at 2.5, and half of the cheapest showing look per site, 0.2 * 1.5 + 0.8 * 2.5, adds 1.15
    prob = np.ones((2, 2, 3))
    prob[1] = 0.0
    prob[1, :, 0] = 1.0
    problem = make_problem(prob, [[0.2, 0.3, 0.5], [0.6, 0.2, 0.2]], [3.0, 1.0], [[0, 2.0], [2.0, 0]], [0.5, 0.5])
    assert lower_bound(problem) == pytest.approx(1.25 + 1.15)
    assert search_limit(problem).lower == pytest.approx(3.5)
    assert lower_bound(problem) <= search_limit(problem).lower + 1e-12


def test_busy_bound_closed_form():
    # two looks of cost 1 covering half the mass each: integral of 1 - tau/2 over [0, 2] = 1
    assert busy_bound(np.array([0.5, 0.5]), np.array([1.0, 1.0])) == pytest.approx(1.0)
    # the cheaper-per-mass look goes first: mass 0.8 at cost 1, then 0.2 at cost 4
    assert busy_bound(np.array([0.2, 0.8]), np.array([4.0, 1.0])) == pytest.approx(1 - 0.4 + 4 * (0.2 - 0.1))


def test_correlated_belief_is_refused():
    problem = random_problem(np.random.default_rng(0), 3, 2, 3)
    problem.joint, problem.factors = np.full((3, 3), 1 / 9), None
    with pytest.raises(ValueError, match="correlated"):
        lower_bound(problem)


def test_bound_is_the_optimum_when_one_look_shows_everything():
    # one viewpoint shows every site perfectly: V* is the walk there and one look, and so is the bound
    problem = make_problem(np.ones((1, 1, 3)), [[0.2, 0.3, 0.5]], [2.0], [[0.0]], [0.5])
    assert lower_bound(problem) == pytest.approx(2.5)
    assert search_limit(problem).lower == pytest.approx(2.5)
