"""The search limit under imperfect detection (fg_tea/planning/limit.py, docs/design.md §6.9):
its bounds against closed forms, the perfect-detection DP and a brute-force expectimax."""

from __future__ import annotations

import itertools
from functools import lru_cache

import numpy as np
import pytest

from fg_tea.planning import bracket, limit
from fg_tea.planning.problem import SearchProblem
from fg_tea.planning.optimal import expected_travel_table
from limit_problems import make_problem as _problem, random_problem as _random_problem


def _brute(problem: SearchProblem, cap, upper: bool) -> float:
    """Expectimax over the explicit truth table, with the solver's cut: past `cap` looks from a
    viewpoint (one number, or a tuple with one per viewpoint), a perfect look (lower) or no look
    but the cyclic sweep (upper)."""
    prob, q0 = problem.prob, problem.factors
    a, m, k = prob.shape
    truths = list(itertools.product(range(k), repeat=m))
    prior = np.array([np.prod([q0[u, t[u]] for u in range(m)]) for t in truths])
    tour = limit._tour(problem.between)

    @lru_cache(maxsize=None)
    def value(pos, counts, found, weights):
        w = np.array(weights)
        unfound = [u for u in range(m) if not found >> u & 1]
        if not unfound or w.sum() <= 0:
            return 0.0
        options = []
        for v in range(a):
            cap_v = cap[v] if isinstance(cap, tuple) else cap
            if counts[v] >= (cap_v if upper else cap_v + 1):
                continue
            perfect = not upper and counts[v] == cap_v
            cost = (problem.start[v] if pos < 0 else problem.between[pos, v]) + problem.look[v]
            expect = 0.0
            for s in itertools.product((0, 1), repeat=len(unfound)):
                lik = np.ones(len(truths))
                for seen, u in zip(s, unfound):
                    p = np.array([prob[v, u, t[u]] for t in truths])
                    p = np.where(p > 0, 1.0, 0.0) if perfect else p
                    lik = lik * (p if seen else 1.0 - p)
                nw = w * lik
                if nw.sum() <= 1e-300:
                    continue
                nf = found | sum(1 << u for seen, u in zip(s, unfound) if seen)
                nc = tuple(c + (i == v) for i, c in enumerate(counts))
                expect += nw.sum() / w.sum() * value(v, nc, nf, tuple(nw))
            options.append(cost + expect)
        if options:
            return min(options)
        post = np.array([[w[[i for i, t in enumerate(truths) if t[u] == j]].sum() for j in range(k)]
                         for u in unfound]) / w.sum()
        first = int(np.argmin(problem.between[pos, tour]))
        return limit._cycle_cost(post, prob[:, unfound, :], np.roll(tour, -first),
                                 float(problem.between[pos, tour[first]]), problem.between, problem.look)

    return value(-1, (0,) * a, 0, tuple(prior))


def test_one_site_has_closed_forms():
    """Keep looking at the one site: V* = d + c / p; the lower bound stops paying after cap + 1."""
    p, d, c = 0.95, 2.0, 0.5
    problem = _problem([[[p]]], [[1.0]], [d], [[0.0]], [c])
    views, sites, q0 = limit._useful(problem)
    for cap in (1, 2, 3):
        lo = bracket._solve(problem, views, sites, q0, cap, upper=False)
        hi = bracket._solve(problem, views, sites, q0, cap, upper=True)
        assert lo == pytest.approx(d + c * (1 - (1 - p) ** (cap + 1)) / p, abs=1e-12)
        assert hi == pytest.approx(d + c / p, abs=1e-9)
    found = bracket.search_limit(problem, tolerance=1e-6)
    assert found.lower <= d + c / p <= found.upper and found.width <= 1e-6


@pytest.mark.parametrize("seed", range(4))
def test_perfect_detection_equals_the_perfect_detection_dp(seed):
    rng = np.random.default_rng(seed)
    m, k = (1, 2, 2, 3)[seed], (5, 4, 5, 4)[seed]
    problem = _random_problem(rng, k, m, k, perfect=True, glance=False)
    loc = np.array(list(itertools.product(range(k), repeat=m)))
    p = np.prod(problem.factors[np.arange(m)[None, :], loc], axis=1)
    dp = float(expected_travel_table(problem.start, problem.between, loc, p).min())
    found = bracket.search_limit(problem)
    assert found.lower == pytest.approx(dp, abs=1e-9) and found.upper == pytest.approx(dp, abs=1e-9)


@pytest.mark.parametrize("seed,m,cap", [(0, 1, 1), (1, 1, 2), (2, 2, 1), (3, 2, 2), (4, 2, 1), (5, 2, 0), (6, 1, 0)])
def test_both_cuts_equal_a_brute_force_expectimax(seed, m, cap):
    rng = np.random.default_rng(100 + seed)
    problem = _random_problem(rng, 3, m, 2 if cap == 2 and m == 2 else 3)
    views, sites, q0 = limit._useful(problem)
    for upper in (False, True) if cap else (False,):  # cap 0: the lower cut's perfect first look
        solved = bracket._solve(problem, views, sites, q0, cap, upper=upper)
        assert solved == pytest.approx(_brute(problem, cap, upper), rel=1e-12, abs=1e-12), upper


