"""A fake house: the environment contract without a simulator, for fast tests of the agent side.

This module answers *how do the task and episode layers behave, given a world that obeys the
adapter contract*, without PyBullet. It shares all verb semantics, hidden truth, failure reasons
and fault injection with the PyBullet house (:class:`~fg_tea.env.adapter.TruthBackedAdapter`) and
replaces geometry and perception by the simplest stand-ins:

* distance d_j (eq. 12): Euclidean, from the agent to the site's vantage point;
* motion: a straight line to the vantage point, followed frame by frame with the same follower
  (at most ``movement_step`` per frame, turning at most ``turn_step_deg``);
* perception [28, 29]: n_o = 100 pixels if object o truly stands at the inspected site and the
  agent looks from the site's own vantage, fewer with the square of the distance from farther away
  (a room glance), 0 if o stands elsewhere; no occlusion, no field of view, and the same count at
  every placement slot of a site (so its expected counts, one per slot, are all equal).
"""

from __future__ import annotations

import math
from typing import Sequence

from fg_tea.env.adapter import TruthBackedAdapter
from fg_tea.env.motion import follow_path
from fg_tea.world.interface import Pose

#: Pixel count reported for an object that truly stands at the inspected site.
FAKE_PIXELS = 100


class FakeHouse(TruthBackedAdapter):
    """A truth-backed adapter with straight-line motion and oracle perception (no simulator).

    Args:
        scenario: the house, sites and objects.
        config: embodiment parameters (docs/design.md §8.6); ``distance`` is always Euclidean here.
    """

    def _build(self) -> None:
        """Nothing to build: the fake world is the truth plus object positions."""

    def _route(self, k: int) -> list[Pose] | None:
        x, y = self._viewpoints[k].position
        target = (float(x), float(y))
        return follow_path(self._pose, [target], self.config)

    def _distance_from(self, k: int, xy: Sequence[float]) -> float:
        vx, vy = self._viewpoints[k].position
        return math.hypot(vx - xy[0], vy - xy[1])

    def _pixel_counts(self, k: int, objects: Sequence[str]) -> dict[str, int]:
        site = self.scenario.sites[k]
        n = fake_pixels(site.vantage, site.position, (self._pose.x, self._pose.y))
        return {name: n if self._truth.site_of.get(name) == site.name else 0 for name in objects}

    def _expected_pixels(self, target: int, site: int, categories: Sequence[str]) -> dict[str, list[float]]:
        """The fake camera's count, the same at every slot: it has no slots, only sites."""
        s = self.scenario.sites[site]
        n = fake_pixels(s.vantage, s.position, self._viewpoints[target].position)
        return {c: [float(n)] * self.slot_count(s.name) for c in categories}


def fake_pixels(vantage: Sequence[float], surface: Sequence[float], eye: Sequence[float]) -> int:
    """The fake camera: FAKE_PIXELS from the site's own vantage point, falling with the square of
    the distance to the surface from anywhere farther away (a room glance)."""
    close = math.hypot(surface[0] - vantage[0], surface[1] - vantage[1])
    far = math.hypot(surface[0] - eye[0], surface[1] - eye[1])
    if far <= close + 1e-9:
        return FAKE_PIXELS
    return int(round(FAKE_PIXELS * (close / far) ** 2))
