"""Variable elimination in log space over named-by-integer discrete factors (docs/design.md §4.8).

A factor here is a pair ``(scope, log_table)``: a tuple of integer variable ids and an array of
natural-log weights (``-inf`` where the weight is zero) with one axis per id. Products are sums
of broadcast log tables and sums out are log-sum-exp, so no product underflows however many
factors meet; nothing is approximated.

- :func:`min_fill_order` — the greedy min-fill elimination order (ties: fewest table entries,
  then lowest id), the standard heuristic of Koller & Friedman §9.4.3;
- :func:`order_cost` — the induced width and the largest table an order builds, without building;
- :func:`sum_out` — sum-product elimination of some variables; :func:`log_product` the product
  of what remains over a given scope;
- :func:`max_assignment` — max-product elimination with backpointers: the most probable assignment
  (ties: the lowest value index at each traceback step).
"""

from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np

LogFactor = tuple[tuple[int, ...], np.ndarray]


def logsumexp(table: np.ndarray, axis: int | tuple[int, ...] | None) -> np.ndarray:
    """log(sum(exp(table))) over `axis`, exact for -inf entries (an all -inf slice gives -inf)."""
    top = np.max(table, axis=axis, keepdims=True)
    shift = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        out = np.log(np.sum(np.exp(table - shift), axis=axis, keepdims=True)) + shift
    return np.squeeze(out, axis=axis) if axis is not None else out.reshape(())


def shifted(log: np.ndarray) -> np.ndarray:
    """`log` less its maximum (unchanged where every entry is -inf)."""
    top = np.max(log)
    return log - top if np.isfinite(top) else log


def normalised(log: np.ndarray, source: str) -> np.ndarray:
    """exp(`log`) scaled to sum to 1.

    Raises:
        ContradictionError: every entry is -inf (the evidence has probability zero; `source`
            names what holds it).
    """
    from fg_tea.common.errors import ContradictionError

    top = np.max(log)
    if not np.isfinite(top):
        raise ContradictionError(f"{source}: the evidence has probability zero under the program")
    p = np.exp(log - top)
    return p / p.sum()


def expand(scope: Sequence[int], table: np.ndarray, target: Sequence[int]) -> np.ndarray:
    """`table` (axes `scope`) with its axes moved into `target`'s order, size-1 axes elsewhere."""
    position = {v: i for i, v in enumerate(target)}
    ordered = sorted(range(len(scope)), key=lambda a: position[scope[a]])
    moved = np.transpose(table, ordered) if ordered != list(range(len(scope))) else table
    shape = [1] * len(target)
    for a in ordered:
        shape[position[scope[a]]] = table.shape[a]
    return moved.reshape(shape)


def log_product(factors: Sequence[LogFactor], scope: Sequence[int],
                cards: Mapping[int, int]) -> np.ndarray:
    """The log of the product of `factors` as a full table over `scope` (which holds all their
    variables; a variable no factor names is uniform)."""
    out = np.zeros([cards[v] for v in scope])
    for s, t in factors:
        out = out + expand(s, t, scope)
    return out


def _neighbours(scopes: Sequence[Sequence[int]]) -> dict[int, set[int]]:
    adj: dict[int, set[int]] = {}
    for s in scopes:
        for v in s:
            adj.setdefault(v, set()).update(w for w in s if w != v)
    return adj


def min_fill_order(scopes: Sequence[Sequence[int]], eliminate: Sequence[int],
                   cards: Mapping[int, int]) -> list[int]:
    """A greedy min-fill order for eliminating `eliminate` from the graph of `scopes`.

    At each step the variable whose elimination adds the fewest new edges between its
    neighbours goes next; ties go to the smaller table (product of the cards of the variable and
    its neighbours), then to the lower id, so the order is deterministic.
    """
    adj = _neighbours(scopes)
    for v in eliminate:
        adj.setdefault(v, set())
    left = set(eliminate)
    order: list[int] = []
    while left:
        def cost(v: int) -> tuple[int, int, int]:
            nb = sorted(adj[v])
            fill = sum(1 for i, a in enumerate(nb) for b in nb[i + 1:] if b not in adj[a])
            return fill, math.prod(cards[w] for w in nb) * cards[v], v
        best = min(left, key=cost)
        nb = adj.pop(best)
        for a in nb:
            adj[a].discard(best)
            adj[a].update(w for w in nb if w != a)
        left.discard(best)
        order.append(best)
    return order


def order_cost(scopes: Sequence[Sequence[int]], order: Sequence[int], keep: Sequence[int],
               cards: Mapping[int, int]) -> tuple[int, int]:
    """(induced width, largest table entries) of eliminating `order`, then joining `keep`.

    The width is the most neighbours a variable has when it is eliminated (the treewidth of the
    order); a table is the product formed at one elimination step, or the final table over the
    kept variables.
    """
    adj = _neighbours(scopes)
    width, largest = 0, max((math.prod(cards[v] for v in s) for s in scopes), default=1)
    for v in order:
        nb = adj.pop(v, set())
        width = max(width, len(nb))
        largest = max(largest, cards[v] * math.prod(cards[w] for w in nb))
        for a in nb:
            adj[a].discard(v)
            adj[a].update(w for w in nb if w != a)
    largest = max(largest, math.prod(cards[v] for v in keep))
    return width, largest


def _union(factors: Sequence[LogFactor], first: int) -> list[int]:
    scope = [first]
    for s, _ in factors:
        scope += [v for v in s if v not in scope]
    return scope


def sum_out(factors: Sequence[LogFactor], order: Sequence[int],
            cards: Mapping[int, int]) -> list[LogFactor]:
    """Sum the variables of `order` out of the product of `factors`, one at a time.

    Returns:
        Factors over the remaining variables whose product equals the sum (scalars included).
    """
    pool = list(factors)
    for v in order:
        touching = [f for f in pool if v in f[0]]
        if not touching:  # a variable no factor names: summing it out multiplies by its card
            pool.append(((), np.array(math.log(cards[v]))))
            continue
        pool = [f for f in pool if v not in f[0]]
        scope = _union(touching, v)
        pool.append((tuple(scope[1:]), logsumexp(log_product(touching, scope, cards), axis=0)))
    return pool


def max_assignment(factors: Sequence[LogFactor], order: Sequence[int],
                   cards: Mapping[int, int]) -> tuple[float, dict[int, int]]:
    """The most probable assignment of the variables of `order` (max-product elimination).

    `order` must name every variable of `factors`. Ties go to the lowest value index at each
    traceback step.

    Returns:
        (log of the maximum product, variable id -> value index); the log is ``-inf`` when every
        assignment has weight zero (the assignment is then meaningless).
    """
    pool = list(factors)
    back: list[tuple[int, tuple[int, ...], np.ndarray]] = []
    for v in order:
        touching = [f for f in pool if v in f[0]]
        pool = [f for f in pool if v not in f[0]]
        scope = _union(touching, v)
        table = log_product(touching, scope, cards)
        back.append((v, tuple(scope[1:]), np.argmax(table, axis=0)))
        pool.append((tuple(scope[1:]), np.max(table, axis=0)))
    assert all(not s for s, _ in pool), "max_assignment: order leaves variables uneliminated"
    best = float(sum(float(t) for _, t in pool))
    values: dict[int, int] = {}
    for v, scope, arg in reversed(back):
        values[v] = int(arg[tuple(values[w] for w in scope)])
    return best, values


def log_weight(factors: Sequence[LogFactor], values: Mapping[int, int]) -> float:
    """The log weight of one full assignment (factors summed in their given order)."""
    return float(sum(float(t[tuple(values[v] for v in s)]) for s, t in factors))
