"""The bracket of the search limit: raise the cuts' caps while memory allows (docs/design.md §6.9).

:func:`search_limit` solves the pairs of cuts of :mod:`fg_tea.planning.limit` (the upper cut at
cap c and the lower at c - 1 count the same 0 to c looks per viewpoint) from c = 1 up, until
the bracket is narrower than the tolerance or the next pair would not fit the memory budget;
then, where it helps, once more with a cap per viewpoint (:func:`view_caps`). Each solve uses
the full tables where they fit and two layers at a time (:mod:`fg_tea.planning.lean_limit`)
where only those do, which reaches one more look per viewpoint at 12 to 16 viewpoints.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from fg_tea.planning.lean_limit import MAX_WORK, lean_bytes, lean_states, solve_root
from fg_tea.planning.limit import MAX_BYTES, Limit, _entries, _useful, human_bytes, solve_tables, table_bytes
from fg_tea.planning.problem import SearchProblem


def limit_fault(problem: SearchProblem, max_bytes: int = MAX_BYTES) -> str | None:
    """Why :func:`search_limit` cannot answer `problem`, or None: a correlated belief (the state
    above is exact only for independent objects) or a solve too large even at one look per
    viewpoint."""
    if not problem.independent:
        return ("search limit: the belief is correlated; the limit is exact for independent "
                "objects only (a factorised model)")
    views, sites, _ = _useful(problem)
    a, m = views.size, len(problem.objects)
    need = pair_bytes(a, m, sites.size, 2)
    if not pair_fits(a, m, sites.size, 2, max_bytes):
        return (f"search limit: {a} viewpoints and {m} objects need about {human_bytes(need)} "
                f"at one look per viewpoint, more than {human_bytes(max_bytes)}")
    return None


def _solve(problem: SearchProblem, views: np.ndarray, sites: np.ndarray, q0: np.ndarray,
           cap: int | Sequence[int] | np.ndarray, upper: bool, max_bytes: int = MAX_BYTES) -> float:
    """The root value of the cut problem (:mod:`fg_tea.planning.limit`); ``upper`` picks the cut.
    From the full tables where they fit `max_bytes`, else from two layers at a time
    (:func:`~fg_tea.planning.lean_limit.solve_root`): the same value."""
    a, m = views.size, len(problem.objects)
    caps = np.broadcast_to(np.asarray(cap, dtype=np.int64), (a,))
    if table_bytes(a, m, sites.size, caps + (1 if upper else 2)) <= max_bytes:
        return solve_tables(problem, views, sites, q0, cap, upper).root
    return solve_root(problem, views, sites, q0, np.asarray(cap), upper)


def pair_bytes(n_views: int, n_objects: int, n_sites: int, levels: int | np.ndarray) -> int:
    """The memory a pair of cuts with ``levels`` counts per viewpoint needs, bytes: the full
    tables' (:func:`~fg_tea.planning.limit.table_bytes`) or, where less, two layers'
    (:func:`~fg_tea.planning.lean_limit.lean_bytes`), as :func:`_solve` chooses."""
    return min(table_bytes(n_views, n_objects, n_sites, levels), lean_bytes(n_views, n_objects, levels))


def pair_fits(n_views: int, n_objects: int, n_sites: int, levels: int | np.ndarray, max_bytes: int) -> bool:
    """Whether a pair of cuts fits `max_bytes` (:func:`pair_bytes`) and, where only two layers fit,
    the solve's work (:data:`~fg_tea.planning.lean_limit.MAX_WORK`)."""
    if table_bytes(n_views, n_objects, n_sites, levels) <= max_bytes:
        return True
    work = lean_states(n_views, levels) * 2 ** n_objects
    return lean_bytes(n_views, n_objects, levels) <= max_bytes and work <= MAX_WORK


