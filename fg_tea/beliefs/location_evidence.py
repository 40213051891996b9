"""Evidence about where objects are: looks at a site or from a viewpoint, detections and misses,
and the hypothetical looks a planner scores (docs/design.md §3.2-§3.5, §4.3, eqs. 5-6, 28-34).

:class:`LocationEvidence` is the location-evidence part of :class:`~fg_tea.beliefs.engine.
BeliefEngine`, which is built from it: it reads and writes the engine's location factors and
caches, declared below, and commits evidence through the engine's trial rollback, so a look that
contradicts the belief leaves it as it was.
"""

from __future__ import annotations

import math
from contextlib import AbstractContextManager
from typing import TYPE_CHECKING, Any, Iterable, Mapping, Sequence

import numpy as np

from fg_tea.beliefs.factors import (
    Evidence,
    Factor,
    as_evidence,
    collapse_factor,
    collapse_target,
    detection_factor,
    location_var,
    log_ratio_gap,
    merge_evidence,
    miss_factor,
    view_miss_factor,
)
from fg_tea.beliefs.occlusion import CompanyEvidence, alone_miss
from fg_tea.beliefs.updates import LookUpdate
from fg_tea.common.errors import ContradictionError
from fg_tea.model.spec import Model

if TYPE_CHECKING:
    from fg_tea.beliefs.graph import BeliefGraph

#: Several objects seen in one look (eq. 4 for each, docs/design.md §3.2): the collapses are
#: repeated in sweeps (iterative proportional fitting) until every seen object's marginal is its
#: eq. 4 target to this relative tolerance (:func:`log_ratio_gap`), or a sweep no longer shrinks
#: the gap. The fixed point, the joint closest in KL with all those marginals, is order-free.
JOINT_COLLAPSE_TOLERANCE = 1e-13
#: Sweeps allowed before the fit stops; IPF converges geometrically, and the bundled houses need
#: fewer than 20 (one sweep when the objects are independent).
JOINT_COLLAPSE_SWEEPS = 500


