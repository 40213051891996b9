"""The exact policy of the cut search problem at a cap that fits a budget (docs/design.md §6.9).

``near_exact`` decides as :class:`fg_tea.planning.exact.ExactPlanner` does, by looking the
current state up in the tables of the upper cut (at most ``cap`` looks per viewpoint, then a
cyclic sweep), solved once and reused while they describe the belief. Two things differ:

- **The solve** is :func:`fg_tea.planning.cut_tables.solve_cut`, the same tables computed layer
  by layer for every set of found objects at once: on the bundled apartment with three objects
  it takes about a sixth of the time of :func:`fg_tea.planning.limit.solve_tables` at cap 2,
  where almost all of that time was numpy call overhead, not arithmetic.
- **The cap** is the largest one up to ``cap`` (default 2) whose tables have at most ``budget``
  entries (default 2^19: levels^viewpoints x viewpoints x 2^objects), so the solve's cost is
  bounded whatever the house: cap 2 fits the apartment's 8 viewpoints with up to three objects.
  The defaults are the design ``experiments/planner_gap.py`` chose on its discovery worlds among
  budgets of 2^17, 2^19 and 2^21 entries at caps up to 3 and 2^19 at cap 2 (its rule: the
  smallest largest distance from the limit among the designs within 4 ms of CPU per decision;
  2^21 allows cap 3 with two objects in 8 viewpoints, a 50 ms solve). The cap used is recorded
  in every decision (``info["near_exact"]``). Below cap 2 the tables are not used: the cut at
  one look per viewpoint forbids looking again from a viewpoint before every other has been
  looked from, the very looks the lookahead misses, and its policy is further from the limit than
  the lookahead's in most discovery houses (``exact:cap=1`` in
  ``experiments/results/planner_gap/discovery.md``). The decision is then the
  default lookahead's (:class:`fg_tea.planning.lookahead.LookaheadPlanner`), and
  ``info["near_exact"]`` says so and why; so does a correlated belief, for which the tables do
  not hold.
- **Restricted tables** (``restrict=1``; default 0, the above): where the tables of every useful
  viewpoint do not fit at cap 2, the tables of the viewpoints that cover most mass at the current
  belief and position, as many as fit, solved again when they cover more than ``slack`` (default 0)
  less mass than the best such set (:mod:`fg_tea.planning.restricted_tables`);
  ``info["near_exact"]`` says ``tables cap=2 over k of n viewpoints``. Measured in two
  12-viewpoint houses by ``experiments/planner_gap.py``'s ``wide-*`` phases
  (``experiments/results/planner_gap/wide/``).

What drives the gap between the lookahead and the limit, decision by decision, and what this
planner costs and gains in the bundled apartment and the small generated houses, is measured by
``experiments/planner_gap.py`` (results in ``experiments/results/planner_gap/``).
Planner specs: ``near_exact`` or ``near_exact:cap=2,budget=524288,restrict=0`` (the defaults).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from fg_tea.model.spec import PlanningWeights
from fg_tea.planning.base import Decision, DistanceModel, PlannerBase, check_inputs, parse_settings
from fg_tea.planning.cut_tables import solve_cut
from fg_tea.planning.exact import ExactPlanner, ExactSettings, _Solved
from fg_tea.planning.limit import _useful
from fg_tea.planning.lookahead import LookaheadPlanner
from fg_tea.planning.problem import LOOK_COST, build_problem
from fg_tea.planning.restricted_tables import STANDING, RestrictedSolved, solve_restricted

#: The smallest cap whose tables are used; below it the decision is the lookahead's.
MIN_CAP = 2
#: Default most table entries of one solve (levels^viewpoints x viewpoints x 2^objects), with
#: the default cap the design ``experiments/planner_gap.py`` chose on its discovery worlds.
BUDGET = 2 ** 19
#: Default largest cap.
CAP = 2


def table_entries(n_views: int, n_objects: int, cap: int) -> int:
    """Entries of the upper cut's tables at `cap`: (cap + 1)^A count vectors, A positions and
    2^m found sets."""
    return (cap + 1) ** n_views * n_views * 2 ** n_objects


def fitted_cap(n_views: int, n_objects: int, cap: int, budget: int) -> int:
    """The largest cap from `cap` down to 1 whose tables have at most `budget` entries, or 0."""
    return next((c for c in range(cap, 0, -1) if table_entries(n_views, n_objects, c) <= budget), 0)


def restricted_size(n_objects: int, budget: int, most: int = 64) -> int:
    """The most viewpoints whose tables at cap :data:`MIN_CAP` fit `budget` (``restrict=1``), or 0."""
    return next((k for k in range(most, 0, -1) if table_entries(k, n_objects, MIN_CAP) <= budget), 0)


@dataclass(frozen=True)
class NearExactSettings:
    """``near_exact:cap=N,budget=E,restrict=R``: the largest cap tried (2 to 8, default :data:`CAP`),
    the most table entries of one solve (at least 1000, default :data:`BUDGET`) and whether tables
    restricted to the viewpoints of most mass decide where those of all do not fit (1), or the
    lookahead (0, the default); with ``restrict=1``, ``slack=S`` (0 to below 1, default 0) is how
    much less mass the kept viewpoints may cover than the best set before they are solved again."""

    cap: int = CAP
    budget: int = BUDGET
    restrict: int = 0
    slack: float = 0.0

    def __post_init__(self) -> None:
        if not MIN_CAP <= self.cap <= 8:
            raise ValueError(f"near_exact: cap must be from {MIN_CAP} to 8, got {self.cap}")
        if self.budget < 1000:
            raise ValueError(f"near_exact: budget must be at least 1000 table entries, got {self.budget}")
        if self.restrict not in (0, 1):
            raise ValueError(f"near_exact: restrict must be 0 or 1, got {self.restrict}")
        if not 0.0 <= self.slack < 1.0:
            raise ValueError(f"near_exact: slack must be from 0 to below 1, got {self.slack}")

    @classmethod
    def parse(cls, spec: str) -> "NearExactSettings":
        """Settings from ``"cap=2,budget=524288"`` (empty: the defaults).

        Raises:
            ValueError: an unknown key or a malformed or out-of-range value.
        """
        return cls(**parse_settings("near_exact", spec, {"cap": int, "budget": int, "restrict": int,
                                                         "slack": float}))

    def spec(self) -> str:
        return (f"cap={self.cap},budget={self.budget}" + (",restrict=1" if self.restrict else "")
                + (f",slack={self.slack:g}" if self.slack else ""))


class _TooLarge(Exception):
    """No cap from :data:`MIN_CAP` up fits the budget (the message says how many entries)."""


class _NoCover(_TooLarge):
    """The restricted tables' viewpoints cannot cover every object (the message says how many);
    unlike the budget, this turns on the belief's masses, so the verdict is not kept."""


