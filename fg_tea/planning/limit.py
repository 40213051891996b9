"""The search limit under imperfect detection: the least expected cost of finding every object.

A yardstick, not a planner (docs/design.md §6.9). Given the search problem one decision solves
(:class:`fg_tea.planning.lookahead.SearchProblem`: viewpoints, the chance ``p_{u,k}(v)`` that a look
from v shows object u standing at site k, travel between viewpoints and a cost per image), it
brackets the optimal expected cost

    V* = min over adaptive policies of E[travel + look cost until every object is found]

from both sides, when the objects are independent under the belief (a factorised belief) and
looks detect independently given where the objects stand, as the agent's model says.

**State.** Under these assumptions the belief after any history is fixed by three things: the
viewpoint the agent stands at, the number of looks n_v made from each viewpoint v (every look so
far missed every object still unfound) and the set F of objects found. An unfound u stands at k
with probability proportional to ``q0_u(k) prod_v (1 - p_{u,k}(v))^{n_v}``; write M_u(n) for the
sum of that over k. A look from v then misses u with probability M_u(n + e_v) / M_u(n), for each
unfound u independently, so the outcome (which objects it finds) has a product distribution and

    V(v, n, F) = min_w [ travel(v, w) + look(w) + sum_S P(S) V(w, n + e_w, F + S) ]

with V = 0 once F holds every object. Counts only grow, so the recursion runs backwards over
count vectors, layer by layer, vectorised over all count vectors of a layer.

**Bounds.** Counts are unbounded, so the state space is cut at ``cap`` looks per viewpoint, two
ways:

- *lower*: the look that takes n_v past ``cap`` is made perfect (it shows every object standing
  at a site in view with probability 1). A more informative look at the same cost can only help,
  so the value is at most V*;
- *upper*: no viewpoint is looked from more than ``cap`` times until every viewpoint has been;
  from there on the agent sweeps every viewpoint in a fixed cyclic order, whose expected cost is
  summed exactly, with a geometric bound on the tail. This is the value of a real policy, so it
  is at least V*.

Both tighten as ``cap`` grows. The upper cut at cap c and the lower cut at cap c - 1 count the
same 0 to c looks per viewpoint, so they cost the same memory: the bracket
(:func:`fg_tea.planning.bracket.search_limit`) pairs them (the lower cut at cap 0 makes the
first look from each viewpoint perfect) and raises c until the interval is narrower than
``tolerance`` or the next pair would not fit its memory budget, as :func:`table_bytes`
estimates the full tables (checked against the measured peak allocation, tested) and
:func:`fg_tea.planning.lean_limit.lean_bytes` two layers of them. With a perfect detector (p = 1
at every site in view) both equal the perfect-detection dynamic program of
:mod:`fg_tea.planning.optimal` (tested), and on small problems they equal a brute-force
expectimax over the truth table with the same cuts (tested).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from fg_tea.planning.problem import SearchProblem

#: Memory one solve may use, bytes, as :func:`table_bytes` estimates it (2 GiB).
MAX_BYTES = 2 * 1024 ** 3
TAIL = 1e-12  # the cyclic sweep is summed until this much probability is left, then bounded


@dataclass(frozen=True)
class Limit:
    """The bracketed optimal expected cost of a search problem (metres-equivalent).

    Attributes:
        lower: a lower bound of V* (perfect looks past the lower cut's cap).
        upper: an upper bound of V* (the capped policy, then a cyclic sweep).
        cap: looks per viewpoint the (uniform) upper cut allows before its sweep.
        entries: table entries of the larger of the two solves.
        viewpoints: viewpoints that can find something (the others are never worth a look).
        objects: objects searched.
        lower_cap: looks per viewpoint after which the lower cut's looks are perfect (one less
            than ``cap``: both cuts then count 0 to ``cap`` looks per viewpoint, the same tables).
        caps: where caps per viewpoint (:func:`~fg_tea.planning.bracket.view_caps`) narrowed the bracket, the upper
            cut's cap of each useful viewpoint (the lower cut's are one less); each end of the
            bracket is the tighter of the two cuts'; else empty.
    """

    lower: float
    upper: float
    cap: int
    entries: int
    viewpoints: int
    objects: int
    lower_cap: int = -1
    caps: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if self.lower_cap < 0:
            object.__setattr__(self, "lower_cap", self.cap - 1)

    @property
    def width(self) -> float:
        """upper - lower: how precisely V* is known."""
        return self.upper - self.lower


def _entries(n_views: int, n_objects: int, levels: int | Sequence[int] | np.ndarray) -> int:
    per = np.broadcast_to(np.asarray(levels, dtype=np.int64), (n_views,))
    return int(np.prod(per)) * n_views * 2 ** n_objects


def table_bytes(n_views: int, n_objects: int, n_sites: int, levels: int | Sequence[int] | np.ndarray) -> int:
    """The peak memory of one solve (:func:`solve_tables`), bytes, with ``levels`` counts per
    viewpoint (``cap + 1`` for the upper cut, ``cap + 2`` for the lower; one number, or one per
    viewpoint).

    The larger of two phases: building the grid (the count digits and successor indices, three
    integer arrays of count vectors x viewpoints alive at once, and the masses' running product
    over sites) and the end of the solve (a float per table entry, the successor indices and the
    masses, and the widest layer's travel-plus-Q array). Checked against the peak allocation
    numpy reports to tracemalloc: within 20 % of it on problems of 5 to 9 viewpoints
    (tests/test_limit_honest.py).
    """
    per = np.broadcast_to(np.asarray(levels, dtype=np.int64), (n_views,))
    n = int(np.prod(per))
    # the widest layer (count vectors of equal total): the largest coefficient of prod_v (1 + .. + x^(l_v - 1))
    poly = np.ones(1, dtype=np.int64)
    for lv in per:
        poly = np.convolve(poly, np.ones(int(lv), dtype=np.int64))
    layer = int(poly.max())
    build = 26 * n * n_views + 16 * n * n_sites + 8 * n * n_objects
    solve = (8 * _entries(n_views, n_objects, levels) + 10 * n * n_views + 8 * n * n_objects
             + 8 * layer * n_views * (n_views + 2))
    return int(max(build, solve))


def human_bytes(n: float) -> str:
    """``1.5 GB``, ``260 MB``: decimal units, for messages."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{int(n)} B"


def _useful(problem: SearchProblem) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(viewpoints that can show some object where it may stand, open sites with mass, q0)."""
    q0 = np.asarray(problem.factors, dtype=float)
    q0 = q0 / q0.sum(axis=1, keepdims=True)
    prob = problem.prob  # (A, U, K')
    sites = np.flatnonzero(q0.sum(axis=0) > 0)
    views = np.flatnonzero((prob[:, :, sites] * q0[None, :, sites]).sum(axis=(1, 2)) > 0)
    return views, sites, q0


class _Grid:
    """Count vectors over the useful viewpoints in C order: ``levels`` values each (one number),
    or ``levels[v]`` values for viewpoint v (a mixed radix)."""

    def __init__(self, n_views: int, levels: int | np.ndarray):
        self.n_views = n_views
        self.per_view = np.broadcast_to(np.asarray(levels, dtype=np.int64), (n_views,)).copy()
        self.levels = int(self.per_view.max()) if n_views else 1
        self.size = int(np.prod(self.per_view))
        self.stride = np.ones(n_views, dtype=np.int64)
        for v in range(n_views - 2, -1, -1):
            self.stride[v] = self.stride[v + 1] * self.per_view[v + 1]
        digits = (np.arange(self.size, dtype=np.int64)[:, None] // self.stride[None, :]) % self.per_view[None, :]
        self.digits = digits.astype(np.int16)
        total = digits.sum(axis=1)
        self.layers = [np.flatnonzero(total == t) for t in range(int(total.max()), -1, -1)]

    def masses(self, q0: np.ndarray, factor: np.ndarray) -> np.ndarray:
        """M[u, n] = sum_k q0[u, k] prod_v factor[u, k, v, n_v], shape (U, size)."""
        out = np.empty((q0.shape[0], self.size))
        for u in range(q0.shape[0]):
            t = q0[u][:, None]  # (K, 1)
            for v in range(self.n_views):
                levels = int(self.per_view[v])
                t = (t[:, :, None] * factor[u, :, v, None, :levels]).reshape(t.shape[0], -1)
            out[u] = t.sum(axis=0)
        return out


def _cycle_cost(q: np.ndarray, p: np.ndarray, tour: np.ndarray, enter: float,
                between: np.ndarray, look: np.ndarray) -> float:
    """Expected cost of sweeping ``tour`` cyclically (entering it at cost ``enter`` for its first
    travel) until every object is found; q (W, K) are the unfound objects' posteriors, p (A, W, K)
    the detection probabilities. Summed until :data:`TAIL` mass is left, the rest bounded."""
    if q.shape[0] == 0:
        return 0.0
    steps = [enter] + [float(between[tour[i], tour[(i + 1) % len(tour)]]) for i in range(len(tour) - 1)]
    closing = float(between[tour[-1], tour[0]])
    unseen = q.copy()  # q_u(k) * P(u missed at k by the looks so far)
    cycle_miss = np.prod(1.0 - p[tour], axis=0)  # (W, K)
    total, s = 0.0, 0
    cost_max = max(steps[1:] + [closing, enter]) + float(look.max())
    while True:
        i = s % len(tour)
        travel = steps[i] if s < len(tour) else (closing if i == 0 else steps[i])
        total += (travel + float(look[tour[i]])) * (1.0 - float(np.prod(1.0 - unseen.sum(axis=1))))
        unseen = unseen * (1.0 - p[tour[i]])
        s += 1
        left = float(unseen.sum())
        if left < TAIL and i == len(tour) - 1:
            break
        if s > 10_000 * len(tour):
            return math.inf  # some mass is never found by the sweep
    with np.errstate(divide="ignore", invalid="ignore"):
        tail = np.where(unseen > 0, unseen / (1.0 - cycle_miss), 0.0)
    return total + cost_max * len(tour) * float(tail.sum())


@dataclass
class Tables:
    """A solved cut problem: V(v, n, F) for every state, and Q-values on demand.

    Attributes:
        root: the value at the start (min over first looks of travel + look + expectation).
        views: the useful viewpoints (indices into the problem's), the order of every axis below.
        cap, upper: the cut (see the module docstring): one cap, or one per useful viewpoint.
    """

    root: float
    views: np.ndarray
    cap: int | np.ndarray
    upper: bool
    values: dict
    mass: np.ndarray
    stride: np.ndarray
    levels: int | np.ndarray
    between: np.ndarray
    start: np.ndarray
    look: np.ndarray

    def q_values(self, here: int | None, counts: np.ndarray, found: int,
                 travel: np.ndarray | None = None) -> np.ndarray:
        """Q(state, w) for every useful viewpoint w: travel + look + expected value after it;
        inf where the cut forbids the look. `here` indexes :attr:`views` (None: the start),
        `counts` the looks per useful viewpoint, `found` a bit mask over the problem's objects;
        `travel`, if given, the metres to each viewpoint from wherever the agent stands."""
        counts = np.minimum(np.asarray(counts, dtype=np.int64), np.asarray(self.levels) - 1)
        idx = int(np.sum(counts * self.stride))
        m = self.mass.shape[0]
        unfound = [u for u in range(m) if not found >> u & 1]
        limit = np.broadcast_to(np.asarray(self.cap) + (0 if self.upper else 1), counts.shape)
        if travel is None:
            travel = self.start if here is None else self.between[here]
        out = np.full(len(self.views), np.inf)
        for w in range(len(self.views)):
            if counts[w] >= limit[w]:
                continue
            nx = idx + int(self.stride[w])
            keep = [self.mass[u, nx] / self.mass[u, idx] if self.mass[u, idx] > 0 else 1.0
                    for u in unfound]
            expect = 0.0
            for s in range(1 << m):
                if s & found:
                    continue
                ps = 1.0
                for j, u in enumerate(unfound):
                    ps *= (1.0 - keep[j]) if s >> u & 1 else keep[j]
                if ps > 0:
                    expect += ps * float(self.values[found | s][w, nx])
            out[w] = travel[w] + self.look[w] + expect
        return out


def cut_inputs(problem: SearchProblem, views: np.ndarray, sites: np.ndarray, q0: np.ndarray):
    """The problem restricted to the useful viewpoints and sites: detection probabilities
    (A, U, K), priors (U, K), travel between viewpoints, from the start and the cost of a look."""
    prob = problem.prob[np.ix_(views, np.arange(len(problem.objects)), sites)]
    between = problem.between[np.ix_(views, views)]
    return prob, q0[:, sites], between, problem.start[views], problem.look[views]


def solve_tables(problem: SearchProblem, views: np.ndarray, sites: np.ndarray, q0: np.ndarray,
                 cap: int | Sequence[int] | np.ndarray, upper: bool) -> Tables:
    """Solve the cut problem and keep its tables (see :class:`Tables`); `cap` is one cap for
    every viewpoint or one per useful viewpoint (in the order of `views`)."""
    prob, q, between, start, look = cut_inputs(problem, views, sites, q0)
    a, m = len(views), len(problem.objects)
    caps = np.broadcast_to(np.asarray(cap, dtype=np.int64), (a,)).copy()  # one cap, or one per viewpoint
    levels = caps + 1 if upper else caps + 2
    grid = _Grid(a, levels)
    # factor[u, k, v, level]: the chance that `level` looks from v all missed u standing at k
    lv = np.arange(int(levels.max()))
    miss = 1.0 - np.transpose(prob, (1, 2, 0))  # (U, K, A)
    factor = miss[..., None] ** lv[None, None, None, :]
    if not upper:  # the look past the cap is perfect: it rules out every site it shows
        factor[:, :, np.arange(a), caps + 1] = np.where(miss < 1.0, 0.0, 1.0)
    mass = grid.masses(q, factor)  # (U, N)
    limit = caps if upper else caps + 1
    succ = np.where(grid.digits < limit[None, :], np.arange(grid.size)[:, None] + grid.stride[None, :], -1)
    full = (1 << m) - 1
    values: dict[int, np.ndarray] = {full: np.zeros((a, grid.size))}
    tour = _tour(between)
    capped = int(np.sum(grid.stride * caps)) if upper else -1
    root_q = None
    for found in sorted(range(full), key=lambda f: -bin(f).count("1")):
        unfound = [u for u in range(m) if not found >> u & 1]
        mass_w = mass[unfound]
        value = np.full((a, grid.size), np.inf)
        subsets = [s for s in range(full + 1) if s & found == 0]
        for layer in grid.layers:
            alive = np.all(mass_w[:, layer] > 0, axis=0)
            q_best = np.full((a, layer.size), np.inf)
            for w in range(a):
                nxt = succ[layer, w]
                ok = (nxt >= 0) & alive
                if not ok.any():
                    continue
                idx, nx = layer[ok], nxt[ok]
                keep = mass_w[:, nx] / mass_w[:, idx]  # P(u still unseen after the look from w)
                expect = np.zeros(idx.size)
                for s in subsets:
                    ps = np.ones(idx.size)
                    for j, u in enumerate(unfound):
                        ps = ps * ((1.0 - keep[j]) if s >> u & 1 else keep[j])
                    nxt_value = values[found | s][w, nx] if s else value[w, nx]
                    expect += np.where(ps > 0, ps * nxt_value, 0.0)  # an impossible branch adds 0
                q_best[w, ok] = look[w] + expect
            best = np.min(between[:, :, None] + q_best[None, :, :], axis=1)  # (A, layer)
            best[:, ~alive] = 0.0  # a state of probability 0: its value is never weighed
            if upper and capped in layer and alive[int(np.flatnonzero(layer == capped)[0])]:
                at = int(np.flatnonzero(layer == capped)[0])
                post = factor[:, :, np.arange(a), caps].prod(axis=2) * q  # (U, K)
                post = post[unfound] / post[unfound].sum(axis=1, keepdims=True)
                for v in range(a):
                    first = int(np.argmin(between[v, tour]))
                    best[v, at] = _cycle_cost(post, prob[:, unfound, :], np.roll(tour, -first),
                                              float(between[v, tour[first]]), between, look)
            value[:, layer] = best
            if found == 0 and (layer == 0).any():
                root_q = q_best[:, int(np.flatnonzero(layer == 0)[0])]
        values[found] = value
    assert root_q is not None
    return Tables(float(np.min(start + root_q)), views, cap if isinstance(cap, int) else caps, upper, values,
                  mass, grid.stride, grid.per_view if grid.per_view.min() != grid.per_view.max() else grid.levels,
                  between, start, look)


def _tour(between: np.ndarray) -> np.ndarray:
    """A nearest-neighbour tour of the viewpoints, from viewpoint 0."""
    a = between.shape[0]
    tour, left = [0], set(range(1, a))
    while left:
        here = tour[-1]
        nxt = min(left, key=lambda w: (between[here, w], w))
        tour.append(nxt)
        left.remove(nxt)
    return np.array(tour)
