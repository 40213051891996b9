"""The environment adapter: how an action happens in the house, and what the camera sees.

This is the boundary of the project's scientific point (docs/design.md eq. (1), §1): truth lives
only behind an :class:`EnvAdapter`, which answers with the observation types of
:mod:`fg_tea.world.interface` and never with the hidden truth itself.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from fg_tea.world.interface import (
    ActionRequest,
    ActionResult,
    InspectionResult,
    Pose,
    StateReading,
)
from fg_tea.world.visibility import VisibilityCurve


@dataclass(frozen=True)
class EnvConfig:
    """Embodiment parameters (defaults: docs/design.md §8.6). Units: metres, degrees, pixels.

    ``look_frames`` is how many frames the agent holds still while it takes an inspection image:
    looking takes time, so even an inspection from where the agent already stands advances the
    frame count (and the frame limit always ends an episode).

    Experiment knobs, off by default: ``failure_rates`` (verb -> probability that the action fails
    with ``injected_failure``) and ``detection_miss_rate``, the probability in [0, 1] that a
    detection the camera would make (eq. 29 satisfied) is dropped, so the object is reported as
    looked-and-not-seen. Both are drawn from the environment's seeded RNG, and only when the rate
    is above zero, so runs with the defaults draw exactly as before and stay byte-identical.
    ``unfindable`` names objects (comma-separated) the camera never reports, wherever they stand: a stand-in for an
    object that is not in the house or out of reach, to measure what a search costs before it is
    given up (docs/design.md §7.8). It draws nothing. ``effect_success`` (truth effect -> P(the
    effect happens)) makes an action that *reports success* leave its states unchanged with
    probability 1 - p (``{"boil": 0.6}``: the kettle heats in 60 % of boils; docs/design.md §12.5);
    one draw per such action, only for the effects named, never reported to the agent.

    The camera's fields (``min_visible_pixels``, ``site_association``, its radius and
    ``camera_curve``) come from a camera file (``fg_tea.env.camera``, docs/design.md §1.3).
    """

    movement_step: float = 0.018
    turn_step_deg: float = 2.5
    turn_before_move_deg: float = 20.0
    face_tolerance_deg: float = 2.5
    agent_radius: float = 0.22
    grid_resolution: float = 0.05
    sensor_height: float = 1.25
    ego_width: int = 320
    ego_height: int = 240
    ego_hfov_deg: float = 90.0
    min_visible_pixels: int = 25
    look_frames: int = 8
    site_association: bool = True
    site_association_radius: float = 0.45
    distance: str = "geodesic"  # or "euclidean" (ablation)
    failure_rates: Mapping[str, float] = field(default_factory=dict)  # verb -> P(fail), injected
    detection_miss_rate: float = 0.0  # P(a would-be detection is dropped), injected
    unfindable: str = ""  # "mug,teabag": objects the camera never reports (absent), injected
    effect_success: Mapping[str, float] = field(default_factory=dict)  # effect -> P(happens), injected
    camera_curve: VisibilityCurve | None = None  # None: threshold detector (eq. 29)
    #: The camera file these camera fields came from (``fg_tea.env.camera``), for provenance.
    camera_source: str = ""

    def __post_init__(self) -> None:
        from fg_tea.env.truth import check_effect_success

        check_effect_success(self.effect_success)


class EnvAdapter(abc.ABC):
    """Turns declarative verbs into motion and observations. Never hands truth to the agent."""

    config: EnvConfig

    @abc.abstractmethod
    def reset(self, seed: int) -> Pose:
        """Rebuild the world from the scenario; seed the one RNG; return the start pose."""

    @abc.abstractmethod
    def agent_pose(self) -> Pose:
        """Current agent pose."""

    @abc.abstractmethod
    def distance_to_site(self, site: str) -> float:
        """Travel distance (metres) from the agent to the site's vantage point; inf if unreachable."""

    @abc.abstractmethod
    def distance_between_sites(self, a: str, b: str) -> float:
        """Travel distance (metres) from site a's vantage point to site b's; inf if unreachable."""

    def walking_distance(self, target: str, xy: Sequence[float]) -> float:
        """Metres the agent would walk from floor point `xy` to viewpoint `target`; inf if none.

        The length of the path the agent follows (what an observation's ``distance`` measures),
        not the planner's estimate. For evaluation only (the clairvoyant yardstick of
        :mod:`fg_tea.episode.yardstick`); adapters that cannot say raise NotImplementedError.
        """
        raise NotImplementedError(f"{type(self).__name__} does not report walking distances")

    @abc.abstractmethod
    def inspect_viewpoint(self, viewpoint: str, objects: Sequence[str]) -> InspectionResult:
        """Go to the viewpoint, face each site in view in turn, look, report on `objects` only.

        A site's close look is the viewpoint named after the site (docs/design.md §5).
        """

    def expected_pixel_counts(self, categories: Sequence[str]
                              ) -> Mapping[str, Mapping[str, Mapping[str, Sequence[float]]]]:
        """Pixels an object of each category would cover on each site in view of each viewpoint,
        standing alone at each of the site's placement slots in turn.

        House geometry and object models only, never where objects truly are (see
        docs/design.md §3.4, "Detection from visibility"). Returns viewpoint -> site -> category
        -> [pixels at slot 0, slot 1, ...]; the agent weighs the slots. An adapter without slots
        may give one number (one slot) instead of a list.
        """
        raise NotImplementedError(f"{type(self).__name__} cannot predict visibility; use the "
                                  "threshold detector with close looks only")

    def company_pixel_counts(self, categories: Sequence[str]) -> Mapping[str, Any]:
        """What the expected counts of :meth:`expected_pixel_counts` leave out: the turn
        tolerance of a real look and the other objects on the same site (docs/design.md §3.4,
        "Facing and company").

        House geometry and object models only, never where objects truly are. Returns
        ``{"offsets_deg": [h_1, ...], "views": viewpoint -> site -> {"facing": category ->
        [[pixels at slot s, heading offset h] ...], "company": "c|c2" -> [[pixels of c at slot s
        with c2 at slot s2] ...]}}`` (the diagonal s = s2 is None). A category is paired with
        itself only when `categories` names it twice.
        """
        raise NotImplementedError(f"{type(self).__name__} cannot predict occlusion")

    @abc.abstractmethod
    def observe_state(self, obj: str, state: str, site: str | None,
                      sensitivity: float, specificity: float) -> StateReading:
        """Go to `site` (None: the object is held) and read `obj.state` through a noisy sensor."""

    @abc.abstractmethod
    def execute(self, request: ActionRequest) -> ActionResult:
        """Carry out a practical action and its truth effects; report failure, never pretend."""

    def truth_report(self) -> dict:
        """The world's hidden truth now, for evaluating an episode after it ends.

        Experiments and the episode log's final record use it; the runner never passes it to the
        agent side. Returns ``{"states": {name: bool}, "sites": {object: site or None},
        "held": object or None, "contained_in": {object: container}}``, and ``"uses_left":
        {object: uses}`` when the scenario has consumables (:mod:`fg_tea.world.consumables`).
        """
        return {}

    def placements(self) -> Mapping[str, tuple[float, float, float]]:
        """Where each object's body stands now (for rendering only, never for the agent)."""
        return {}

    def close(self) -> None:
        """Release simulator resources."""

    def __enter__(self) -> "EnvAdapter":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
