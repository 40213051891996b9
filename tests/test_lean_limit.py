"""The limit's root value with two layers in memory (fg_tea/planning/lean_limit.py,
docs/design.md §6.9): the same root as the full tables for both cuts, one cap or one per
viewpoint, and a memory estimate that matches what the solve allocates."""

from __future__ import annotations

import itertools
import tracemalloc

import numpy as np
import pytest
from limit_problems import blind_problem, random_problem

from fg_tea.planning import lean_limit
from fg_tea.planning.lean_limit import Layers, lean_bytes, solve_root
from fg_tea.planning.limit import _useful, solve_tables


def test_layers_number_every_vector_of_a_total_in_c_order():
    levels = np.array([3, 2, 4, 1, 3])
    layers = Layers(levels)
    every = np.array(list(itertools.product(*[range(int(lv)) for lv in levels])))
    for total in range(layers.top + 1):
        want = every[every.sum(axis=1) == total]  # itertools.product is C order
        assert layers.size(total) == len(want)
        got = layers.unrank(total, np.arange(len(want)))
        assert np.array_equal(got, want)
        assert np.array_equal(layers.rank(total, want), np.arange(len(want)))
        successors = layers.successors(total, want)
        for w in range(levels.size):
            rows = np.flatnonzero(want[:, w] < levels[w] - 1)
            moved = want[rows].copy()
            moved[:, w] += 1
            above = every[every.sum(axis=1) == total + 1]
            expected = [int(np.flatnonzero((above == row).all(axis=1))[0]) for row in moved]
            assert np.array_equal(successors[rows, w], expected)
    assert layers.size(layers.top + 1) == 0 and layers.size(-1) == 0


def _same_root(problem, cap, upper):
    views, sites, q0 = _useful(problem)
    want = solve_tables(problem, views, sites, q0, cap, upper).root
    got = solve_root(problem, views, sites, q0, cap, upper)
    assert got == pytest.approx(want, rel=1e-10, abs=1e-12)
    return got


@pytest.mark.parametrize("seed", range(8))
def test_the_root_equals_the_full_tables_for_both_cuts(seed, monkeypatch):
    """Random problems of 1-3 objects, with and without a glance over two sites, one cap and
    one per viewpoint; a small step size makes every layer take several steps."""
    monkeypatch.setattr(lean_limit, "CHUNK", 7)
    rng = np.random.default_rng(seed)
    m, k = 1 + seed % 3, 3 + seed % 2
    problem = random_problem(rng, k, m, k, glance=bool(seed % 2))
    a = _useful(problem)[0].size
    for cap in (0, 1, 2):
        _same_root(problem, cap, upper=False)
        _same_root(problem, cap + 1, upper=True)
    caps = rng.integers(1, 4, size=a)
    _same_root(problem, caps, upper=True)
    _same_root(problem, caps - 1, upper=False)


def test_states_of_no_probability_and_a_blind_look_give_the_same_root():
    problem = blind_problem()
    for cap in (1, 2, 3):
        _same_root(problem, cap, upper=True)
        _same_root(problem, cap - 1, upper=False)


@pytest.mark.parametrize("m, cap", [(1, 3), (3, 2)])
def test_the_memory_estimate_matches_the_peak_allocation(m, cap):
    """Within a factor of 1.5 of the peak numpy reports, on a problem whose widest layer is
    larger than one step."""
    rng = np.random.default_rng(3)
    problem = random_problem(rng, 9, m, 9, glance=False)
    views, sites, q0 = _useful(problem)
    tracemalloc.start()
    solve_root(problem, views, sites, q0, cap, upper=True)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    estimate = lean_bytes(views.size, m, cap + 1)
    assert peak / 1.5 <= estimate <= 1.5 * peak, (estimate, peak)


def test_the_bracket_reaches_a_cap_only_two_layers_fit_and_agrees_with_the_full_tables(monkeypatch):
    """A budget below the full tables of the pair at cap 2 but above two layers of them: the bracket goes to cap 2 through the layered solve, with the ends the
    full tables give."""
    from fg_tea.planning import bracket
    from fg_tea.planning.limit import table_bytes

    monkeypatch.setattr(lean_limit, "CHUNK", 64)
    rng = np.random.default_rng(5)
    problem = random_problem(rng, 10, 2, 10, glance=False)
    views, sites, q0 = _useful(problem)
    budget = lean_bytes(views.size, 2, 3)
    assert table_bytes(views.size, 2, sites.size, 3) > budget
    found = bracket.search_limit(problem, tolerance=0.0, max_bytes=budget, max_cap=2)
    assert (found.cap, found.lower_cap) == (2, 1)
    assert found.lower >= solve_tables(problem, views, sites, q0, 1, False).root - 1e-12
    assert found.upper <= solve_tables(problem, views, sites, q0, 2, True).root + 1e-12
    assert bracket.limit_fault(problem, budget) is None
    small = min(lean_bytes(views.size, 2, 2), table_bytes(views.size, 2, sites.size, 2)) - 1
    assert "more than" in bracket.limit_fault(problem, small)