@pytest.mark.parametrize("seed,m,caps", [(20, 1, (0, 2, 1, 2)), (21, 2, (1, 0, 1, 3)), (22, 2, (2, 1, 0, 1)),
                                         (23, 1, (1, 1, 1, 4))])
def test_caps_per_viewpoint_equal_a_brute_force_expectimax(seed, m, caps):
    """A cap for each viewpoint (more looks where detection is poor: the last viewpoint is a
    glance over two sites) bounds the same way."""
    rng = np.random.default_rng(100 + seed)
    problem = _random_problem(rng, 3, m, 3)
    views, sites, q0 = limit._useful(problem)
    assert list(views) == [0, 1, 2, 3]
    for upper in (False, True):
        if upper and 0 in caps:
            continue  # an upper cut allows at least one look from each viewpoint
        solved = bracket._solve(problem, views, sites, q0, caps, upper=upper)
        assert solved == pytest.approx(_brute(problem, caps, upper), rel=1e-12, abs=1e-12), upper
    lows = bracket._solve(problem, views, sites, q0, caps, upper=False)
    uniform = bracket._solve(problem, views, sites, q0, max(caps), upper=False)
    assert lows <= uniform + 1e-12  # fewer looks before the perfect one: a looser lower bound


def test_the_limit_pairs_each_upper_cut_with_the_lower_cut_one_cap_below():
    """Both count 0 to c looks per viewpoint (the same tables): a budget that holds only that
    many stops at the pair, whose bracket is the narrowest of the cuts that fit."""
    rng = np.random.default_rng(11)
    problem = _random_problem(rng, 4, 2, 4)
    views, sites, q0 = limit._useful(problem)
    budget = limit.table_bytes(views.size, 2, sites.size, 3)
    found = bracket.search_limit(problem, tolerance=0.0, max_bytes=budget)
    assert (found.cap, found.lower_cap) == (2, 1) and found.entries >= 3 ** views.size * views.size * 4
    lows = [bracket._solve(problem, views, sites, q0, c, upper=False) for c in (0, 1)]
    highs = [bracket._solve(problem, views, sites, q0, c, upper=True) for c in (1, 2)]
    assert found.lower >= max(lows) and found.upper <= min(highs)
    assert found.caps == () or (found.lower, found.upper) != (max(lows), min(highs))
    assert limit.table_bytes(views.size, 2, sites.size, 4) > budget  # the lower cut at cap 2 did not fit


def test_caps_per_viewpoint_go_where_looks_miss_and_narrow_the_bracket():
    """The glance (detecting 10-50 %) gets more looks before the cut than the close looks
    (60-97 %), within the same memory (full tables or two layers of them, whichever fits), and the
    bracket is at least as narrow as the uniform one."""
    rng = np.random.default_rng(3)
    problem = _random_problem(rng, 3, 1, 3)
    views, sites, q0 = limit._useful(problem)
    budget = limit.table_bytes(views.size, 1, sites.size, 4)
    caps = bracket.view_caps(problem, views, sites, q0, max_bytes=budget)
    assert caps[3] > caps[:3].max() and bracket.pair_fits(views.size, 1, sites.size, caps + 1, budget)
    found = bracket.search_limit(problem, tolerance=0.0, max_bytes=budget)
    uniform = [bracket._solve(problem, views, sites, q0, c, upper=u) for c, u in ((2, False), (3, True))]
    assert found.lower >= uniform[0] and found.upper <= uniform[1]
    assert found.caps == tuple(caps) and found.width < uniform[1] - uniform[0]


def test_the_bounds_bracket_and_tighten_with_the_cap():
    rng = np.random.default_rng(7)
    problem = _random_problem(rng, 4, 2, 4)
    views, sites, q0 = limit._useful(problem)
    lows = [bracket._solve(problem, views, sites, q0, c, upper=False) for c in (1, 2, 3)]
    highs = [bracket._solve(problem, views, sites, q0, c, upper=True) for c in (1, 2, 3)]
    assert all(lo <= hi + 1e-12 for lo in lows for hi in highs)
    assert lows == sorted(lows) and highs == sorted(highs, reverse=True)
    found = bracket.search_limit(problem, tolerance=0.05, max_bytes=2_000_000)
    assert found.lower >= lows[0] and found.upper <= highs[0] and found.width <= highs[0] - lows[0]


def test_a_correlated_or_too_large_problem_is_refused_with_one_line():
    rng = np.random.default_rng(1)
    problem = _random_problem(rng, 3, 1, 3)
    joint = SearchProblem(problem.objects, problem.names, problem.kinds, problem.probability,
                          problem.start, problem.between, problem.look, problem.p_max,
                          problem.n_sites, problem.allowed, problem.factors[0], None)
    assert "correlated" in bracket.limit_fault(joint)
    with pytest.raises(ValueError, match="more than 100 B"):
        bracket.search_limit(problem, max_bytes=100)
