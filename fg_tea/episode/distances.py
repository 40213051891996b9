"""Planner distances from an environment: the one adapter between an environment's geodesic
lookups and a planner's :class:`~fg_tea.planning.base.DistanceModel` (docs/design.md §6.1).

The runner hands it to the agent at every decision; the exact-policy yardstick
(:mod:`fg_tea.study.yardstick`) reads the start pose's distances through it and moves the agent
with :meth:`EnvDistances.at`.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np


class EnvDistances:
    """Planner distances from the environment: geodesic lookups from the agent and between sites.

    Distances between viewpoints do not change during an episode (the floor plan is fixed), so
    `between`, when given, is the episode's cache of them: a planner that asks for the whole
    matrix at every decision (the lookahead: 27 sites and 9 room viewpoints, 1,296 lookups)
    computes it once, and keeps each whole matrix asked for (`matrices`, by viewpoint names).
    """

    def __init__(self, env: Any, between: dict[tuple[str, str], float] | None = None,
                 matrices: dict[tuple[str, ...], np.ndarray] | None = None) -> None:
        self._env = env
        self._from: dict[str, float] = {}
        self._between = {} if between is None else between
        self._matrices = {} if matrices is None else matrices

    def from_agent(self, site: str) -> float:
        if site not in self._from:
            self._from[site] = float(self._env.distance_to_site(site))
        return self._from[site]

    def between(self, a: str, b: str) -> float:
        if a == b:
            return 0.0
        key = (a, b)
        if key not in self._between:
            self._between[key] = float(self._env.distance_between_sites(a, b))
        return self._between[key]

    def matrix_for(self, sites: Sequence[str]) -> np.ndarray:
        """Metres between every two of `sites`, shape (K, K), zero diagonal (read-only, cached)."""
        key = tuple(sites)
        found = self._matrices.get(key)
        if found is None:
            # Most decisions ask for a subset of an earlier matrix (viewpoints drop out as
            # sites are excluded): copy its entries rather than look each pair up again.
            whole = max(self._matrices, key=len, default=())
            index = {s: i for i, s in enumerate(whole)}
            if key and all(s in index for s in key):
                rows = np.array([index[s] for s in key])
                found = self._matrices[whole][np.ix_(rows, rows)]
            else:
                found = np.array([[self.between(a, b) if a != b else 0.0 for b in key] for a in key])
            found.setflags(write=False)
            self._matrices[key] = found
        return found

    def at(self, viewpoint: str | None) -> "StandingAt":
        """The same distances with the agent standing at `viewpoint` (None: where it is now)."""
        return StandingAt(self, viewpoint)


class StandingAt:
    """An :class:`EnvDistances` seen from a viewpoint's vantage (None: from the agent)."""

    def __init__(self, distances: EnvDistances, here: str | None) -> None:
        self.distances, self.here = distances, here

    def from_agent(self, site: str) -> float:
        d = self.distances
        return d.from_agent(site) if self.here is None else d.between(self.here, site)

    def between(self, a: str, b: str) -> float:
        return self.distances.between(a, b)


__all__ = ["EnvDistances", "StandingAt"]
