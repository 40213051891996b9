"""What one update did to the belief: the records :class:`~fg_tea.beliefs.engine.BeliefEngine`
returns for a look (:class:`LookUpdate`) and for a state reading or transition (:class:`StateUpdate`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np


@dataclass(frozen=True)
class LookUpdate:
    """The effect of one look on the location beliefs.

    Attributes:
        viewpoint: what was looked from: the inspected site (:meth:`BeliefEngine.observe_site`)
            or the viewpoint's name (:meth:`BeliefEngine.observe_viewpoint`).
        detections: the observation, object -> True (seen) / False (looked, not seen).
        before, after: location marginals of every object before and after, object -> one
            probability per site in :attr:`sites` order (``after_by_site()`` labels them).
        detected: objects seen, in object order.
        sites: the site names, in the order of the vectors of `before` and `after`.
    """

    viewpoint: str
    detections: Mapping[str, bool]
    before: Mapping[str, np.ndarray]
    after: Mapping[str, np.ndarray]
    detected: tuple[str, ...] = ()
    sites: tuple[str, ...] = ()

    def after_by_site(self) -> dict[str, dict[str, float]]:
        """:attr:`after` labelled by site: object -> {site: probability}, e.g.
        ``update.after_by_site()["mug"]["sideboard"]``."""
        return self._by_site(self.after)

    def before_by_site(self) -> dict[str, dict[str, float]]:
        """:attr:`before` labelled by site, as :meth:`after_by_site`."""
        return self._by_site(self.before)

    def _by_site(self, marginals: Mapping[str, np.ndarray]) -> dict[str, dict[str, float]]:
        if not self.sites:
            raise ValueError("this LookUpdate was made without its site names (sites=...)")
        return {o: dict(zip(self.sites, map(float, p), strict=True)) for o, p in marginals.items()}


@dataclass(frozen=True)
class StateUpdate:
    """Belief in each touched state, before and after an observation or transition."""

    kind: str
    before: Mapping[str, float]
    after: Mapping[str, float]
    detail: Mapping[str, object] = field(default_factory=dict)
