"""The agent's observation model of a look: which sites a viewpoint sees, and how well.

This module answers, for the agent, *what can one look show?* (docs/design.md, "Viewpoints" and
"Detection from visibility"). A viewpoint is a site's close vantage or a room glance; one look
from it covers its sites in view, and for every object o and in-view site j the model expects

    p_{o,j} = P(o seen | o stands at j, look from v)

— the probability the detector reports o if o is there. It enters the miss factor
l(a) = 1 - p_{o,a} for a in view (1 elsewhere) and the planner's score. Where p comes from:

- ``detector = "threshold"`` (eq. 29; the pre-viewpoint model): a close look shows every object
  on its site, p = 1 - mu (mu the miss likelihood of eqs. 5-6). A room glance shows an object
  with p = 1 - mu times the fraction of j's placement slots at which its expected pixel count
  reaches ``min_visible_pixels``.
- ``detector = "visibility"`` (eq. 30): p = the mean, over j's placement slots s, of the agent's
  assumed visibility curve evaluated at the pixel count n^(c, j, s, v) that an object of o's
  category c would cover standing alone at slot s of j, seen from v (docs/design.md §3.4,
  eq. (33)). Those counts are computed by the environment from the house geometry and the object
  models alone, never from where objects truly are, and handed over once per house.

Each kind's p is computed by its class in :mod:`fg_tea.world.detectors` (a new kind registers
there: docs/how-to/add-a-detector.md).

Why a mean over slots, of probabilities: an object put on a site takes the site's first free
slot, so which slot it stands at depends on how many objects share the site and in what order
they came, which the agent does not know. It takes each of the site's S slots (S = min(number of
objects, capacity), slot positions being house geometry) as equally likely; P(seen | o at j) is
then the average of P(seen | o at slot s) over s. Averaging pixel counts first and applying the
curve once would not be that expectation, because the curve is not linear in n. A table with one
number per (viewpoint, site, category) instead of a list is read as a single slot.

Nothing here imports a simulator: the expected pixel counts arrive as numbers.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Mapping, Sequence

import numpy as np

from fg_tea.beliefs.occlusion import CompanyModel, CompanyTable, fixed_companions, together_from
from fg_tea.model.spec import Model
from fg_tea.world.interface import logged_viewpoint
from fg_tea.world.scenario import Scenario

#: Expected pixels: viewpoint -> site -> object category -> pixels at each placement slot of the
#: site (a sequence, slot 0 first; a single number counts as one slot).
PixelTable = Mapping[str, Mapping[str, Mapping[str, "float | Sequence[float]"]]]


def slot_pixels(value: "float | Sequence[float]") -> np.ndarray:
    """The per-slot expected pixel counts of one table entry as a 1-D array (at least one slot)."""
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"expected pixel counts must be a number or a non-empty list, got {value!r}")
    return arr


@dataclass(frozen=True)
class View:
    """One viewpoint as the agent models it.

    Attributes:
        name: the viewpoint's name (a site's name for its close look).
        kind: ``"site"`` (close look) or ``"room"`` (room glance).
        room: the room the viewpoint looks into.
        sites: belief indices of the sites in view.
        probability: shape (N objects in belief order, len(sites)); p_{o,j} in [0, 1].
        miss: the same shape; the miss likelihood 1 - p_{o,j} of eqs. 5-6 (mu itself for the
            threshold detector's close look, so the pre-viewpoint factors are reproduced exactly).
        pixels: the same shape; expected pixel counts averaged over the site's placement slots
            (NaN where none were computed), for reports; p is computed per slot, not from these.
        conditional: under ``occlusion``, p given the other objects on the site (eq. 59).
    """

    name: str
    kind: str
    room: str
    sites: tuple[int, ...]
    probability: np.ndarray
    miss: np.ndarray
    pixels: np.ndarray
    #: (N, len(sites), 2^N) p_o(j, v | companions) under ``occlusion`` (eq. 59), which a joint
    #: belief absorbs exactly; None otherwise (docs/design.md §3.4, "Facing and company").
    conditional: np.ndarray | None = None
    #: the object order of the rows (the view model's); a belief refuses a view of another order
    objects: tuple[str, ...] = ()

    def probability_over_sites(self, n_sites: int) -> np.ndarray:
        """p_{o,a} over all K sites, shape (N, K): zero outside the view."""
        out = np.zeros((self.probability.shape[0], n_sites))
        out[:, list(self.sites)] = self.probability
        return out


def view_from_log(event: Mapping, sites: Sequence[str], objects: Sequence[str], model: Model) -> View:
    """The :class:`View` an ``observation`` event was absorbed with, rebuilt from the log.

    Uses the logged ``sites_in_view`` and ``detection_probability``; logs written before
    viewpoints existed (neither field) are close looks with p = 1 - mu. Where p equals 1 - mu the
    miss likelihood is mu itself, as the threshold detector's close look uses it.
    """
    index = {s: i for i, s in enumerate(sites)}
    in_view = list(event.get("sites_in_view") or [logged_viewpoint(event)])
    logged = event.get("detection_probability") or {}
    mu = model.miss_likelihood
    prob = np.zeros((len(objects), len(in_view)))
    for o, obj in enumerate(objects):
        row = logged.get(obj)
        for c, site in enumerate(in_view):
            prob[o, c] = float(row[site]) if row is not None else 1.0 - mu
    miss = np.where(prob == 1.0 - mu, mu, 1.0 - prob)
    kind = event.get("viewpoint_kind", "site")
    name = logged_viewpoint(event)
    return View(name, kind, "", tuple(index[s] for s in in_view), prob, miss,
                np.full(prob.shape, np.nan))


def found_from_log(event: Mapping) -> dict[str, str | None]:
    """object -> the in-view site it was seen at, or None (looked, not seen), from an event."""
    found_at = event.get("found_at") or {}
    return {o: (found_at.get(o, logged_viewpoint(event)) if seen else None)
            for o, seen in event["detections"].items()}


class ViewModel:
    """Every viewpoint the agent may look from, with its detection probabilities.

    Args:
        scenario: the house (sites, room vantages, object categories; never truth).
        model: the agent's model (detector kind, assumed curve, miss likelihood, glances switch).
        objects: belief object order (default: the scenario's).
        expected_pixels: viewpoint -> site -> category -> expected pixels at each placement slot,
            from the environment's :meth:`~fg_tea.env.base.EnvAdapter.expected_pixel_counts`.
            Needed unless the model uses the threshold detector with close looks only.

    Raises:
        ValueError: expected pixels are needed but missing, or lack a viewpoint, site or category.
    """

    def __init__(self, scenario: Scenario, model: Model, objects: Sequence[str] | None = None,
                 expected_pixels: PixelTable | None = None,
                 company: CompanyTable | None = None) -> None:
        self.model = model
        self.sites = scenario.site_names
        self.objects = tuple(objects) if objects is not None else scenario.object_names
        categories = [scenario.object(o).category for o in self.objects]
        site_index = {s: i for i, s in enumerate(self.sites)}
        mu = model.miss_likelihood
        kind = model.detector_kind  # how this detector's look probabilities are computed
        self.max_probability = kind.max_probability(model)
        needs_pixels = not model.close_looks_only
        if needs_pixels and expected_pixels is None:
            raise ValueError(f"model {model.name!r} needs the expected pixel counts of every "
                             "viewpoint (room glances or the visibility detector)")
        views = []
        for vp in scenario.viewpoints:
            if vp.kind == "room" and not model.room_glances:
                continue
            n_view = len(vp.sites)
            pixels = np.full((len(self.objects), n_view), np.nan)
            prob = np.zeros((len(self.objects), n_view))
            if needs_pixels:
                assert expected_pixels is not None  # checked above
                table = expected_pixels.get(vp.name)
                if table is None:
                    raise ValueError(f"no expected pixel counts for viewpoint {vp.name!r}")
                for c, s in enumerate(vp.sites):
                    for o, cat in enumerate(categories):
                        try:
                            slots = slot_pixels(table[s][cat])
                        except KeyError:
                            raise ValueError(f"no expected pixel count for category {cat!r} at "
                                             f"site {s!r} from viewpoint {vp.name!r}") from None
                        pixels[o, c] = float(slots.mean())
                        # Eq. (33): the mean over slots of P(seen | slot), each slot equally likely.
                        prob[o, c] = kind.slot_probability(model, cat, slots, vp.kind)
            if not needs_pixels:
                prob = np.full((len(self.objects), n_view), 1.0 - mu)
            prob, miss = kind.look_tables(model, vp.kind, prob)
            if model.learning is not None and model.learning.detection_active:
                prob, miss = _learned(model, scenario, vp, categories, prob, miss)
            views.append(View(vp.name, vp.kind, vp.room, tuple(site_index[s] for s in vp.sites),
                              prob, miss, pixels, objects=self.objects))
        self.company: CompanyModel | None = None
        if (model.facing_tolerance or model.occlusion) and model.learning is not None \
                and model.learning.detection_active:
            raise ValueError(f"model {model.name!r}: learned detection probabilities (eq. 51) "
                             "cannot be combined with [perception] facing_tolerance or occlusion")
        if model.facing_tolerance or model.occlusion:
            if company is None:
                raise ValueError(f"model {model.name!r} needs the company pixel counts of every "
                                 "viewpoint ([perception] facing_tolerance or occlusion)")
            curve = model.detection_curve
            assert expected_pixels is not None and curve is not None  # visibility detector
            self.company = CompanyModel(categories, curve, [(v.name, [self.sites[j] for j in v.sites])
                                                            for v in views],
                                        company, expected_pixels, model.occlusion)
            tables = self.company.tables
            views = [replace(v, probability=tables[v.name][:, :, 0].copy(),
                             miss=1.0 - tables[v.name][:, :, 0],
                             conditional=tables[v.name] if model.occlusion else None)
                     for v in views]
        self.views: tuple[View, ...] = tuple(views)
        self._by_name = {v.name: v for v in self.views}

    @property
    def belief_dependent(self) -> bool:
        """True when each look's probabilities depend on the belief (``occlusion``)."""
        return self.company is not None and self.company.occlusion

    def reweigh(self, marginals: np.ndarray, pairwise: np.ndarray | None = None,
                placed: Mapping[int, int | None] | None = None) -> None:
        """Set every view's probabilities to their mean under a belief over who shares each site
        (docs/design.md §3.4, "Facing and company"); nothing changes without ``occlusion``.

        Args:
            marginals: (N, K) location marginals in this view model's object order.
            pairwise: (N, N, K, K) pairwise marginals of a joint belief; None for a factorised one.
            placed: objects the agent has moved (object index -> the site index it put it on, or
                None while held or inside another): their company is where they are now, not
                where the belief's start locations say (:func:`~fg_tea.beliefs.occlusion.fixed_companions`).
        """
        if not self.belief_dependent:
            return
        assert self.company is not None
        placed = dict(placed or {})
        together = together_from(np.asarray(marginals, dtype=float), pairwise)
        for o2, j in placed.items():
            together[:, o2, :] = 0.0
            if j is not None:
                together[:, o2, j] = 1.0
        views = []
        for v in self.views:
            table = self.company.tables[v.name]
            if placed:
                table = fixed_companions(table, v.sites, placed)
            prob = np.clip(self.company.expected(v.name, v.sites, together, table), 0.0, 1.0)
            views.append(replace(v, probability=prob, miss=1.0 - prob, conditional=table))
        self.views = tuple(views)
        self._by_name = {v.name: v for v in self.views}

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(v.name for v in self.views)

    def view(self, name: str) -> View:
        try:
            return self._by_name[name]
        except KeyError:
            raise KeyError(f"no viewpoint {name!r} in this model's views "
                           f"(room glances {'on' if self.model.room_glances else 'off'})") from None

    def probabilities(self, name: str) -> dict[str, dict[str, float]]:
        """p_{o,j} of one viewpoint as object -> in-view site -> probability (for the log)."""
        v = self.view(name)
        return {o: {self.sites[j]: float(v.probability[i, c]) for c, j in enumerate(v.sites)}
                for i, o in enumerate(self.objects)}


def _learned(model: Model, scenario: Scenario, vp, categories: Sequence[str], prob: np.ndarray,
             miss: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 51 on one viewpoint's p_{o,j}: each (category, look band) cell with counts moves its
    probabilities to the Beta posterior mean; cells without counts are left exactly as they are."""
    import math

    from fg_tea.model.learning import band_of, learned_detection

    prob, miss = prob.copy(), miss.copy()
    for c, s in enumerate(vp.sites):
        site = scenario.site(s)
        distance = math.hypot(vp.position[0] - site.position[0], vp.position[1] - site.position[1])
        band = band_of(vp.kind, distance)
        for o, cat in enumerate(categories):
            new = float(learned_detection(model.learning, cat, band, np.array([prob[o, c]]))[0])
            if new != prob[o, c]:
                prob[o, c], miss[o, c] = new, 1.0 - new
    return prob, miss


__all__ = ["View", "ViewModel", "PixelTable", "slot_pixels", "view_from_log", "found_from_log"]
