"""The root value of a cut problem with two layers of values in memory (docs/design.md §6.9).

:func:`fg_tea.planning.limit.solve_tables` keeps V(v, n, F) for every count vector n, because a
planner reads its Q-values anywhere; a bracket of the limit needs only the value at the start.
A look adds one to the total count, so the values of total t depend only on those of total
t + 1 (whatever the look finds): :func:`solve_root` runs the recursion from the largest total
down to 0 and keeps the values of two totals (*layers*) at a time, for every found set at once
as :mod:`fg_tea.planning.cut_tables` does. Its memory is set by the widest layer, not by the
whole grid: at 16 viewpoints and two looks each, about an eighth of the 3^16 count vectors.

Nothing else is stored. The count vectors of a layer are numbered in C order (their rank among
the vectors of that total, :class:`Layers`), computed from the digits and back, so a successor
n + e_w is found by ranking it in the layer above; each vector's masses M_u(n) are computed
from its digits (only the viewpoints that see a site enter its product) and kept with its
layer. Both cuts, one cap or one per viewpoint, are the same as ``solve_tables``'s, and so are
the values (tests/test_lean_limit.py checks the root against it to 1e-9 relative).
"""

from __future__ import annotations

import numpy as np

from fg_tea.planning.cut_tables import _capped_values, _expectation, _nearest_plus
from fg_tea.planning.limit import cut_inputs
from fg_tea.planning.problem import SearchProblem

#: Count vectors times found sets a solve may visit (about ten minutes of CPU here), when the
#: bracket (fg_tea/planning/bracket.py) chooses its caps.
MAX_WORK = 1 << 30

#: Count vectors solved per step within a layer: bounds the step's arrays (found sets x
#: vectors x viewpoints floats, a few of them) to tens of megabytes.
CHUNK = 1 << 15


class Layers:
    """The count vectors with digit v in [0, levels[v]), grouped by their total and numbered in
    C order within a total (the first viewpoint the most significant digit)."""

    def __init__(self, levels: np.ndarray) -> None:
        self.levels = np.asarray(levels, dtype=np.int64)
        self.n_views = self.levels.size
        self.top = int(self.levels.sum() - self.n_views)
        # suffix[v][s]: how many vectors of the viewpoints v.. have total s
        suffix = [np.ones(1, dtype=np.int64)]
        for lv in self.levels[::-1]:
            suffix.append(np.convolve(suffix[-1], np.ones(int(lv), dtype=np.int64)))
        self.suffix = suffix[::-1]
        self._tables: dict[int, list[np.ndarray]] = {}

    def size(self, total: int) -> int:
        """How many vectors have this total."""
        return int(self.suffix[0][total]) if 0 <= total <= self.top else 0

    def _count(self, v: int, total: np.ndarray) -> np.ndarray:
        table = self.suffix[v]
        inside = (total >= 0) & (total < table.size)
        return np.where(inside, table[np.clip(total, 0, table.size - 1)], 0)

    def unrank(self, total: int, ranks: np.ndarray) -> np.ndarray:
        """The digits (len(ranks), n_views) of the vectors of `total` with these ranks."""
        r = np.asarray(ranks, dtype=np.int64).copy()
        digits = np.zeros((r.size, self.n_views), dtype=np.int64)
        prefix = np.zeros(r.size, dtype=np.int64)
        for v in range(self.n_views):
            done = np.zeros(r.size, dtype=bool)
            for d in range(int(self.levels[v])):
                count = self._count(v + 1, total - prefix - d)
                stay = ~done & (r < count)
                digits[stay, v] = d
                done |= stay
                r = np.where(done, r, r - count)
            prefix += digits[:, v]
        return digits

    def _before(self, total: int) -> list[np.ndarray]:
        """before[v][p, d]: how many vectors of `total` whose digits before v sum to p and equal
        a given prefix have digit v below d (the rank's share of viewpoint v)."""
        held = self._tables.get(total)
        if held is None:
            held = []
            p = np.arange(self.top + 2)[:, None]
            for v in range(self.n_views):
                d = np.arange(int(self.levels[v]) + 1)[None, :]
                counts = self._count(v + 1, total - p - d)        # the vectors with digit v = d
                held.append(np.concatenate([np.zeros((p.size, 1), dtype=np.int64),
                                            np.cumsum(counts, axis=1)[:, :-1]], axis=1))
            if len(self._tables) > 4:
                self._tables.clear()
            self._tables[total] = held
        return held

    def rank(self, total: int, digits: np.ndarray) -> np.ndarray:
        """The ranks of vectors (rows of `digits`, all of this total) among those of `total`."""
        before = self._before(total)
        prefix = np.cumsum(digits, axis=1) - digits
        return sum((before[v][prefix[:, v], digits[:, v]] for v in range(self.n_views)),
                   np.zeros(digits.shape[0], dtype=np.int64))

    def successors(self, total: int, digits: np.ndarray) -> np.ndarray:
        """The rank among the vectors of ``total + 1`` of n + e_w for every row n of `digits` and
        every viewpoint w, shape (rows, n_views); meaningless where digit w is at its top. The
        shares of the viewpoints before w are n's own, those after w see a prefix one larger."""
        before = self._before(total + 1)
        prefix = np.cumsum(digits, axis=1) - digits
        a = self.n_views
        same = np.stack([before[v][prefix[:, v], digits[:, v]] for v in range(a)], axis=1)
        shifted = np.stack([before[v][prefix[:, v] + 1, digits[:, v]] for v in range(a)], axis=1)
        raised = np.stack([before[w][prefix[:, w], digits[:, w] + 1] for w in range(a)], axis=1)
        head = np.cumsum(same, axis=1) - same                        # shares of v < w
        tail = np.cumsum(shifted[:, ::-1], axis=1)[:, ::-1] - shifted  # shares of v > w
        return head + raised + tail


