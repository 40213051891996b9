"""The K most probable joint assignments of a factor product, exactly (docs/design.md §4.8).

Two exact routes:

- :func:`kbest_dense` — from a full log table (small components): the K largest entries, ties in
  index order;
- :func:`kbest_partition` — Lawler-Nilsson partitioning over max-product elimination: the best
  assignment of the whole space, then the space minus it split into disjoint cells (the first
  i-1 variables fixed to the best assignment's values, the i-th barred from its value), each
  cell's best found by elimination with the constraints as unary factors; a priority queue
  yields solutions in order. K solutions cost at most K x n eliminations.

Solutions come as ``(log weight, value indices)``; equal weights are ordered by their value
indices (smallest first), so the output is deterministic.
"""

from __future__ import annotations

import heapq
from typing import Mapping, Sequence

import numpy as np

from fg_tea.beliefs.elimination import LogFactor, log_weight, max_assignment, min_fill_order


def kbest_dense(log_table: np.ndarray, k: int) -> list[tuple[float, tuple[int, ...]]]:
    """The `k` largest entries of `log_table` (``-inf`` entries never), largest first."""
    flat = log_table.ravel()
    finite = np.flatnonzero(np.isfinite(flat))
    if finite.size == 0:
        return []
    take = min(k, finite.size)
    values = flat[finite]
    threshold = np.partition(-values, take - 1)[take - 1]
    cand = finite[-values <= threshold]
    ranked = cand[np.lexsort((cand, -flat[cand]))][:take]
    return [(float(flat[i]), tuple(int(x) for x in np.unravel_index(i, log_table.shape))) for i in ranked]


def kbest_partition(factors: Sequence[LogFactor], variables: Sequence[int], cards: Mapping[int, int],
                    k: int) -> list[tuple[float, tuple[int, ...]]]:
    """The `k` best assignments of `variables` (which hold every variable of `factors`).

    Returns:
        Up to `k` pairs (log weight, value index per variable in `variables` order), best first;
        fewer when fewer assignments have non-zero weight.
    """
    order = min_fill_order([s for s, _ in factors], list(variables), cards)

    def solve(masks: tuple[np.ndarray | None, ...]) -> tuple[float, tuple[int, ...]] | None:
        extra: list[LogFactor] = []
        for v, mask in zip(variables, masks):
            if mask is not None:
                with np.errstate(divide="ignore"):
                    extra.append(((v,), np.log(mask.astype(float))))
        top, values = max_assignment(list(factors) + extra, order, cards)
        if not np.isfinite(top):
            return None
        x = tuple(values[v] for v in variables)
        return log_weight(factors, dict(zip(variables, x))), x

    first = solve((None,) * len(variables))
    if first is None:
        return []
    heap: list = [(-first[0], first[1], (None,) * len(variables))]
    out: list[tuple[float, tuple[int, ...]]] = []
    while heap and len(out) < k:
        neg, x, masks = heapq.heappop(heap)
        out.append((-neg, x))
        for i, v in enumerate(variables):
            allowed = np.ones(cards[v], dtype=bool) if masks[i] is None else masks[i].copy()
            allowed[x[i]] = False
            if not allowed.any():
                continue
            child = tuple(_one_hot(cards[w], x[j]) for j, w in enumerate(variables[:i])) + \
                (allowed,) + masks[i + 1:]
            found = solve(child)
            if found is not None:
                heapq.heappush(heap, (-found[0], found[1], child))
    return out


def _one_hot(card: int, index: int) -> np.ndarray:
    mask = np.zeros(card, dtype=bool)
    mask[index] = True
    return mask


def merge_independent(lists: Sequence[Sequence[tuple[float, tuple[int, ...]]]],
                      k: int) -> list[tuple[float, tuple[int, ...]]]:
    """The `k` best concatenations of one solution from each list (independent components),
    weights added; ties ordered by the concatenated indices."""
    out: list[tuple[float, tuple[int, ...]]] = [(0.0, ())]
    for options in lists:
        pairs = [(a + b, x + y) for a, x in out for b, y in options]
        pairs.sort(key=lambda p: (-p[0], p[1]))
        out = pairs[:k]
    return out