class LocationEvidence:
    """Looks and their hypotheticals (module docstring); a part of the belief engine."""

    # The engine's state these updates use (BeliefEngine.__init__ sets it).
    model: Model
    graph: BeliefGraph
    backend: str
    sites: tuple[str, ...]
    objects: tuple[str, ...]
    _site_index: dict[str, int]
    _obj_index: dict[str, int]
    _loc_factors: list[Factor]
    _unary: np.ndarray
    _correlated: bool
    _company: CompanyEvidence | None
    _cache: dict[str, Any]
    _coupling: Any
    _prior_tables: dict[int, np.ndarray]

    if TYPE_CHECKING:  # the engine's own queries and bookkeeping, which these updates call
        def _trial(self) -> AbstractContextManager[None]: ...

        def copy(self) -> LocationEvidence: ...

        def location(self, obj: str) -> np.ndarray: ...

        def locations(self) -> dict[str, np.ndarray]: ...

        def _location_factors(self) -> list[Factor]: ...

        def _location_marginals(self) -> np.ndarray: ...

        def _gtsam_marginals(self, factors: Sequence[Factor]) -> np.ndarray: ...

        def _pairwise(self) -> np.ndarray: ...

    # ------------------------------------------------------------------ location evidence
    def _commit_location(self, factors: Iterable[Factor]) -> None:
        """Multiply unary location evidence into the graph, in log space.

        Every object holds at most one :class:`~fg_tea.beliefs.factors.Evidence` factor: each new
        miss, detection or collapse is merged into it as a sum of logs, so the graph does not
        grow with the number of inspections and a thousand misses at one site stay exact (their
        product, mu^1000, is far below the smallest float). ``_unary[o]`` is the normalised
        prior x evidence, computed from the logs.
        """
        for f in factors:
            var = f.variables[0]
            o = self._obj_index[var[2:-1]]
            pos = next((i for i, g in enumerate(self._loc_factors)
                        if isinstance(g, Evidence) and g.variables == (var,)), None)
            merged = merge_evidence(None if pos is None else as_evidence(self._loc_factors[pos]), f)
            log_row = self._log_prior(o) + merged.log_table
            top = float(np.max(log_row))
            if not np.isfinite(top):
                raise ContradictionError(f"evidence {f.label} has probability zero under the model")
            row = np.exp(log_row - top)
            self._unary[o] = row / row.sum()
            if pos is None:
                self._loc_factors.append(merged)
            else:
                self._loc_factors[pos] = merged
            for key in ("structured", "compiled"):  # what the evidence left unchanged is reused from it
                previous = self._cache.pop(key, None)
                if previous is not None:
                    self._cache[key + "_previous"] = previous
            for key in ("locations", "joint", "pairwise", "eliminated"):
                self._cache.pop(key, None)
            if self._coupling is not None:  # the coupled states' message changes with o's marginal
                self._cache.pop("states", None)

    def _log_prior(self, o: int) -> np.ndarray:
        """log q0(L_o) (eq. 2), normalised; -inf where the prior is zero."""
        table = self._prior_tables.get(o, self.graph.location_priors[o].table)  # a coupling's, if any
        with np.errstate(divide="ignore"):
            return np.log(table / table.sum())

    def _location_evidence(self, obj: str) -> Evidence | None:
        var = location_var(obj)
        return next((g for g in self._loc_factors
                     if isinstance(g, Evidence) and g.variables == (var,)), None)

    def unseen_probability(self, obj: str, excluded: Iterable[str] = ()) -> tuple[float | None, int]:
        """How much chance is left of finding `obj` by looking, and how many looks missed it.

        R_o = sum over sites j not in `excluded` of q0(L_o = j) x P(every look so far missed o |
        L_o = j): the probability, under o's prior (eq. 2) and the detection model (eqs. 5-6),
        that o stands at a reachable site and is still unseen (the search give-up rule of
        :class:`fg_tea.model.spec.PlanningWeights`). Computed from the merged log evidence, so it is
        exact however many looks there were.

        Returns:
            (R_o, looks): R_o is None once o has been seen (a detection or collapse is not a
            likelihood over where o stood, so the rule no longer applies); looks counts the
            misses absorbed for o (failed picks at a believed site included).
        """
        o = self._obj_index[obj]
        ev = self._location_evidence(obj)
        if ev is None:
            log_l, looks, seen = np.zeros(len(self.sites)), 0, False
        else:
            log_l = np.asarray(ev.log_table, dtype=float)
            seen = ev.kind_count("collapse") + ev.kind_count("detect") > 0
            looks = ev.count - ev.kind_count("collapse") - ev.kind_count("detect")
        if self._company is not None:  # coupled misses count with their p̄ (eq. 60)
            log_l = log_l + self._company.log_miss[o]
        if seen:
            return None, looks
        skip = {self._site_index[s] for s in excluded if s in self._site_index}
        keep = [j for j in range(len(self.sites)) if j not in skip]
        if not keep:
            return 0.0, looks
        terms = self._log_prior(o)[keep] + log_l[keep]
        top = float(np.max(terms))
        if not np.isfinite(top):
            return 0.0, looks
        return float(np.exp(top) * np.exp(terms - top).sum()), looks

    def _log_location(self, obj: str) -> np.ndarray:
        """log q(L_o), exact even where q underflows (log prior + log evidence + log message).

        Without relational factors q(L_o) is the normalised prior x evidence. With them,
        q(L_o = a) is proportional to that times c(a), the marginal L_o would have with a uniform
        prior and no evidence of its own (the message of the relational factors); c is bounded
        away from zero because relational factors are positive, so only the unary part needs logs.
        """
        o = self._obj_index[obj]
        ev = self._location_evidence(obj)
        log_u = self._log_prior(o) + (0.0 if ev is None else ev.log_table)
        if self._correlated:
            var, k = location_var(obj), len(self.sites)
            other = self.copy()
            other._unary[o] = np.full(k, 1.0 / k)
            other._loc_factors = [g for g in self._loc_factors if g.variables != (var,)]
            other._loc_factors.append(Factor((var,), np.full(k, 1.0 / k), f"uniform {var}"))
            other._cache = {}
            with np.errstate(divide="ignore"):
                log_u = log_u + np.log(other.location(obj))
        top = float(np.max(log_u))
        return log_u - (top + float(np.log(np.exp(log_u - top).sum())))

    def _detection_factor(self, obj: str, j: int, miss: float | None = None) -> Factor:
        """The factor of "obj seen at site j": eq. 4's collapse, or the detection likelihood
        (miss likelihood `miss`, default the model's mu)."""
        if self.model.positive_update == "collapse":
            current = self.location(obj)
            # Any entry below the smallest normal float (q at j after many misses there, or q
            # elsewhere after many misses elsewhere) is taken from the exact log belief, so the
            # ratio t / q keeps eq. 4's floor at every site.
            exact = None if current.min() >= np.finfo(float).tiny else self._log_location(obj)
            try:
                return collapse_factor(obj, j, current, self.model.prior_floor, log_current=exact)
            except ContradictionError:
                raise ContradictionError(f"the model rules out what the agent saw: the {obj} at "
                                         f"{self.sites[j]}, where the model gives it probability zero "
                                         "(evidence cannot overturn a factor's zero; give it a small "
                                         "positive weight)") from None
        return detection_factor(obj, j, len(self.sites),
                                self.model.miss_likelihood if miss is None else miss,
                                self.model.false_positive_rate)

    def _apply_detections(self, seen: Sequence[tuple[str, int, float | None]]) -> int:
        """Absorb the detections of one look: (object, site index, miss likelihood or None).

        With the likelihood update (eq. 31) the factors are multiplied in, which commutes. With
        eq. 4's collapse, one object's collapse moves the others it is correlated with (joint
        models), so the collapses are repeated in sweeps until every seen object's marginal is
        its eq. 4 target (:data:`JOINT_COLLAPSE_TOLERANCE`): iterative proportional fitting,
        whose fixed point, the joint closest in KL to the belief before the look among those with
        every target marginal, is independent of the order of the objects (docs/design.md §3.2).

        Returns:
            The number of sweeps (1 when nothing is correlated).
        """
        if not seen:
            return 0
        if self.model.positive_update != "collapse" or len(seen) == 1:
            for o, j, miss in seen:
                self._commit_location([self._detection_factor(o, j, miss)])
            return 1
        previous = math.inf
        for sweep in range(1, JOINT_COLLAPSE_SWEEPS + 1):
            reached = {}
            for o, j, miss in seen:
                self._commit_location([self._detection_factor(o, j, miss)])
                reached[o] = self.location(o)
            gap = max(log_ratio_gap(self.location(o), q) for o, q in reached.items())
            if gap <= JOINT_COLLAPSE_TOLERANCE or (gap < 1e-10 and gap >= previous):
                break
            previous = gap
        return sweep

    def observe_site(self, site: str, detections: Mapping[str, bool]) -> LookUpdate:
        """Absorb one inspection of `site`: True = seen there, False = looked and not seen.

        An object absent from `detections` is "no observation" and its evidence is unchanged.
        Misses [5, 6] are applied first (they commute); then detections [4], together
        (:meth:`_apply_detections`: each seen object ends at eq. 4's value, in any object order).

        Raises:
            ContradictionError: the evidence has probability zero; the belief is left unchanged.
        """
        if site not in self._site_index:
            raise KeyError(f"no site named {site!r}")
        for obj in detections:
            if obj not in self._obj_index:
                raise KeyError(f"no object named {obj!r}")
        j, k = self._site_index[site], len(self.sites)
        before = self.locations()
        with self._trial():
            misses = [miss_factor(o, j, k, self.model.miss_likelihood)
                      for o in self.objects if detections.get(o) is False]
            self._commit_location(misses)
            self._apply_detections([(o, j, None) for o in self.objects
                                    if detections.get(o) is True])
            after = self.locations()
        detected = tuple(o for o in self.objects if detections.get(o) is True)
        return LookUpdate(site, dict(detections), before, after, detected, tuple(self.sites))

    def observe_viewpoint(self, view, found: Mapping[str, str | None]) -> LookUpdate:
        """Absorb one look from a viewpoint (docs/design.md eq. 30 over every site in view).

        Args:
            view: the :class:`~fg_tea.beliefs.detection.View` looked from (its sites in view and
                p_{o,j}).
            found: object -> the in-view site it was seen at, or None for "looked, not seen
                anywhere in view". Objects absent are "no observation".

        Misses multiply L_o by l(a) = 1 - p_{o,a} on the sites in view (they commute); then
        detections apply eq. 4 at the site seen (or, with ``positive_update = "likelihood"``,
        l(a) = p_{o,j} at that site and the false-positive rate elsewhere), together and in any
        object order (:meth:`_apply_detections`).

        Raises:
            ContradictionError: the evidence has probability zero; the belief is left unchanged.
        """
        k = len(self.sites)
        if getattr(view, "objects", ()) and tuple(view.objects) != self.objects:
            raise ValueError(f"view {view.name!r} has rows for {view.objects}, not {self.objects}")
        in_view = {self.sites[j] for j in view.sites}
        for obj, site in found.items():
            if obj not in self._obj_index:
                raise KeyError(f"no object named {obj!r}")
            if site is not None and site not in in_view:
                raise KeyError(f"site {site!r} is not in view of {view.name!r}")
        label = str(view.sites[0]) if view.kind == "site" else view.name
        before = self.locations()
        coupled = getattr(view, "conditional", None) is not None and self._correlated
        with self._trial():
            if coupled:  # eq. 59 kept exactly: site-local factors over who stands there
                company = self._company or CompanyEvidence.empty(len(self.objects), k)
                self._company = company.absorb(view.conditional, view.sites, {
                    self._obj_index[o]: None if s is None else self._site_index[s]
                    for o, s in found.items()}, view.probability)
                for key in ("locations", "joint", "pairwise", "structured", "eliminated", "compiled"):
                    self._cache.pop(key, None)
            miss = alone_miss(view.conditional) if coupled else view.miss
            self._commit_location([view_miss_factor(o, view.sites, miss[self._obj_index[o]], k, label)
                                   for o in self.objects if o in found and found[o] is None])
            seen = []
            for o in self.objects:
                site = found.get(o)
                if site is not None:
                    j = self._site_index[site]
                    seen.append((o, j, 0.0 if coupled else
                                 float(view.miss[self._obj_index[o], view.sites.index(j)])))
            self._apply_detections(seen)
            after = self.locations()
        detected = tuple(o for o in self.objects if found.get(o) is not None)
        return LookUpdate(view.name, {o: found[o] is not None for o in found}, before, after,
                          detected, tuple(self.sites))

    def observe_view(self, view, found: Mapping[str, str | None]) -> LookUpdate:
        """Deprecated name of :meth:`observe_viewpoint` (a viewpoint is called a viewpoint)."""
        import warnings

        warnings.warn("BeliefEngine.observe_view is deprecated; use observe_viewpoint",
                      DeprecationWarning, stacklevel=2)
        return self.observe_viewpoint(view, found)

    # ------------------------------------------------------------------ hypothetical evidence
    def hypothetical(self, site: str, detections: Mapping[str, bool]) -> dict[str, np.ndarray]:
        """Location marginals *if* `site` were inspected with this outcome; the belief is untouched."""
        return dict(self.copy().observe_site(site, detections).after)

    def hypothetical_all(self) -> tuple[np.ndarray, np.ndarray]:
        """Every single-object hypothesis at every site, without touching the belief.

        Returns:
            (miss, seen): arrays of shape (N, K, N, K). ``miss[o, j, p]`` is q(L_p) after "o not
            seen at site j" [5, 6]; ``seen[o, j, p]`` is q(L_p) after "o seen at site j" [4].
            A hypothesis with probability zero under the belief leaves the marginals as they are.

        The numpy backend answers all 2·N·K hypotheses in one vectorised step: an observation
        touches one variable, so P(L_p | obs on o) = sum_a P(L_p, L_o = a) l(a) / sum_a P(L_o = a)
        l(a), from the pairwise marginals. The gtsam backend re-solves the graph per hypothesis
        (the reference the fast path is tested against).
        """
        if self.backend == "gtsam":
            return self._hypothetical_all_resolved()
        m = self._location_marginals()
        pw = self._pairwise()
        n, k = m.shape
        mu = self.model.miss_likelihood
        # Miss at j: l(a) = 1 - (1 - mu)[a = j]; P(L_p = b, miss) >= mu q(L_p = b), so the
        # subtraction below loses at most a factor 1/mu of relative precision.
        z_miss = 1.0 - (1.0 - mu) * m                                      # (o, j)
        num = m[None, None, :, :] - (1.0 - mu) * np.transpose(pw, (0, 2, 1, 3))
        miss = np.maximum(num, 0.0) / z_miss[:, :, None, None]
        if self.model.positive_update == "collapse":
            # Jeffrey's rule: q'(L_p) = sum_a t_j(a) P(L_p | L_o = a), t_j restricted to the
            # support of q(L_o) (eq. 4 where the belief allows it).
            floor = self.model.prior_floor
            targets = np.stack([collapse_target(j, k, floor) for j in range(k)])   # (j, a)
            support = m > 0                                                         # (o, a)
            t = targets[None, :, :] * support[:, None, :]                           # (o, j, a)
            t_norm = t.sum(axis=2, keepdims=True)
            t = np.divide(t, t_norm, out=np.zeros_like(t), where=t_norm > 0)
            safe = np.where(support, m, 1.0)
            cond = np.where(support[:, None, :, None], pw / safe[:, None, :, None], 0.0)
            seen = np.einsum("oja,opab->ojpb", t, cond)
            possible = support                                                      # (o, j)
        else:
            lik = np.full((k, k), self.model.false_positive_rate)
            np.fill_diagonal(lik, 1.0 - mu)                                         # (j, a)
            num = np.einsum("ja,opab->ojpb", lik, pw)
            den = np.einsum("ja,oa->oj", lik, m)
            possible = den > 0
            seen = num / np.where(possible, den, 1.0)[:, :, None, None]
        seen = np.where(possible[:, :, None, None], seen, m[None, None, :, :])
        return miss, seen

    def _hypothetical_all_resolved(self) -> tuple[np.ndarray, np.ndarray]:
        """hypothetical_all by re-running the backend's inference once per hypothesis."""
        n, k = len(self.objects), len(self.sites)
        base = self._location_marginals()
        miss = np.empty((n, k, n, k))
        seen = np.empty((n, k, n, k))
        factors = self._location_factors()
        for o, obj in enumerate(self.objects):
            for j in range(k):
                for out, make in ((miss, lambda: miss_factor(obj, j, k, self.model.miss_likelihood)),
                                  (seen, lambda: self._detection_factor(obj, j))):
                    try:
                        out[o, j] = self._gtsam_marginals(factors + [make()])
                    except ContradictionError:
                        out[o, j] = base
        return miss, seen


__all__ = ["LocationEvidence"]