def widest_layer(levels: np.ndarray) -> int:
    """The number of count vectors of the most common total."""
    layers = Layers(np.asarray(levels))
    return int(layers.suffix[0].max())


def lean_bytes(n_views: int, n_objects: int, levels: int | np.ndarray) -> int:
    """The peak memory of :func:`solve_root`, bytes: two layers of values for every found set
    but the full one (which is 0) and of masses, and one step's arrays (:data:`CHUNK` vectors;
    about ten arrays of found sets x vectors x viewpoints floats). Checked against the peak
    allocation numpy reports to tracemalloc (tests/test_lean_limit.py)."""
    per = np.broadcast_to(np.asarray(levels, dtype=np.int64), (n_views,))
    width = widest_layer(per)
    found = 2 ** n_objects
    layers = 2 * 8 * width * ((found - 1) * n_views + n_objects)
    step = 10 * 8 * found * min(CHUNK, width) * n_views
    return int(layers + step)


def lean_states(n_views: int, levels: int | np.ndarray) -> int:
    """Count vectors the solve visits (its time grows with this times the found sets)."""
    per = np.broadcast_to(np.asarray(levels, dtype=np.int64), (n_views,))
    return int(np.prod(per))


def solve_root(problem: SearchProblem, views: np.ndarray, sites: np.ndarray, q0: np.ndarray,
               cap: int | np.ndarray, upper: bool) -> float:
    """The root value of the cut problem, as ``solve_tables(...).root`` (see the module
    docstring); `cap` is one cap or one per useful viewpoint, `upper` picks the cut."""
    prob, q, between, start, look = cut_inputs(problem, views, sites, q0)  # prob: (A, m, K)
    a, m = len(views), len(problem.objects)
    caps = np.broadcast_to(np.asarray(cap, dtype=np.int64), (a,)).copy()
    levels = caps + 1 if upper else caps + 2
    miss = 1.0 - np.transpose(prob, (1, 2, 0))                    # (m, K, A)
    factor = miss[..., None] ** np.arange(int(levels.max()))[None, None, None, :]
    if not upper:  # the look past the cap is perfect: it rules out every site it shows
        factor[:, :, np.arange(a), caps + 1] = np.where(miss < 1.0, 0.0, 1.0)
    seen_by = [np.flatnonzero((miss[:, k, :] < 1.0).any(axis=0)) for k in range(q.shape[1])]
    layers = Layers(levels)
    full = (1 << m) - 1
    found = np.array([[f >> u & 1 for u in range(m)] for f in range(full + 1)], dtype=bool)
    prev_values = np.zeros((full, a, 0))
    prev_mass = np.zeros((m, 0))
    root_q = np.full(a, np.inf)
    for total in range(layers.top, -1, -1):
        size = layers.size(total)
        values = np.empty((full, a, size))
        mass = np.empty((m, size))
        finite = bool(np.isfinite(prev_values).all())
        for lo in range(0, size, CHUNK):
            ranks = np.arange(lo, min(size, lo + CHUNK))
            digits = layers.unrank(total, ranks)
            here = _masses(q, factor, seen_by, digits)
            mass[:, ranks] = here
            live = np.all((here > 0)[None] | found[:, :, None], axis=1)       # (F, n)
            q_best = _q_values(layers, total, digits, here, prev_mass, prev_values, live, look, finite)
            best = np.where(live[:full, None, :], _nearest_plus(between, q_best[:full]), 0.0)
            if upper and total == layers.top:  # the fully capped state: the cyclic sweep
                alive = [f for f in range(full) if live[f, 0]]
                best[alive, :, 0] = _capped_values(q, prob, factor, caps, alive, ~found, between, look)
            values[:, :, ranks] = best
            if total == 0:
                root_q = q_best[0, 0]
        prev_values, prev_mass = values, mass
    return float(np.min(start + root_q))


