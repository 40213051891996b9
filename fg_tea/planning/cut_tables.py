"""The upper cut's tables, solved for every set of found objects at once (docs/design.md §6.9).

The same tables as :func:`fg_tea.planning.limit.solve_tables` with ``upper=True`` (at most ``cap``
looks per viewpoint, then a cyclic sweep), computed in another order: a look adds one to the
total count, so every state of count total t depends only on states of total t + 1, whatever
objects it finds. The recursion therefore runs layer by layer over the totals and, within a
layer, over every found set F, every look w and every outcome S at once (3^|U| pairs (F, S) with
S outside F), instead of one found set and one look at a time. The sweep values of the fully
capped state are summed for every found set and every position in one batch
(:func:`sweep_costs`), term by term as :func:`fg_tea.planning.limit._cycle_cost` sums them.

The values agree with ``solve_tables`` to rounding (tests/test_cut_tables.py); what changes is
the number of numpy calls, about 25 per layer instead of one per (found set, layer, look,
outcome), which is what a solve costs on the small problems a planner meets at every decision.
"""

from __future__ import annotations

import math

import numpy as np

from fg_tea.planning.limit import TAIL, Tables, _Grid, _tour, cut_inputs
from fg_tea.planning.problem import SearchProblem


def sweep_costs(post: np.ndarray, prob: np.ndarray, tour: np.ndarray, enter: np.ndarray,
                first: np.ndarray, between: np.ndarray, look: np.ndarray) -> np.ndarray:
    """The expected cost of sweeping `tour` cyclically until every object is found, for a batch.

    Batch member b has the posteriors ``post[b]`` (m, K) (a found object's row is all zero), enters
    the tour at its position ``first[b]`` at cost ``enter[b]`` and then follows it round; ``prob``
    (A, m, K) are the detection probabilities. Each member is summed until less than
    :data:`~fg_tea.planning.limit.TAIL` of its mass is left at the end of a round, then the rest is
    bounded geometrically, as :func:`fg_tea.planning.limit._cycle_cost` does; inf for a member
    some of whose mass no look of the tour can find.
    """
    n, size = post.shape[0], len(tour)
    if n == 0:
        return np.zeros(0)
    cycle = np.array([between[tour[i], tour[(i + 1) % size]] for i in range(size)])
    edge_max = float(cycle.max()) if size > 1 else -math.inf
    cost_max = np.maximum(edge_max, enter) + float(look.max())
    miss = 1.0 - prob
    cycle_miss = np.prod(miss[tour], axis=0)                     # (m, K)
    unseen = post.copy()
    total = np.zeros(n)
    active = np.ones(n, dtype=bool)
    out = np.full(n, np.inf)
    prev = np.full(n, -1)
    s = 0
    while active.any():
        i = s % size
        at = tour[(first + i) % size]                             # (n,) the viewpoint looked from
        travel = enter if s == 0 else between[prev, at]
        left = 1.0 - np.prod(1.0 - unseen.sum(axis=2), axis=1)   # P(search not over)
        total = np.where(active, total + (travel + look[at]) * left, total)
        unseen = np.where(active[:, None, None], unseen * miss[at], unseen)
        prev = at
        s += 1
        if i == size - 1:
            done = active & (unseen.sum(axis=(1, 2)) < TAIL)
            with np.errstate(divide="ignore", invalid="ignore"):
                tail = np.where(unseen > 0, unseen / (1.0 - cycle_miss[None]), 0.0).sum(axis=(1, 2))
            out = np.where(done, total + cost_max * size * tail, out)
            active &= ~done
        if s > 10_000 * size:
            break  # the members still active have mass no look finds: inf
    return out


class _Layout:
    """The count vectors of :class:`fg_tea.planning.limit._Grid` sorted by total looks, largest
    first, so that every layer is a slice; each state's successors in that order. It depends on
    the number of viewpoints and levels only, so it is kept (:func:`_layout`)."""

    def __init__(self, n_views: int, levels: int) -> None:
        self.grid = _Grid(n_views, levels)
        self.order = np.concatenate(self.grid.layers)              # sorted position -> C index
        self.rank = np.empty_like(self.order)
        self.rank[self.order] = np.arange(self.order.size)         # C index -> sorted position
        digits = self.grid.digits[self.order]
        after = self.order[:, None] + self.grid.stride[None, :]
        self.succ = np.where(digits < levels - 1, self.rank[np.minimum(after, self.order.size - 1)], -1)
        sizes = np.cumsum([0] + [len(layer) for layer in self.grid.layers])
        self.bounds = list(zip(sizes[:-1], sizes[1:]))


_LAYOUTS: dict[tuple[int, int], _Layout] = {}


def _layout(n_views: int, levels: int) -> _Layout:
    key = (n_views, levels)
    if key not in _LAYOUTS:
        if len(_LAYOUTS) > 16:
            _LAYOUTS.clear()
        _LAYOUTS[key] = _Layout(n_views, levels)
    return _LAYOUTS[key]


