"""Small search problems for the tests of the limit and the exact planner (docs/design.md §6.9)."""

from __future__ import annotations

import numpy as np

from fg_tea.planning.problem import SearchProblem


def make_problem(prob, factors, start, between, look) -> SearchProblem:
    prob = np.asarray(prob, dtype=float)
    a, m, k = prob.shape
    return SearchProblem(tuple(f"o{u}" for u in range(m)), tuple(f"v{i}" for i in range(a)),
                         ("site",) * a, prob, np.asarray(start, float), np.asarray(between, float),
                         np.asarray(look, float), float(prob.max()), k, np.arange(k), None,
                         np.asarray(factors, float))


def random_problem(rng, a, m, k, perfect=False, glance=True):
    """Close looks at each of k sites (a = k) plus, with `glance`, one look covering two sites."""
    pts = rng.uniform(0, 5, size=(k + 1, 2))
    prob = np.zeros((k + (1 if glance else 0), m, k))
    for j in range(k):
        prob[j, :, j] = 1.0 if perfect else rng.uniform(0.6, 0.97, size=m)
    if glance:
        prob[k, :, :2] = rng.uniform(0.1, 0.5, size=(m, 2))
        pts = np.vstack([pts, rng.uniform(0, 5, size=(1, 2))])
    views = pts[1:]
    between = np.linalg.norm(views[:, None] - views[None, :], axis=2)
    start = np.linalg.norm(views - pts[0], axis=1)
    factors = rng.dirichlet(np.ones(k), size=m)
    look = np.full(len(views), 0.0 if perfect else 0.144)
    return make_problem(prob, factors, start, between, look)


def blind_problem() -> SearchProblem:
    """An object that cannot stand at a site (a state whose mass runs out), a look that never
    shows one of the objects and a perfect look, over three viewpoints and two objects."""
    prob = np.zeros((3, 2, 3))
    prob[0, :, 0] = [0.9, 0.0]   # v0 never shows o1
    prob[1, :, 1] = [0.7, 0.8]
    prob[2, :, 2] = [1.0, 1.0]   # a perfect look: its site's mass is gone after one
    factors = [[0.5, 0.3, 0.2], [0.0, 0.6, 0.4]]
    between = np.array([[0, 2.0, 3.0], [2.0, 0, 1.5], [3.0, 1.5, 0]])
    return make_problem(prob, factors, [1.0, 2.0, 2.5], between, [0.144] * 3)
