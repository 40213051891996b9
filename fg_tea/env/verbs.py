"""How a declarative verb happens in the house: the verbs of :class:`TruthBackedAdapter`.

This module answers *given a practical action request, what does it need, what does it change in
the hidden truth, and which failure does it report?* (docs/design.md §8.5). :class:`ActionVerbs`
carries out NAVIGATE, PICK, PLACE, INSERT, FILL, POUR, USE and WAIT over the adapter's
:class:`~fg_tea.env.truth.TeaTruth`, walking and facing with the adapter's motion (its half of
:class:`~fg_tea.env.adapter.TruthBackedAdapter`, which is built from it).

Failure reasons (``ActionResult.reason``): ``injected_failure`` (seeded fault injection,
``config.failure_rates[verb]``), ``unreachable``, ``object_not_at_site``, ``not_graspable``,
``hands_full``, ``not_held``, ``not_a_container``, ``destination_not_at_site``,
``destination_out_of_reach``, ``object_out_of_reach``, ``site_full``, ``used_up`` (a consumable
object with no use left, :mod:`fg_tea.world.consumables`: checked last, when everything else
would let the action succeed, so a use is taken only by an action that happens). A failed action
has no truth effect. A malformed request (unknown verb, object, site or effect, or a missing field the
verb needs) raises ``ValueError``: that is a caller bug, not a world event.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Mapping, Sequence

import numpy as np

from fg_tea.env.base import EnvConfig
from fg_tea.env.motion import motion_of
from fg_tea.env.truth import EFFECTS, TeaTruth, effect_happens
from fg_tea.world.consumables import USED_UP
from fg_tea.world.interface import ActionRequest, ActionResult, Pose
from fg_tea.world.scenario import ObjectSpec, Scenario

#: Truth effect a verb applies when the request names none.
DEFAULT_EFFECT = {"FILL": "fill", "POUR": "pour"}


#: Horizontal reach (m) of the kinematic gripper: an object closer than this to the agent can be
#: used, filled or poured into without moving. Vantage points stand 1.0-1.3 m from their surface.
REACH_M = 1.6


class ActionVerbs:
    """The practical verbs of a truth-backed adapter (module docstring); a part of
    :class:`~fg_tea.env.adapter.TruthBackedAdapter`."""

    # The adapter's state these verbs use (TruthBackedAdapter.__init__ and reset set it).
    scenario: Scenario
    config: EnvConfig
    _rng: np.random.Generator
    _truth: TeaTruth
    _pose: Pose
    _start: Pose | None
    _positions: dict[str, tuple[float, float, float]]

    if TYPE_CHECKING:  # the adapter's motion, geometry and lookups, which the verbs call
        def _require_reset(self) -> None: ...

        def _spec(self, name: str) -> ObjectSpec: ...

        def _site_index(self, site: str) -> int: ...

        def _go_to_site(self, k: int) -> tuple[list[Pose], bool]: ...

        def _face(self, target: Sequence[float]) -> list[Pose]: ...

        def _travelled(self, frames: Sequence[Pose]) -> float: ...

        def _carry(self) -> None: ...

        def _put(self, obj: str, position: tuple[float, float, float]) -> None: ...

        def _occupants(self, site: str) -> list[str]: ...

        def _free_slot(self, site: str) -> tuple[float, float, float]: ...

        def _sync(self) -> None: ...

        def placements(self) -> Mapping[str, tuple[float, float, float]]: ...

    def execute(self, request: ActionRequest) -> ActionResult:
        self._require_reset()
        self._start = self._pose
        verb = request.verb.upper()
        handler = {"NAVIGATE": self._navigate, "PICK": self._pick, "PLACE": self._place,
                   "INSERT": self._insert, "FILL": self._effect_action, "USE": self._effect_action,
                   "POUR": self._pour, "WAIT": self._wait}.get(verb)
        if handler is None:
            raise ValueError(f"verb {request.verb!r} is not an executable action here "
                             "(SEARCH and INSPECT go through inspect_viewpoint and observe_state)")
        self._spec(request.object)
        if request.site is not None:
            self._site_index(request.site)
        if request.destination is not None:
            self._spec(request.destination)
        effect = request.effect if request.effect is not None else DEFAULT_EFFECT.get(verb)
        if effect is not None and effect not in EFFECTS:
            raise ValueError(f"unknown truth effect {effect!r} (known: {', '.join(EFFECTS)})")
        rate = float(self.config.failure_rates.get(verb, 0.0))
        if rate > 0.0 and float(self._rng.random()) < rate:
            return self._result(False, "injected_failure", [])
        return handler(request, effect)

    # --- verbs -----------------------------------------------------------------------------

    def _navigate(self, request: ActionRequest, effect: str | None) -> ActionResult:
        frames, arrived = self._go_to_site(self._needs_site(request))
        if not arrived:
            return self._result(False, "unreachable", frames)
        return self._finish(effect, request, frames)

    def _pick(self, request: ActionRequest, effect: str | None) -> ActionResult:
        k = self._needs_site(request)
        site = self.scenario.sites[k]
        if "graspable" not in self._spec(request.object).affordances:
            return self._result(False, "not_graspable", [])
        if self._truth.held is not None:
            return self._result(False, "hands_full", [])
        frames, arrived = self._go_to_site(k)
        if not arrived:
            return self._result(False, "unreachable", frames)
        frames += self._face(site.position)
        if self._truth.site_of.get(request.object) != site.name:
            return self._result(False, "object_not_at_site", frames)
        if (empty := self._take_use(request, frames)) is not None:
            return empty
        self._truth.pick(request.object)
        self._carry()
        return self._finish(effect, request, frames)

    def _place(self, request: ActionRequest, effect: str | None) -> ActionResult:
        k = self._needs_site(request)
        site = self.scenario.sites[k]
        if self._truth.held != request.object:
            return self._result(False, "not_held", [])
        frames, arrived = self._go_to_site(k)
        if not arrived:
            return self._result(False, "unreachable", frames)
        frames += self._face(site.position)
        occupants = self._occupants(site.name)
        if site.capacity is not None and len(occupants) >= site.capacity:
            return self._result(False, "site_full", frames)
        if (empty := self._take_use(request, frames)) is not None:
            return empty
        position = self._free_slot(site.name)
        self._truth.place(request.object, site.name)
        self._put(request.object, position)
        return self._finish(effect, request, frames)

    def _to_container(self, request: ActionRequest, verb: str) -> tuple[str, list[Pose], ActionResult | None]:
        """INSERT and POUR: the held object taken to its container destination; a failure result,
        or None when the action may go ahead."""
        dest = request.destination
        if dest is None:
            raise ValueError(f"{verb} needs a destination object")
        if self._truth.held != request.object:
            return dest, [], self._result(False, "not_held", [])
        if "container" not in self._spec(dest).affordances:
            return dest, [], self._result(False, "not_a_container", [])
        frames, ok, reason = self._approach(request.site, dest, "destination")
        return dest, frames, (None if ok else self._result(False, reason, frames))

    def _insert(self, request: ActionRequest, effect: str | None) -> ActionResult:
        dest, frames, failed = self._to_container(request, "INSERT")
        if failed is None:
            failed = self._take_use(request, frames)
        if failed is not None:
            return failed
        self._truth.insert(request.object, dest)
        self._put(dest, self._positions[dest])
        self._carry()
        return self._finish(effect, request, frames)

    def _pour(self, request: ActionRequest, effect: str | None) -> ActionResult:
        _, frames, failed = self._to_container(request, "POUR")
        if failed is None:
            failed = self._take_use(request, frames)
        return failed if failed is not None else self._finish(effect, request, frames)

    def _effect_action(self, request: ActionRequest, effect: str | None) -> ActionResult:
        frames, ok, reason = self._approach(request.site, request.object, "object")
        if not ok:
            return self._result(False, reason, frames)
        return self._take_use(request, frames) or self._finish(effect, request, frames)

    def _wait(self, request: ActionRequest, effect: str | None) -> ActionResult:
        return self._take_use(request, []) or self._finish(effect, request, [])

    # --- helpers ---------------------------------------------------------------------------

    def _approach(self, site: str | None, obj: str, role: str) -> tuple[list[Pose], bool, str]:
        """Go to `site` if given, then check `obj` is held, at that site, or within reach."""
        frames: list[Pose] = []
        if self._truth.held == obj:
            return frames, True, ""
        if site is not None:
            k = self._site_index(site)
            frames, arrived = self._go_to_site(k)
            if not arrived:
                return frames, False, "unreachable"
            frames += self._face(self.scenario.sites[k].position)
            if self._truth.site_of.get(obj) != site:
                return frames, False, f"{role}_not_at_site"
            return frames, True, ""
        x, y, _ = self._positions[obj]
        if math.hypot(x - self._pose.x, y - self._pose.y) > REACH_M:
            return frames, False, f"{role}_out_of_reach"
        return frames, True, ""

    def _take_use(self, request: ActionRequest, frames: list[Pose]) -> ActionResult | None:
        """Take a use of the request's object if it is a consumable of this verb (the action is
        about to succeed); the ``used_up`` failure when none is left, else None."""
        if self._truth.take_use(request.object, request.verb.upper()):
            return None
        return self._result(False, USED_UP, frames)

    def _finish(self, effect: str | None, request: ActionRequest, frames: list[Pose]) -> ActionResult:
        if effect is not None and effect_happens(self.config.effect_success, effect, self._rng):
            self._truth.apply_effect(effect, request.object, request.destination, self._rng)
        return self._result(True, "", frames)

    def _result(self, ok: bool, reason: str, frames: list[Pose]) -> ActionResult:
        self._sync()
        return ActionResult(ok, reason, distance=self._travelled(frames), frames=len(frames),
                            motion=motion_of(frames), placements=self.placements())

    def _needs_site(self, request: ActionRequest) -> int:
        if request.site is None:
            raise ValueError(f"{request.verb} needs a site")
        return self._site_index(request.site)
