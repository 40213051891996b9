"""Baseline search planners behind the :class:`~fg_tea.planning.base.Planner` interface.

They answer the same question as the EFE planner (eqs. 8, 9, 17: which (object, site) next?) with
simpler rules, so experiments can measure what each term of eqs. 12-16 buys:

- :class:`NearestPlanner` — the nearest site not yet inspected (distance only, no belief);
- :class:`GreedyProbabilityPlanner` — the most probable (object, site), argmax q(L_o = j);
- :class:`RandomPlanner` — a uniformly random uninspected site from a seeded Generator;
- :class:`~fg_tea.planning.efe.FactorisedEFEPlanner` — docs/design.md eqs. (10)-(11) on marginals
  (defined in :mod:`fg_tea.planning.efe`, re-exported here).

Site-level baselines (nearest, random) label their choice with the most relevant object (eq. 15;
ties to the first in the caller's order), the object whose search node the inspection serves.
Each candidate records every term the EFE score would use, with the baseline's own score in
``base`` and ``total``.
"""

from __future__ import annotations

from typing import Callable, Mapping, Sequence

import numpy as np

from fg_tea.planning.base import (
    Candidate,
    Decision,
    DistanceModel,
    PlannerBase,
    check_inputs,
    distance_vector,
    most_relevant,
    repeat_counts,
)
from fg_tea.planning.efe import FactorisedEFEPlanner


def _fresh_sites(eligible: list[int], counts: np.ndarray) -> list[int]:
    """Eligible sites never inspected; when all were, those inspected least often."""
    fewest = min(int(counts[j]) for j in eligible)
    return [j for j in eligible if counts[j] == fewest]


def _site_decision(name: str, belief, objects: Sequence[str], relevance: Mapping[str, float],
                   distances: DistanceModel, inspected: Mapping[str, int],
                   excluded_sites: frozenset[str], score: Callable[[list[int], np.ndarray], np.ndarray],
                   views=None) -> Decision:
    """A site-level baseline: score the least-inspected eligible sites for the most relevant object.

    Args:
        score: (pool of site indices, distances d of all sites) -> one total per pool site;
            the smallest wins (first in site order on ties).
    """
    _, eligible = check_inputs(belief, objects, relevance, excluded_sites, views)
    sites = list(belief.sites)
    d = distance_vector(distances, sites)
    counts = repeat_counts(inspected, sites)
    pool = _fresh_sites(eligible, counts)
    totals = score(pool, d)
    target = most_relevant(objects, relevance)
    q = belief.location(target)
    candidates = tuple(Candidate(target, sites[j], float(d[j]), float(q[j]), 0.0, int(counts[j]),
                                 float(relevance[target]), float(t), float(t))
                       for j, t in zip(pool, totals))
    best = min(candidates, key=lambda c: c.total)  # first minimum in site order
    return Decision(best.object, best.viewpoint, best.total, candidates, name)


class NearestPlanner(PlannerBase):
    """Go to the nearest site not yet inspected in this search (ties: site order).

    Score: total = d_j (metres) over the sites with the fewest negative inspections so far.
    """

    name = "nearest"

    def choose(self, belief, objects: Sequence[str], relevance: Mapping[str, float],
               distances: DistanceModel, inspected: Mapping[str, int],
               excluded_sites: frozenset[str] = frozenset(), views=None) -> Decision:
        return _site_decision(self.name, belief, objects, relevance, distances, inspected,
                              excluded_sites, lambda pool, d: d[pool], views)


class GreedyProbabilityPlanner(PlannerBase):
    """Inspect the most probable (object, site): argmax q(L_o = j) (ties: object, then site order).

    Score: total = -q(L_o = j). No distance, information or repeat term: after a miss, eq. 6
    lowers q at the inspected site by the factor mu, which is what moves the search on.
    """

    name = "greedy"

    def choose(self, belief, objects: Sequence[str], relevance: Mapping[str, float],
               distances: DistanceModel, inspected: Mapping[str, int],
               excluded_sites: frozenset[str] = frozenset(), views=None) -> Decision:
        obj_idx, eligible = check_inputs(belief, objects, relevance, excluded_sites, views)
        sites = list(belief.sites)
        q = belief.location_matrix()[obj_idx]
        d = distance_vector(distances, sites)
        counts = repeat_counts(inspected, sites)
        candidates = tuple(Candidate(o, sites[j], float(d[j]), float(q[i, j]), 0.0, int(counts[j]),
                                     float(relevance[o]), float(-q[i, j]), float(-q[i, j]))
                           for i, o in enumerate(objects) for j in eligible)
        best = min(candidates, key=lambda c: c.total)
        return Decision(best.object, best.viewpoint, best.total, candidates, self.name)


class RandomPlanner(PlannerBase):
    """A uniformly random site among those not yet inspected (seeded; ties impossible).

    Each eligible site draws one key u ~ U[0, 1) from the Generator, in site order; the smallest
    key wins, and the keys are the candidates' totals, so the log shows the draw.

    Args:
        rng: the Generator all randomness comes from (one draw of K' numbers per decision).
    """

    name = "random"

    def __init__(self, rng: np.random.Generator) -> None:
        if not isinstance(rng, np.random.Generator):
            raise ValueError("RandomPlanner needs a numpy.random.Generator "
                             "(e.g. numpy.random.default_rng(seed))")
        self.rng = rng

    def choose(self, belief, objects: Sequence[str], relevance: Mapping[str, float],
               distances: DistanceModel, inspected: Mapping[str, int],
               excluded_sites: frozenset[str] = frozenset(), views=None) -> Decision:
        return _site_decision(self.name, belief, objects, relevance, distances, inspected,
                              excluded_sites, lambda pool, d: self.rng.random(len(pool)), views)


__all__ = ["NearestPlanner", "GreedyProbabilityPlanner", "RandomPlanner", "FactorisedEFEPlanner"]