class _FittedTables(ExactPlanner):
    """The exact planner's table look-ups, solved by :func:`solve_cut` at the fitted cap."""

    def __init__(self, settings: NearExactSettings, look: float) -> None:
        super().__init__(ExactSettings(cap=settings.cap), look)
        self.budget = settings.budget
        self.restrict = bool(settings.restrict)
        self.slack = settings.slack + 1e-12
        self._distances: DistanceModel | None = None

    def check(self, belief, objects: Sequence[str]) -> None:
        return None  # NearExactPlanner routes a correlated belief and a large house elsewhere

    def choose(self, belief, objects: Sequence[str], relevance: Mapping[str, float],
               distances: DistanceModel, inspected: Mapping[str, int],
               excluded_sites: frozenset[str] = frozenset(), views=None) -> Decision:
        self._distances = distances  # where the agent stands decides the viewpoints restricted tables keep
        return super().choose(belief, objects, relevance, distances, inspected, excluded_sites, views)

    def _state(self, solved: _Solved, belief, objects, inspected, excluded):
        """As the exact planner's, and for restricted tables (``restrict=1``) only while the
        budget leaves room for as many viewpoints and those kept cover at most ``slack`` less mass
        than the best set at the current belief and position."""
        if isinstance(solved, RestrictedSolved):
            assert self._distances is not None, "restricted tables are solved in choose"
            here = next((v for v in solved.every if self._distances.from_agent(v) < STANDING), None)
            if (restricted_size(len(objects), self.budget) != solved.k
                    or solved.shortfall(belief, objects, here) > self.slack):
                return None
        return super()._state(solved, belief, objects, inspected, excluded)

    def _solve(self, belief, objects, distances, inspected, excluded, views) -> _Solved:
        problem = build_problem(belief, objects, distances, excluded, views, self.look)
        useful, sites, q0 = _useful(problem)
        cap = fitted_cap(len(useful), len(objects), self.settings.cap, self.budget)
        k = restricted_size(len(objects), self.budget)
        if cap < MIN_CAP and self.restrict and k >= 1:
            try:
                solved = solve_restricted(problem, objects, inspected, excluded, k,
                                          fitted_cap(k, len(objects), self.settings.cap, self.budget))
            except ValueError as exc:
                raise _NoCover(str(exc)) from None
            self.solves += 1
            return solved
        if cap < MIN_CAP:
            need = table_entries(len(useful), len(objects), MIN_CAP)
            raise _TooLarge(f"{len(useful)} viewpoints and {len(objects)} object"
                            f"{'s' * (len(objects) != 1)} need {need} table entries at cap {MIN_CAP}, "
                            f"more than the budget {self.budget}")
        tables = solve_cut(problem, useful, sites, q0, cap)
        self.solves += 1
        names = [problem.names[i] for i in useful]
        miss = 1.0 - problem.prob[useful]
        return _Solved(tables, names, tuple(objects), dict(inspected), excluded, q0, miss,
                       problem.allowed)


