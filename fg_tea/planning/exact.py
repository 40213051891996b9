"""The exact search policy under imperfect detection, where it fits (docs/design.md §6.9).

``exact`` solves the search once, by the dynamic program of :mod:`fg_tea.planning.limit`
(the upper cut: at most ``cap`` looks per viewpoint, then a cyclic sweep), and then decides by
looking the current state up in its tables: where the agent stands (any position: travel to each
viewpoint is added to the tables' expectations), the looks made from each viewpoint since the
solve, and the objects found since. Its expected cost is the upper bound of the limit, within
0.1 % of the limit in the bundled apartment at the default cap (``experiments/search_limit.py``).

The tables are valid while the belief is what they assume: the belief the solve started from,
updated by looks that missed. At every decision the planner checks that the belief's marginals of
the objects still searched equal the tables' posterior for the looks counted (relative 1e-6); when
they do not (another kind of evidence, a reopened search, an excluded site, other objects) or a
viewpoint has been looked from ``cap`` times, it solves again from the current belief. A
correlated belief is refused (the tables are exact for independent objects only), and so is a
house whose tables at the cap asked for (the default, 3, or ``exact:cap=N``) would need more than
:data:`MAX_BYTES` of memory (:func:`fg_tea.planning.limit.table_bytes`): the one-line refusal names
the house's size and the largest cap that fits, to ask for explicitly. The cap is never lowered
behind the user's back; every decision records the cap it planned with (``info["exact"]``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from fg_tea.common.errors import PlannerRefused
from fg_tea.planning.base import (Candidate, Decision, DistanceModel, PlannerBase, check_inputs,
                                  parse_settings)
from fg_tea.planning.limit import Tables, _useful, human_bytes, solve_tables, table_bytes
from fg_tea.planning.problem import LOOK_COST, build_problem

#: Memory one solve may use, bytes (512 MiB), as :func:`fg_tea.planning.limit.table_bytes` estimates
#: it: the apartment's 8 close looks fit up to cap 4, a house of 12 sites at cap 1 only.
MAX_BYTES = 512 * 1024 ** 2


@dataclass(frozen=True)
class ExactSettings:
    """``exact:cap=N``: at most N looks per viewpoint in the tables (1 to 8; default 3)."""

    cap: int = 3

    def __post_init__(self) -> None:
        if not 1 <= self.cap <= 8:
            raise ValueError(f"exact: cap must be from 1 to 8, got {self.cap}")

    @classmethod
    def parse(cls, spec: str) -> "ExactSettings":
        """Settings from ``"cap=3"`` (empty: the defaults).

        Raises:
            ValueError: an unknown key or a malformed or out-of-range value.
        """
        return cls(**parse_settings("exact", spec, {"cap": int}))


@dataclass
class _Solved:
    tables: Tables
    names: list[str]            # the useful viewpoints, in the tables' order
    objects: tuple[str, ...]    # the objects searched when solved (the tables' bit order)
    counts: dict[str, int]      # looks per viewpoint when solved
    excluded: frozenset[str]
    posterior: np.ndarray       # (U, K') q0 over the problem's open sites
    miss: np.ndarray            # (A', U, K') 1 - p over the useful viewpoints
    allowed: np.ndarray         # the open sites (belief indices)


class ExactPlanner(PlannerBase):
    """Decide by the exact tables of the cut search problem (see the module docstring)."""

    name = "exact"

    def __init__(self, settings: ExactSettings = ExactSettings(), look: float = LOOK_COST,
                 max_bytes: int = MAX_BYTES) -> None:
        self.settings, self.look, self.max_bytes = settings, look, max_bytes
        self._solved: _Solved | None = None
        self.solves = 0

    def check(self, belief, objects: Sequence[str]) -> None:
        """Refuse a correlated belief, or a house whose tables do not fit at the cap asked for.

        Before the episode the viewpoints are not known: the sites where some searched object may
        stand count as viewpoints (the close looks); a solve checks the viewpoints it has again.

        Raises:
            PlannerRefused: kind ``"belief"`` or ``"size"``.
        """
        if belief.correlated:
            raise PlannerRefused("exact planner: the belief is correlated; the exact tables hold "
                                 "for independent objects only (use a factorised model)",
                                 "belief", self.name)
        mass = sum((np.asarray(belief.marginal(o), dtype=float) > 0).astype(int) for o in objects)
        n_sites = int(np.count_nonzero(mass)) if len(objects) else 0
        self._fit(n_sites, n_sites, len(objects), "sites")

    def _fit(self, n_views: int, n_sites: int, n_objects: int, what: str) -> None:
        """Refuse, in one line, tables that need more than :attr:`max_bytes` at the cap asked for,
        naming the largest cap that fits (never lowering the cap silently)."""
        cap = self.settings.cap
        need = table_bytes(n_views, n_objects, n_sites, cap + 1)
        if need <= self.max_bytes:
            return
        fits = [c for c in range(cap - 1, 0, -1) if table_bytes(n_views, n_objects, n_sites, c + 1)
                <= self.max_bytes]
        hint = (f"cap {fits[0]} fits: ask for it as exact:cap={fits[0]}" if fits
                else "no cap fits: use another planner (e.g. lookahead)")
        raise PlannerRefused(f"exact planner: {n_views} {what} and {n_objects} object"
                             f"{'s' * (n_objects != 1)} need about {human_bytes(need)} of tables at "
                             f"cap {cap}, more than {human_bytes(self.max_bytes)}; {hint}",
                             "size", self.name)

    def _solve(self, belief, objects, distances, inspected, excluded, views) -> _Solved:
        problem = build_problem(belief, objects, distances, excluded, views, self.look)
        useful, sites, q0 = _useful(problem)
        self._fit(len(useful), len(sites), len(objects), "viewpoints")
        tables = solve_tables(problem, useful, sites, q0, self.settings.cap, upper=True)
        self.solves += 1
        names = [problem.names[i] for i in useful]
        miss = 1.0 - problem.prob[useful]
        return _Solved(tables, names, tuple(objects), dict(inspected), excluded, q0, miss,
                       problem.allowed)

    def _state(self, solved: _Solved, belief, objects, inspected, excluded):
        """(looks per useful viewpoint since the solve, found mask), or None if the tables no
        longer describe the belief."""
        if excluded != solved.excluded or not set(objects) <= set(solved.objects):
            return None
        counts = np.array([inspected.get(v, 0) - solved.counts.get(v, 0) for v in solved.names])
        if (counts < 0).any() or (counts >= solved.tables.cap).all():
            return None
        for u, o in enumerate(solved.objects):
            if o not in objects:
                continue
            post = solved.posterior[u] * np.prod(solved.miss[:, u, :] ** counts[:, None], axis=0)
            if post.sum() <= 0:
                return None
            have = np.asarray(belief.marginal(o))[solved.allowed]
            if not np.allclose(post / post.sum(), have / max(have.sum(), 1e-300), rtol=1e-6, atol=1e-12):
                return None
        found = sum(1 << u for u, o in enumerate(solved.objects) if o not in objects)
        return counts, found

    def choose(self, belief, objects: Sequence[str], relevance: Mapping[str, float],
               distances: DistanceModel, inspected: Mapping[str, int],
               excluded_sites: frozenset[str] = frozenset(), views=None) -> Decision:
        """The look of least expected cost to find every object, from the exact tables."""
        check_inputs(belief, objects, relevance, excluded_sites, views)
        self.check(belief, objects)
        excluded = frozenset(excluded_sites)
        state = None if self._solved is None else self._state(self._solved, belief, objects,
                                                                inspected, excluded)
        if state is None:
            self._solved = self._solve(belief, objects, distances, inspected, excluded, views)
            state = self._state(self._solved, belief, objects, inspected, excluded)
            assert state is not None, "a fresh solve describes the belief it started from"
        solved = self._solved
        assert solved is not None
        counts, found = state
        travel = np.array([float(distances.from_agent(v)) for v in solved.names])
        q = solved.tables.q_values(None, counts, found, travel=travel)
        if not np.isfinite(q).any():  # every look at the cap: solve again from here
            self._solved = solved = self._solve(belief, objects, distances, inspected, excluded, views)
            counts, found = np.zeros(len(solved.names), dtype=np.int64), 0
            travel = np.array([float(distances.from_agent(v)) for v in solved.names])
            q = solved.tables.q_values(None, counts, found, travel=travel)
        best = int(np.argmin(q))
        sites = list(belief.sites)
        candidates = []
        now = solved.posterior * np.prod(solved.miss ** counts[:, None, None], axis=0)
        now = now / np.maximum(now.sum(axis=1, keepdims=True), 1e-300)  # (U, K') this moment
        for w, name in enumerate(solved.names):
            if not math.isfinite(q[w]):
                continue
            finds = [(float((now[u] * (1.0 - solved.miss[w, u])).sum()), o)
                     for u, o in enumerate(solved.objects) if o in objects]
            chance, obj = max(finds)
            kind = views.view(name).kind if views is not None else "site"
            candidates.append(Candidate(obj, name, float(travel[w]), chance, 0.0,
                                        int(inspected.get(name, 0)), float(relevance[obj]),
                                        float(q[w]), float(q[w]), kind))
        chosen = next(c for c in candidates if c.viewpoint == solved.names[best])
        info: dict[str, float | str] = {"exact": f"cap={solved.tables.cap}", "expected_cost": float(q[best]),
                "solves": float(self.solves), "viewpoints": float(len(solved.names)),
                "look_cost": self.look, "sites": float(len(sites))}
        return Decision(chosen.object, chosen.viewpoint, chosen.total, tuple(candidates), self.name, info)
