"""near_exact beyond the size its tables fit: the exact tables of a restricted search (docs/design.md §6.9).

Where the upper cut's tables at cap 2 over every useful viewpoint do not fit near_exact's budget
(12 close looks or more, one to three objects), ``near_exact:restrict=1`` still decides by exact
tables, of a smaller search: the ``k`` viewpoints that cover most of the searched objects' mass at
the current belief (greedily: each next viewpoint the one whose sites add the most mass not yet
covered, summed over the objects still searched), ``k`` the most whose tables at the cap fit the
budget; the viewpoint the agent stands at is kept first, so that looking again from it stays a
choice, and an object the cover would leave with no mass gets its best viewpoint (where ``k``
cannot cover every object, near_exact decides as the lookahead and says why). The restricted
search is the current belief conditioned on the objects standing at sites those viewpoints show;
its tables are solved by :func:`fg_tea.planning.cut_tables.solve_cut` and reused while they
describe the belief (the checks of :class:`fg_tea.planning.exact.ExactPlanner`), the number of
objects leaves the same number of viewpoints in the budget, and the kept viewpoints cover at most
``slack`` less of the mass (averaged over the objects still searched) than the ones the cover
would keep now (:meth:`RestrictedSolved.shortfall`); else they are solved again from the current
belief. The mass left out is not charged: the restricted tables plan as if it were not there, and
it comes back into the search as the covered mass falls.

The decision is thus a function of the belief and of where the last solve started, as
near_exact's own is; it never reads anything but the belief, the distances and the views.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from fg_tea.planning.cut_tables import solve_cut
from fg_tea.planning.exact import _Solved
from fg_tea.planning.limit import _useful
from fg_tea.planning.problem import SearchProblem

#: Metres from a viewpoint within which the agent stands at it (its next look there is a re-look).
STANDING = 1e-9


def greedy_cover(shows: np.ndarray, masses: np.ndarray, k: int, first: int | None = None) -> np.ndarray:
    """The `k` viewpoints (rows of `shows`, ascending) that cover the most mass, greedily: row
    `first` (the viewpoint the agent stands at, if any), then each next one the row that adds the
    most of ``masses`` (objects x sites) summed over the objects at sites (columns) no row chosen so
    far shows; ties go to the earlier row. Then, should an object with mass have none at the sites
    covered (possible only in skewed beliefs), the latest pick other than `first` gives way to the
    row that covers most of that object's mass, object by object. Every row if `k` is at least
    their number.

    Raises:
        ValueError: `k` rows cannot cover some mass of every object.
    """
    n = shows.shape[0]
    if k >= n:
        return np.arange(n)
    masses = np.atleast_2d(masses)
    mass = masses.sum(axis=0)
    covered = np.zeros(shows.shape[1], dtype=bool)
    free = np.ones(n, dtype=bool)
    chosen: list[int] = []
    for i in range(k):
        gain = np.where(free, (shows & ~covered[None, :]).astype(float) @ mass, -1.0)
        j = first if i == 0 and first is not None else int(np.argmax(gain))
        chosen.append(j)
        free[j] = False
        covered |= shows[j]
    fixed = [j for j in chosen if j == first]              # rows an object's swap has put in, and `first`
    for u in range(masses.shape[0]):
        if masses[u].sum() <= 0 or masses[u] @ shows[chosen].any(axis=0) > 0:
            continue
        out = next((j for j in reversed(chosen) if j not in fixed), None)
        if out is None:
            raise ValueError(f"restricted search: {k} viewpoints cannot cover some mass of every object")
        best = int(np.argmax(shows.astype(float) @ masses[u]))
        chosen[chosen.index(out)] = best
        fixed.append(best)
    if any(masses[u].sum() > 0 and masses[u] @ shows[chosen].any(axis=0) <= 0 for u in range(masses.shape[0])):
        raise ValueError(f"restricted search: {k} viewpoints cannot cover some mass of every object")
    return np.sort(np.array(chosen, dtype=np.int64))


def view_shows(problem: SearchProblem, useful: np.ndarray) -> np.ndarray:
    """(A', K') booleans: the open sites each useful viewpoint can show some object at."""
    return problem.prob[useful].max(axis=1) > 0


def restricted_problem(problem: SearchProblem, views: np.ndarray) -> SearchProblem:
    """`problem` with only `views` and the open sites they show, the objects' marginals
    restricted to those sites (the conditioning happens where the tables normalise them).

    Raises:
        ValueError: an object has no mass at the sites the views show.
    """
    assert problem.factors is not None, "a restricted search needs independent objects"
    shows = problem.prob[views].max(axis=1) > 0            # (A'', K')
    keep = np.flatnonzero(shows.any(axis=0))                # positions in problem.allowed
    factors = problem.factors[:, keep]
    if (factors.sum(axis=1) <= 0).any():
        raise ValueError("restricted search: an object has no mass at the sites of the chosen viewpoints")
    sub = replace(problem, names=tuple(problem.names[i] for i in views),
                  kinds=tuple(problem.kinds[i] for i in views), probability=problem.probability[views],
                  start=problem.start[views], between=problem.between[np.ix_(views, views)],
                  look=problem.look[views], allowed=problem.allowed[keep], factors=factors)
    sub.__dict__.pop("_prob", None)
    return sub


@dataclass
class RestrictedSolved(_Solved):
    """Tables of a restricted search, with what decides whether they are still the ones to use:
    the useful viewpoints of the whole search when solved, the sites each shows, its open sites
    (belief indices), the number of viewpoints kept and which (names)."""

    every: tuple[str, ...] = ()
    shows: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), dtype=bool))
    every_allowed: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    k: int = 0
    kept: tuple[str, ...] = ()

    def shortfall(self, belief, objects, here: str | None) -> float:
        """How much less mass the kept viewpoints cover at `belief` than the ones
        :func:`greedy_cover` would keep now (with the agent at viewpoint `here`, None: elsewhere):
        the mass of each object still searched over the whole search's open sites, normalised,
        averaged over the objects; inf if the agent stands at a useful viewpoint the tables left out."""
        if here in self.every and here not in self.kept:
            return float("inf")
        masses = np.zeros((len(objects), self.every_allowed.size))
        for u, o in enumerate(objects):
            m = np.asarray(belief.marginal(o), dtype=float)[self.every_allowed]
            masses[u] = m / max(float(m.sum()), 1e-300)
        mass = masses.sum(axis=0)
        first = self.every.index(here) if here in self.every else None
        try:
            now = greedy_cover(self.shows, masses, self.k, first)
        except ValueError:
            return float("inf")  # solved again: the solve says why no restricted tables hold
        kept = [self.every.index(v) for v in self.kept]
        gap = float(mass @ self.shows[now].any(axis=0) - mass @ self.shows[kept].any(axis=0))
        return gap / max(len(objects), 1)


def solve_restricted(problem: SearchProblem, objects, inspected, excluded, k: int, cap: int) -> RestrictedSolved:
    """The tables of `problem` restricted to the `k` viewpoints :func:`greedy_cover` keeps at its
    belief, at `cap` looks per viewpoint (:func:`fg_tea.planning.cut_tables.solve_cut`).

    Raises:
        ValueError: `k` viewpoints cannot cover some mass of every object.
    """
    useful, _, q0 = _useful(problem)
    shows = view_shows(problem, useful)
    here = np.flatnonzero(problem.start[useful] < STANDING)
    views = useful[greedy_cover(shows, q0, k, int(here[0]) if here.size else None)]
    sub = restricted_problem(problem, views)
    sub_useful, sub_sites, sub_q0 = _useful(sub)
    tables = solve_cut(sub, sub_useful, sub_sites, sub_q0, cap)
    names = [sub.names[i] for i in sub_useful]
    return RestrictedSolved(tables, names, tuple(objects), dict(inspected), excluded, sub_q0,
                            1.0 - sub.prob[sub_useful], sub.allowed,
                            every=tuple(problem.names[i] for i in useful), shows=shows,
                            every_allowed=problem.allowed, k=k, kept=tuple(problem.names[i] for i in views))


__all__ = ["greedy_cover", "view_shows", "restricted_problem", "RestrictedSolved", "solve_restricted"]
