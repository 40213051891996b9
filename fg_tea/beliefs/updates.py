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
        before, after: location marginals of every object before and after.
        detected: objects seen, in object order.
    """

    viewpoint: str
    detections: Mapping[str, bool]
    before: Mapping[str, np.ndarray]
    after: Mapping[str, np.ndarray]
    detected: tuple[str, ...] = ()


@dataclass(frozen=True)
class StateUpdate:
    """Belief in each touched state, before and after an observation or transition."""

    kind: str
    before: Mapping[str, float]
    after: Mapping[str, float]
    detail: Mapping[str, object] = field(default_factory=dict)
