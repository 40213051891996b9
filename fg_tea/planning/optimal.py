"""The Bayes-optimal search limit: least expected travel until every required object is found.

This planner is the yardstick for eqs. 12-17 (and the baselines): on the current belief it solves
the search problem exactly, by dynamic programming over the belief tree of inspection orders.

**The model optimised** (stated precisely, because the real sensor is not this one):

- hidden truth: the sites L_U = (L_u)_{u in U} of the required objects U = `objects`, distributed
  as the current belief P(L_U) (the exact joint for correlated beliefs, the product of marginals
  otherwise), restricted to the open sites defined below (truths that put an object on an
  excluded site are conditioned away: no inspection could ever find it there);
- perfect detection: inspecting site j reveals exactly which objects of U stand at j (mu -> 0,
  fp = 0); an object is found when its site is inspected, and several can be found at once;
- cost: metres travelled, ``distances.from_agent(j)`` to the first site, then
  ``distances.between(i, j)``; the search ends when every object of U has been found;
- value: V = min over adaptive policies of E_{L_U}[travel until all of U is found].

Under perfect detection an inspected site is never worth revisiting, so the belief state after a
sequence of inspections is (S = set of inspected sites, c = current site, the sites in S where
objects were found). Writing U_S,c(t) for the optimal cost-to-go in the state reached when the
truth is t (constant over truths that agree on S), the Bellman recursion is

    U_S,c(t) = 0                                                      if every L_u(t) is in S
    U_S,c(t) = min_{j not in S} [ between(c, j) + E[ U_{S+j}, j (t') | t' ~_S t ] ]  otherwise

where t' ~_S t means "t' and t put the same objects on the same sites of S and the others outside
S" (the information gathered so far), and the expectation is under P restricted to that class. The
root is min_j [from_agent(j) + E_t U_{j},j (t)]. The DP visits all 2^K' subsets (K' open sites)
with vectors over the K'^|U| truths, so it is exact and costs O(2^K' K'^2 K'^|U|); K' is capped
(default 10) and a larger problem raises ``ValueError``.

**Real sensors miss.** The same assumption is applied to the past: a site inspected in the
current search is taken as searched, and truths that put a required object there are conditioned
away, exactly like excluded sites. Precisely, the DP ranges over the *open* sites, the eligible
sites inspected the fewest times so far (``inspected``; at the start of a search, every site never
inspected); if the belief puts no mass on them, over every eligible site. So when a real miss
(mu > 0) leaves an object unfound after every site was searched, a new sweep starts and the belief
(eq. 6) decides where to look again; within a sweep no site is planned twice. Without this rule a
re-inspection of the site the agent stands at would cost nothing and always look worthwhile, and
the planner could repeat it forever. The caller must therefore count every inspection at which at
least one object of `objects` was not seen. The planner re-runs after each real observation
(receding horizon); the repeat penalty of eq. 12 is not used, and ``relevance`` only labels: the
decision names the object most probable at the chosen site.
"""

from __future__ import annotations

import itertools
from typing import Mapping, Sequence

import numpy as np

from fg_tea.common.errors import PlannerRefused
from fg_tea.planning.base import (
    Candidate,
    Decision,
    DistanceModel,
    PlannerBase,
    check_inputs,
    distance_matrix,
    distance_vector,
    repeat_counts,
)

MAX_SITES = 10
MAX_TRUTHS = 20_000


def size_fault(n_sites: int, n_objects: int, max_sites: int = MAX_SITES,
               max_truths: int = MAX_TRUTHS) -> str | None:
    """Why a search over `n_sites` open sites for `n_objects` objects is too large, or None.

    The first decision of an episode plans over every site and every object still to find, so
    this checks, before an episode starts, the largest problem the planner will be asked.
    """
    if n_sites > max_sites:
        return (f"{n_sites} sites exceed the limit of {max_sites} (exact DP over inspection "
                f"orders visits 2^{n_sites} site subsets)")
    if n_sites ** n_objects > max_truths:
        return (f"{n_objects} objects over {n_sites} sites give {n_sites ** n_objects:,} hidden "
                f"truths, more than the limit of {max_truths:,}")
    return None