def solve_cut(problem: SearchProblem, views: np.ndarray, sites: np.ndarray, q0: np.ndarray,
              cap: int) -> Tables:
    """The tables of the upper cut at `cap` (see the module docstring), as
    :func:`fg_tea.planning.limit.solve_tables` ``(..., cap, upper=True)`` returns them."""
    prob, q, between, start, look = cut_inputs(problem, views, sites, q0)  # prob: (A, m, K)
    a, m = len(views), len(problem.objects)
    levels = cap + 1
    lay = _layout(a, levels)
    size = lay.order.size
    miss = 1.0 - np.transpose(prob, (1, 2, 0))                   # (m, K, A)
    factor = miss[..., None] ** np.arange(levels)[None, None, None, :]
    mass = lay.grid.masses(q, factor)                             # (m, N), C order
    sorted_mass = mass[:, lay.order]
    full = (1 << m) - 1
    n_found = full + 1
    found = np.array([[f >> u & 1 for u in range(m)] for f in range(n_found)], dtype=bool)  # (F, m)
    alive = np.all((sorted_mass > 0)[None] | found[:, :, None], axis=1)  # (F, N)
    values = np.zeros((n_found, a, size))                         # sorted order; F = all: 0
    flat = values.reshape(n_found, a * size)                      # a view: (F, A * N)
    column = np.arange(a)[None, :] * size                         # where each position's row starts
    finite = True
    root_q = np.full(a, np.inf)
    for lo, hi in lay.bounds:
        nxt = lay.succ[lo:hi]                                     # (n, A)
        ok = nxt >= 0
        nx = np.where(ok, nxt, 0)
        here = sorted_mass[:, lo:hi]
        with np.errstate(divide="ignore", invalid="ignore"):
            keep = np.where(here[:, :, None] > 0, sorted_mass[:, nx] / here[:, :, None], 1.0)  # (m, n, A)
        later = np.take(flat, nx + column, axis=1)                # (F', n, A): V(F', w, n + e_w)
        expect = _expectation(later, keep, finite)                # (F, n, A)
        live = alive[:, lo:hi]
        q_best = np.where(ok[None] & live[:, :, None], look[None, None, :] + expect, np.inf)
        best = np.where(live[:full, None, :], _nearest_plus(between, q_best[:full]), 0.0)
        if lo == 0:                                               # the first layer: all capped
            capped = [f for f in range(full) if alive[f, 0]]
            best[capped, :, 0] = _capped_values(q, prob, factor, cap, capped, ~found, between, look)
            finite = bool(np.isfinite(best).all())
        values[:full, :, lo:hi] = best
        if hi == size:                                            # the last layer: the start
            root_q = q_best[0, -1]
    in_c_order = {f: values[f][:, lay.rank] for f in range(n_found)}
    return Tables(float(np.min(start + root_q)), views, cap, True, in_c_order, mass,
                  lay.grid.stride, levels, between, start, look)


def _expectation(later: np.ndarray, keep: np.ndarray, finite: bool) -> np.ndarray:
    """E[V(F | S, w, n + e_w)] over the outcome S of each look, for every found set F at once.

    `later` holds V for every found set F' (bit u of F' is object u), `keep` (m, n, A) the
    chance that a look misses u. The outcome is independent per object, so the expectation
    contracts one object's axis at a time: where u is unfound the value is the mix of "u still
    unfound" (weight keep) and "u found" (1 - keep), where u is found already it stays as it is.
    """
    m = keep.shape[0]
    out = later.reshape((2,) * m + later.shape[1:]).copy()       # axis m - 1 - u: object u's bit
    for u in range(m):
        axis = m - 1 - u
        miss_u = np.take(out, 0, axis=axis)
        seen_u = np.take(out, 1, axis=axis)
        if finite:
            mixed = seen_u + keep[u] * (miss_u - seen_u)
        else:                                                      # an impossible branch adds 0
            with np.errstate(invalid="ignore"):
                mixed = (np.where(keep[u] > 0, keep[u] * miss_u, 0.0)
                         + np.where(keep[u] < 1, (1.0 - keep[u]) * seen_u, 0.0))
        index: list[slice | int] = [slice(None)] * out.ndim
        index[axis] = 0
        out[tuple(index)] = mixed
    return out.reshape(later.shape)


def _nearest_plus(between: np.ndarray, q_best: np.ndarray) -> np.ndarray:
    """min over w of between[v, w] + q_best[F, n, w], shape (F, A, n): one look at a time, which
    keeps every array (F, A, n) instead of (F, A, n, A)."""
    qt = np.ascontiguousarray(np.moveaxis(q_best, 2, 1))          # (F, A_w, n)
    best = between[None, :, 0, None] + qt[:, None, 0, :]
    step = np.empty_like(best)
    for w in range(1, qt.shape[1]):
        np.add(between[None, :, w, None], qt[:, None, w, :], out=step)
        np.minimum(best, step, out=best)
    return best


def _capped_values(q: np.ndarray, prob: np.ndarray, factor: np.ndarray, cap: int | np.ndarray,
                   live: list[int], unfound: np.ndarray, between: np.ndarray, look: np.ndarray) -> np.ndarray:
    """The sweep's value at the fully capped state for the found sets `live`, shape (|live|, A):
    from each position, enter the nearest-neighbour tour at its nearest viewpoint. `cap` is one
    cap or one per viewpoint."""
    a = between.shape[0]
    if not live:
        return np.zeros((0, a))
    post = factor[:, :, np.arange(a), cap].prod(axis=2) * q      # (m, K)
    rows = []
    for f in live:
        p = np.where(unfound[f][:, None], post, 0.0)
        rows.append(p / np.where(p.sum(axis=1, keepdims=True) > 0, p.sum(axis=1, keepdims=True), 1.0))
    tour = _tour(between)
    first = np.argmin(between[:, tour], axis=1)                  # (A,) per position
    enter = between[np.arange(a), tour[first]]
    batch_post = np.repeat(np.stack(rows), a, axis=0)             # (|live| * A, m, K)
    batch_first = np.tile(first, len(live))
    batch_enter = np.tile(enter, len(live))
    out = sweep_costs(batch_post, prob, tour, batch_enter, batch_first, between, look)
    return out.reshape(len(live), a)


__all__ = ["solve_cut", "sweep_costs"]