class NearExactPlanner(PlannerBase):
    """Decide by the upper cut's exact tables at a cap fitted to a budget (module docstring).

    Args:
        weights: the EFE weights of the lookahead that decides where the tables do not fit.
        settings: the largest cap and the budget of table entries.
        look: metres-equivalent cost of one image.
    """

    name = "near_exact"

    def __init__(self, weights: PlanningWeights, settings: NearExactSettings = NearExactSettings(),
                 look: float = LOOK_COST) -> None:
        self.settings = settings
        self.tables = _FittedTables(settings, look)
        self.lookahead = LookaheadPlanner(weights)
        # the last search whose tables did not fit, and why: (key, views, reason)
        self._too_large: tuple[tuple, object, str] | None = None
        self._said = False  # whether the first decision by the lookahead was announced on stderr

    @property
    def solves(self) -> int:
        """Table solves so far (each one at the cap it records)."""
        return self.tables.solves

    def check(self, belief, objects: Sequence[str]) -> None:
        """The lookahead's limits: a correlated belief is planned by it.

        Raises:
            PlannerRefused: a correlated belief whose joint the lookahead cannot hold.
        """
        if belief.correlated:
            self.lookahead.check(belief, objects)

    def choose(self, belief, objects: Sequence[str], relevance: Mapping[str, float],
               distances: DistanceModel, inspected: Mapping[str, int],
               excluded_sites: frozenset[str] = frozenset(), views=None) -> Decision:
        """The look of least expected cost under the fitted tables, or the lookahead's look where
        they do not hold or fit (``info["near_exact"]`` says which, and why)."""
        check_inputs(belief, objects, relevance, excluded_sites, views)
        why = "the belief is correlated" if belief.correlated else ""
        # The viewpoints the tables need, and so whether they fit, follow from the objects, the
        # excluded sites, the views and where each object may stand: the same as at the last
        # decision whose tables did not fit, the answer is the same, without building the problem.
        key = (tuple(objects), frozenset(excluded_sites),
               tuple(tuple(np.flatnonzero(np.asarray(belief.marginal(o)) > 0)) for o in objects))
        last = self._too_large
        if not why and last is not None and last[0] == key and last[1] is views:
            why = last[2]
        if not why:
            try:
                d = self.tables.choose(belief, objects, relevance, distances, inspected,
                                       excluded_sites, views)
            except _TooLarge as exc:
                why = str(exc)
                if not isinstance(exc, _NoCover):
                    self._too_large = (key, views, why)
            else:
                solved = self.tables._solved
                assert solved is not None
                route = f"tables cap={solved.tables.cap}"
                if isinstance(solved, RestrictedSolved):
                    route += f" over {len(solved.kept)} of {len(solved.every)} viewpoints"
                return Decision(d.object, d.viewpoint, d.total, d.candidates, self.name,
                                {**d.info, "near_exact": route, "budget": float(self.settings.budget)})
        self.tables._solved = None
        if not self._said:
            self._said = True
            warnings.warn(f"near_exact: deciding as the lookahead does where the tables do not hold ({why}); "
                          "each decision's info['near_exact'] records how it was made", stacklevel=2)
        d = self.lookahead.choose(belief, objects, relevance, distances, inspected, excluded_sites, views)
        return Decision(d.object, d.viewpoint, d.total, d.candidates, self.name,
                        {**d.info, "near_exact": f"lookahead: {why}", "budget": float(self.settings.budget)})


def decision_route(decision: Decision) -> str:
    """``"tables"`` or ``"lookahead"``: how a near_exact decision was made."""
    return str(decision.info.get("near_exact", "")).split(" ")[0].rstrip(":")


__all__ = ["NearExactPlanner", "NearExactSettings", "fitted_cap", "table_entries", "decision_route",
           "MIN_CAP", "BUDGET", "CAP"]