def truth_table(belief, objects: Sequence[str], eligible: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """The hidden truths the DP ranges over and their probabilities.

    Args:
        belief: the belief engine (read only).
        objects: the required objects U.
        eligible: indices of the sites the DP may inspect (K' of them).

    Returns:
        (loc, p): loc of shape (T, |U|), each object's site as an index into `eligible`;
        p of shape (T,), probabilities summing to 1 (truths of probability 0 are dropped).

    Raises:
        ValueError: every truth puts some object on an excluded site.
    """
    idx = [belief.objects.index(o) for o in objects]
    n = len(idx)
    if belief.correlated:
        joint = belief.location_joint()
        others = tuple(a for a in range(joint.ndim) if a not in idx)
        p_u = joint.sum(axis=others) if others else joint
        order = sorted(idx)
        p_u = np.transpose(p_u, [order.index(i) for i in idx])
    else:
        q = belief.location_matrix()
        p_u = q[idx[0]]
        for i in idx[1:]:
            p_u = np.multiply.outer(p_u, q[i])
    p_u = p_u[np.ix_(*([list(eligible)] * n))]
    total = p_u.sum()
    if not total > 0:
        raise ValueError("optimal planner: the belief puts every required object configuration "
                         "on an excluded site")
    loc = np.array(list(itertools.product(range(len(eligible)), repeat=n)), dtype=np.int64)
    p = (p_u / total).reshape(-1)
    keep = p > 0
    return loc[keep], p[keep]


def expected_travel_table(start: np.ndarray, between: np.ndarray, loc: np.ndarray,
                          p: np.ndarray) -> np.ndarray:
    """Expected travel of the best policy that inspects each site first, by DP over the belief tree.

    Args:
        start: shape (K',), metres from the agent to each site the DP may inspect.
        between: shape (K', K'), metres between those sites.
        loc: shape (T, n), each truth's site per object (indices into the K' sites).
        p: shape (T,), truth probabilities (sum 1).

    Returns:
        shape (K',): E[travel until all found | first inspect j, then act optimally], metres.
    """
    k = len(start)
    t_count, n = loc.shape
    base = k + 1
    powers = base ** np.arange(n)
    bits = (1 << loc)  # (T, n): each object's site as a bit
    n_classes = base ** n
    sites = np.arange(k)

    def class_ids(mask: int) -> tuple[np.ndarray, np.ndarray]:
        inside = (bits & mask) != 0  # (T, n)
        ids = (np.where(inside, loc, k) * powers).sum(axis=1)
        return ids, inside.all(axis=1)

    def cond_expect(ids: np.ndarray, values: np.ndarray) -> np.ndarray:
        """E[values | class] for each row of values (J, T), broadcast back to truths."""
        j_count = values.shape[0]
        offs = (ids[None, :] + n_classes * np.arange(j_count)[:, None]).reshape(-1)
        num = np.bincount(offs, weights=(values * p[None, :]).reshape(-1), minlength=j_count * n_classes)
        den = np.bincount(ids, weights=p, minlength=n_classes)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = num.reshape(j_count, n_classes) / den[None, :]
        return ratio[:, ids]

    full = (1 << k) - 1
    # U[mask] has shape (K', T): row c = cost-to-go standing at c in S = mask (rows c not in S unused).
    upper: dict[int, np.ndarray] = {full: np.zeros((k, t_count))}
    for size in range(k - 1, 0, -1):
        level: dict[int, np.ndarray] = {}
        for combo in itertools.combinations(range(k), size):
            mask = sum(1 << c for c in combo)
            ids, done = class_ids(mask)
            outside = [j for j in range(k) if not mask >> j & 1]
            nxt = np.stack([upper[mask | 1 << j][j] for j in outside])  # (J, T)
            a = cond_expect(ids, nxt)  # (J, T)
            inside = list(combo)
            cost = between[np.ix_(inside, outside)][:, :, None] + a[None, :, :]  # (s, J, T)
            u = np.zeros((k, t_count))
            u[inside] = np.where(done[None, :], 0.0, cost.min(axis=1))
            level[mask] = u
        upper = level
    first = np.stack([upper[1 << int(j)][j] for j in sites])  # (K', T)
    return start + first @ p


class OptimalPlanner(PlannerBase):
    """Bayes-optimal search under perfect detection (see the module docstring for the model).

    Args:
        max_sites: largest number of open sites accepted (the DP is exponential in it).
        max_truths: largest number of hidden truths K'^|U| accepted.
    """

    name = "optimal"

    def __init__(self, max_sites: int = MAX_SITES, max_truths: int = MAX_TRUTHS) -> None:
        self.max_sites = int(max_sites)
        self.max_truths = int(max_truths)

    def check(self, belief, objects: Sequence[str]) -> None:
        """Refuse, before an episode starts, a house too large for the DP.

        Raises:
            PlannerRefused: kind ``"size"``, with :func:`size_fault`'s reason.
        """
        fault = size_fault(len(belief.sites), len(objects), self.max_sites, self.max_truths)
        if fault is not None:
            raise PlannerRefused(f"optimal planner: {fault}; use another planner", "size", self.name)

    def choose(self, belief, objects: Sequence[str], relevance: Mapping[str, float],
               distances: DistanceModel, inspected: Mapping[str, int],
               excluded_sites: frozenset[str] = frozenset(), views=None) -> Decision:
        """The first inspection of an optimal search; candidates carry each first site's expected travel.

        Raises:
            PlannerRefused: more open sites than `max_sites`, more truths than `max_truths`.
            ValueError: the usual input faults of :func:`~fg_tea.planning.base.check_inputs`, or
                a belief that puts every required configuration on an excluded site.
        """
        obj_idx, eligible = check_inputs(belief, objects, relevance, excluded_sites, views)
        sites = list(belief.sites)
        counts = repeat_counts(inspected, sites)
        fewest = min(int(counts[j]) for j in eligible)
        open_sites = [j for j in eligible if counts[j] == fewest]
        k = len(open_sites)
        if k > self.max_sites:
            raise PlannerRefused(f"optimal planner: {k} sites exceed the limit of {self.max_sites} "
                                 f"(exact DP over inspection orders visits 2^{k} site subsets); "
                                 "exclude sites or use another planner", "size", self.name)
        if k ** len(objects) > self.max_truths:
            raise PlannerRefused(f"optimal planner: {len(objects)} objects over {k} sites give "
                                 f"{k ** len(objects):,} hidden truths, more than the limit of "
                                 f"{self.max_truths:,}", "size", self.name)
        try:
            loc, p = truth_table(belief, objects, open_sites)
        except ValueError:
            if len(open_sites) == len(eligible):
                raise
            open_sites = eligible  # the open sites cannot hold the objects: search everywhere
            k = len(open_sites)
            if k > self.max_sites or k ** len(objects) > self.max_truths:
                raise PlannerRefused(f"optimal planner: {k} sites exceed the limit of "
                                     f"{self.max_sites} (or {k ** len(objects):,} truths exceed "
                                     f"{self.max_truths:,})", "size", self.name) from None
            loc, p = truth_table(belief, objects, open_sites)
        names = [sites[j] for j in open_sites]
        start = distance_vector(distances, names)
        between = distance_matrix(distances, names)
        values = expected_travel_table(start, between, loc, p)
        q = belief.location_matrix()[obj_idx]
        candidates = []
        for e, j in enumerate(open_sites):
            i = int(np.argmax(q[:, j]))
            o = objects[i]
            candidates.append(Candidate(o, sites[j], float(start[e]), float(q[i, j]), 0.0,
                                        int(counts[j]), float(relevance[o]), float(values[e]),
                                        float(values[e])))
        best = candidates[int(np.argmin(values))]
        info: dict[str, float | str] = {"expected_travel": best.total, "sites": k, "truths": int(len(p)),
                "detection": "perfect"}
        return Decision(best.object, best.viewpoint, best.total, tuple(candidates), self.name, info)


__all__ = ["OptimalPlanner", "expected_travel_table", "truth_table", "size_fault", "MAX_SITES", "MAX_TRUTHS"]
