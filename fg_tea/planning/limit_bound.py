"""A lower bound on the search limit that any house affords: objects one at a time, perfect looks.

The limit of :mod:`fg_tea.planning.limit` brackets the optimal expected cost V* exactly but needs
a table over count vectors, ``(cap + 2) ** A`` entries for A viewpoints: out of reach at 27 or 45
sites. This module bounds V* from below in O(|U| A log A) (docs/design.md §6.9, "A lower bound
at any size"), under the limit's own assumptions: a factorised belief (objects independent) and
looks that detect independently given where the objects stand.

Three relaxations, each of which can only lower the optimum:

1. **Perfect looks.** A look from w shows u at every in-view site (``p_{u,k}(w) > 0``) with
   probability 1. A policy for the imperfect detector can be run with perfect looks by dropping
   detections at random; it then stops no later, so the perfect-look optimum is at most V*.
2. **One object.** Finding every object costs at least finding object u, so V* >= max_u V*_u.
   With perfect looks the looks made before u is found depend only on the other objects (which
   are independent of u) and on the policy's own coins, so the viewpoints visited by a given
   budget are independent of where u stands.
3. **Cheapest arrival, mean busy time.** Each viewpoint helps at most once (a second perfect
   look shows nothing new) and its look costs at least ``c_w = min(start_w, min_{v != w}
   between_{v,w}) + look_w``. Along any sequence of distinct looks, let D_j be the mass of u the
   j-th look newly shows and C_j the cost spent when it ends; u is found at cost
   ``sum_j D_j C_j = sum_j D_j M_j + sum_j D_j c_j / 2``, M_j the midpoint of the look's cost
   interval (scheduling's mean busy time). The first sum is the integral over tau of one minus
   the mass released by tau were each look's D_j released evenly over its cost; that mass is at
   most F(tau), the best fractional knapsack of masses ``Q_w = sum_{k in view of w} q_u(k)`` at
   costs c_w (filled in order of Q_w / c_w), so the sum is at least the integral of
   ``(1 - F(tau))^+``, in closed form. The second is at least half of
   ``sum_k q_u(k) min_{w shows k} c_w``: a site's mass is shown by a look that can see it.

The bound is loose where travel is long between the likely viewpoints (it charges each look its
cheapest arrival), tight where one viewpoint holds most of the mass. It is checked against the
limit's lower end on random small problems (tests/test_limit_bound.py).
"""

from __future__ import annotations

import numpy as np

from fg_tea.planning.problem import SearchProblem


def look_floor(problem: SearchProblem) -> np.ndarray:
    """c_w, shape (A,): the least any look from viewpoint w can cost (travel in plus the look)."""
    between = np.asarray(problem.between, dtype=float)
    a = between.shape[0]
    arrive = np.where(np.eye(a, dtype=bool), np.inf, between).min(axis=0) if a > 1 else np.full(a, np.inf)
    return np.minimum(np.asarray(problem.start, dtype=float), arrive) + np.asarray(problem.look, dtype=float)


def busy_bound(mass: np.ndarray, cost: np.ndarray) -> float:
    """The integral of ``(1 - F(tau))^+`` over tau, F the fractional knapsack of `mass` (the mass
    each viewpoint covers) at `cost` (its least cost): the first sum of relaxation 3 of the
    module docstring."""
    mass, cost = np.asarray(mass, dtype=float), np.asarray(cost, dtype=float)
    keep = mass > 0
    mass, cost = mass[keep], cost[keep]
    order = np.lexsort((cost, -np.divide(mass, cost, out=np.full(mass.shape, np.inf), where=cost > 0)))
    total, covered = 0.0, 0.0
    for j in order:
        left = 1.0 - covered
        if left <= 0.0:
            break
        q, c = float(mass[j]), float(cost[j])
        if q <= left:
            total += c * (left - q / 2.0)  # (1 - F) falls linearly from `left` to `left - q`
            covered += q
        else:
            total += c * left * left / (2.0 * q)  # it reaches 0 part-way through this look
            covered = 1.0
    return total


def bound_fault(problem: SearchProblem) -> str | None:
    """Why :func:`lower_bound` does not bound `problem`, or None."""
    if not problem.independent:
        return ("search bound: the belief is correlated; the bound needs independent objects "
                "(a factorised model)")
    return None


def lower_bound(problem: SearchProblem) -> float:
    """A lower bound on the optimal expected cost V* of `problem`: max over objects of
    :func:`object_bound` with perfect looks (see the module docstring).

    Raises:
        ValueError: :func:`bound_fault` says why there is none.
    """
    fault = bound_fault(problem)
    if fault:
        raise ValueError(fault)
    q0 = np.asarray(problem.factors, dtype=float)
    q0 = q0 / q0.sum(axis=1, keepdims=True)
    seen = problem.prob > 0  # (A, U, K'): the sites a look from w shows u at, perfect looks
    cost = look_floor(problem)
    return max((object_bound(seen[:, u, :], q0[u], cost) for u in range(len(problem.objects))), default=0.0)


def object_bound(seen: np.ndarray, q: np.ndarray, cost: np.ndarray) -> float:
    """The bound for one object (relaxation 3): `seen` (A, K') the sites each viewpoint shows,
    `q` (K',) the object's prior, `cost` (A,) each look's least cost. A site no viewpoint shows
    adds nothing (the optimum is then infinite, and any number bounds it)."""
    mass = (seen * q[None, :]).sum(axis=1)
    floor = np.where(seen, cost[:, None], np.inf).min(axis=0)  # (K',) the cheapest look showing k
    shown = np.isfinite(floor)
    return busy_bound(mass, cost) + 0.5 * float(np.sum(q[shown] * floor[shown]))


__all__ = ["bound_fault", "busy_bound", "look_floor", "lower_bound", "object_bound"]