def _masses(q: np.ndarray, factor: np.ndarray, seen_by: list, digits: np.ndarray) -> np.ndarray:
    """M[u, n] = sum_k q[u, k] prod_v factor[u, k, v, n_v] for the rows n of `digits`; only the
    viewpoints that see site k change its product."""
    out = np.zeros((q.shape[0], digits.shape[0]))
    for k, views in enumerate(seen_by):
        term = np.repeat(q[:, k, None], digits.shape[0], axis=1)
        for v in views:
            term *= factor[:, k, v, digits[:, v]]
        out += term
    return out


def _q_values(layers: Layers, total: int, digits: np.ndarray, here: np.ndarray, prev_mass: np.ndarray,
              prev_values: np.ndarray, live: np.ndarray, look: np.ndarray, finite: bool) -> np.ndarray:
    """Q(F, n, w) = look(w) + E[V(F | S, w, n + e_w)] for every found set F, vector n (rows of
    `digits`) and look w, shape (F, n, A); inf where the cut forbids the look or n is impossible
    under F (`live`, shape (F, n), is False)."""
    n, a = digits.shape
    ok = digits < (layers.levels - 1)[None, :]
    nxt = np.where(ok, layers.successors(total, digits), 0)
    full = prev_values.shape[0]
    later = np.zeros((full + 1, n, a))                             # V(F', w, n + e_w); F' = all: 0
    if prev_values.shape[2]:
        later[:full] = prev_values[:, np.arange(a)[None, :], nxt]
        with np.errstate(divide="ignore", invalid="ignore"):
            keep = np.where(here[:, :, None] > 0, prev_mass[:, nxt] / here[:, :, None], 1.0)  # (m, n, A)
    else:
        keep = np.ones((here.shape[0], n, a))
    expect = _expectation(later, keep, finite)
    return np.where(ok[None] & live[:, :, None], look[None, None, :] + expect, np.inf)


__all__ = ["CHUNK", "MAX_WORK", "Layers", "lean_bytes", "lean_states", "solve_root", "widest_layer"]