def search_limit(problem: SearchProblem, tolerance: float = 1e-3, max_bytes: int = MAX_BYTES,
                 max_cap: int = 12, progress: Callable[[str], None] | None = None) -> Limit:
    """Bracket the optimal expected search cost of `problem` (see the module docstring).

    Args:
        problem: a search problem with a factorised belief (``problem.factors``).
        tolerance: stop raising the cap once ``upper - lower`` is at most this (metres).
        max_bytes: the most memory one solve may use (as :func:`table_bytes` estimates it).
        max_cap: the largest cap tried.
        progress: called with a line after each pair of cuts (a long solve says where it is).

    Raises:
        ValueError: :func:`limit_fault` says why the problem cannot be answered.
    """
    fault = limit_fault(problem, max_bytes)
    if fault:
        raise ValueError(fault)
    views, sites, q0 = _useful(problem)
    a, m = views.size, len(problem.objects)
    best: Limit | None = None
    # The upper cut at cap c and the lower cut at cap c - 1 both count 0 to c looks per
    # viewpoint: the same tables, so the same memory; each step raises both by one.
    for cap in range(1, max_cap + 1):
        if not pair_fits(a, m, sites.size, cap + 1, max_bytes) and best is not None:
            break
        lo = _solve(problem, views, sites, q0, cap - 1, upper=False, max_bytes=max_bytes)
        hi = _solve(problem, views, sites, q0, cap, upper=True, max_bytes=max_bytes)
        lo_best = lo if best is None else max(lo, best.lower)
        hi_best = hi if best is None else min(hi, best.upper)
        best = Limit(lo_best, hi_best, cap, _entries(a, m, cap + 1), a, m, cap - 1)
        if progress is not None:
            progress(f"caps {cap - 1} and {cap}: [{lo:.6f}, {hi:.6f}] m")
        if best.width <= tolerance:
            break
    assert best is not None
    caps = view_caps(problem, views, sites, q0, max_bytes, max_cap)
    if best.width > tolerance and caps.min() != caps.max():
        lo = _solve(problem, views, sites, q0, caps - 1, upper=False, max_bytes=max_bytes)
        hi = _solve(problem, views, sites, q0, caps, upper=True, max_bytes=max_bytes)
        if progress is not None:
            progress(f"caps {', '.join(map(str, caps))} per viewpoint: [{lo:.6f}, {hi:.6f}] m")
        if lo > best.lower or hi < best.upper:
            best = Limit(max(lo, best.lower), min(hi, best.upper), best.cap,
                         max(best.entries, _entries(a, m, caps + 1)), a, m, best.lower_cap,
                         tuple(int(c) for c in caps))
    return best


def view_caps(problem: SearchProblem, views: np.ndarray, sites: np.ndarray, q0: np.ndarray,
              max_bytes: int = MAX_BYTES, max_cap: int = 12) -> np.ndarray:
    """Upper-cut caps per useful viewpoint that fill the memory budget where looks miss most.

    From a cap of 1 everywhere, the viewpoint whose next look past its cap would find the most
    (sum over objects and sites of q0 (1 - p)^cap p: the prior mass that look alone shows) gets
    one more, while the pair of cuts (:func:`search_limit`) still fits `max_bytes`: a room glance
    that detects one time in three gets several looks before the cut, a close look that detects
    19 times in 20 one or two. Any caps give valid bounds; these spend the memory where a cut
    would otherwise bind.
    """
    prob = problem.prob[np.ix_(views, np.arange(len(problem.objects)), sites)]   # (A, U, K)
    q = q0[None, :, sites]
    a, m = views.size, len(problem.objects)
    caps = np.ones(a, dtype=np.int64)
    while True:
        gain = (q * (1.0 - prob) ** caps[:, None, None] * prob).sum(axis=(1, 2))  # (A,)
        for v in sorted(range(a), key=lambda v: (-gain[v], v)):
            if gain[v] <= 0 or caps[v] >= max_cap:
                continue
            trial = caps.copy()
            trial[v] += 1
            if pair_fits(a, m, sites.size, trial + 1, max_bytes):
                caps = trial
                break
        else:
            return caps


__all__ = ["limit_fault", "pair_bytes", "pair_fits", "search_limit", "view_caps"]
