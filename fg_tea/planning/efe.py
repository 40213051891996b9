"""EFE-style search: score every (object, site) inspection and take the argmin (eqs. 8-17).

For each unresolved object o and each site j the score, lower is better, is (eqs. 12, 16)

    G(o, j) = w_d d_j - w_p q(L_o = j) - w_e I(o, j) + w_a n_j - lambda r_o

and the decision is (o*, j*) = argmin G (eq. 17); exact ties go to the earlier object in the
caller's order, then the earlier site in belief order. d_j is the travel distance (metres) from
the caller's :class:`~fg_tea.planning.base.DistanceModel`; q is the location marginal; n_j is the
number of earlier inspections of site j with negative evidence in this search; r_o is the task
relevance of eq. 15. Weights come from the model file (:class:`~fg_tea.model.spec.PlanningWeights`).

The repeat term deviates from eq. 12 on purpose. Eq. 12's original indicator [j already inspected]
equals n_j for the first repeat, but a flat penalty lets a zero-travel re-inspection win forever:
once an object has been missed everywhere (a detector miss), the site the agent stands at has
d_j = 0, q ≈ 0 and I ≈ 0, so its score w_a - lambda r_o can beat every site that costs travel, and
the agent looks at the same empty surface again and again (found in the detector-miss sweeps).
Counting repeats makes each further look dearer, so the search moves on.

**Information gain, factorised beliefs** (``belief.correlated`` is False) — docs/design.md
eqs. (10)-(11) exactly:

    E[H_after | pi_oj] = q_j * 0 + (1 - q_j) * H(q^{-j}),   q^{-j}(i) ∝ q(i) * (mu if i = j else 1)
    I(o, j) = H(q) - E[H_after | pi_oj]

with q = q(L_o), q_j = q(L_o = j), q^{-j} the miss posterior of eq. 6 and H the entropy of eq. 7
(nats). This is an approximation even for a factorised belief: it treats "present" as "detected"
(probability q_j rather than (1 - mu) q_j + fp (1 - q_j)), sets the entropy after a detection to 0,
and looks only at o's own detection. It is kept unchanged because it is the original design's
agent (docs/design.md §6.2, §10).

**Information gain, joint beliefs** (``belief.correlated`` is True) — exact. One inspection of
site j produces the joint outcome D_j = (D_u)_{u in U} of every unresolved object u in `objects`
(seen / not seen), with the detection model

    P(D_u = seen | L_u = a) = 1 - mu if a = j else fp        (mu = miss_likelihood, fp = false_positive_rate)

independently across u given the locations. The gain is the mutual information

    I(o, j) = H(L_o) - E_{d ~ P(D_j)} [ H(L_o | D_j = d) ]  =  H(L_o) + H(D_j) - H(L_o, D_j),

computed from the exact joint P(L_U) (``belief.location_joint()`` summed over objects outside U):

    P(L_o = a, D_j = d) = sum_{L_U : L_o = a} P(L_U) prod_{u in U} P(D_u = d_u | L_u).

All K sites and all 2^|U| outcomes are evaluated in one vectorised product of shape
(K, 2, ..., 2, K, ..., K). It differs from eqs. 10-11 in two ways that matter for correlated
beliefs: a detection or a miss of *another* object u at j moves L_o through the relational factors
(co-location, capacity), so an inspection can be informative about o even where o itself is
unlikely; and the outcome probabilities and posteriors are the exact Bayesian ones (the posterior
after a detection keeps whatever entropy the model implies rather than being set to 0). Because
observing more can only add information, the joint I(o, j) is at least the mutual information
between L_o and o's own detection at j.

Every formula below is answered in :mod:`fg_tea.planning.look_gain`: one
:class:`~fg_tea.planning.look_gain.LookGain` per decision picks the route the belief allows (dense
joint, subset program, elimination, one object's closed form, factorised) and answers each look by it.

The original factorised score on a joint belief (eqs. 10-11 applied to the marginals) is
:class:`FactorisedEFEPlanner`, a baseline.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from fg_tea.model.spec import PlanningWeights
from fg_tea.planning.base import (
    Candidate,
    Decision,
    DistanceModel,
    PlannerBase,
    check_inputs,
    distance_vector,
    repeat_counts,
)
from fg_tea.planning.look_gain import (CHUNK_ENTRIES, DENSE_GAIN_LIMIT, INFORMATION_MODES, LookGain,
                                       check_information, coupling_strength, entropies,
                                       factorised_information_gain, information_mode, joint_information_gain,
                                       one_object_information_gain, structured_gain,
                                       view_factorised_information_gain, view_joint_information_gain)

PRUNE_SLACK = 1e-9       # score units: a candidate is skipped only if its lower bound exceeds the
                         # best upper bound by more than this (rounding of the two scores)


class EFEPlanner(PlannerBase):
    """The EFE-style planner of eqs. 12-17.

    Args:
        weights: w_d, w_p, w_e, w_a and lambda from the model file.
        information: ``"auto"`` (exact joint gain when the belief is correlated, eqs. 10-11
            otherwise), ``"factorised"`` (always eqs. 10-11 on the marginals) or ``"joint"``
            (always the exact joint gain, also on factorised beliefs).
        prune: with viewpoints and the structured joint gain, skip the exact gain of every
            candidate that provably cannot be chosen (docs/design.md §6.2, eq. 56); the choice
            is the same, and those candidates log the gain's upper bound, flagged. False
            computes every gain exactly (for callers that rank all candidates).
        rank: with `prune`, keep exact every candidate that could make one of the `rank`
            viewpoints of best score (a viewpoint's score: its best object's), not only the
            argmin, so that those viewpoints and their order are exact (the lookahead's root
            candidates); 1 is the argmin alone.
    """

    name = "efe"

    def __init__(self, weights: PlanningWeights, information: str = "auto",
                 prune: bool = True, rank: int = 1) -> None:
        if information not in INFORMATION_MODES:
            raise ValueError(f"unknown information mode {information!r}; use one of "
                             f"{', '.join(INFORMATION_MODES)}")
        self.weights = weights
        self.information = information
        self.prune = prune
        if rank < 1:
            raise ValueError(f"rank must be at least 1, got {rank}")
        self.rank = rank

    def check(self, belief, objects: Sequence[str]) -> None:
        """Refuse a belief whose exact joint gain has no route: a joint above the dense limit
        without a subset program or the elimination method (docs/design.md §4.6).

        Raises:
            PlannerRefused: kind ``"belief"``, naming the sizes and the way out.
        """
        check_information(belief, objects, information_mode(self.information, belief), self.name)

    def information_gain(self, belief, objects: Sequence[str]) -> tuple[np.ndarray, str]:
        """I(o, j) for the objects (caller's order) and every site, shape (|objects|, K), nats.

        Returns:
            (gain, mode) with mode ``"joint"`` or ``"factorised"``: the formula used.
        """
        mode = information_mode(self.information, belief)
        idx = [belief.objects.index(o) for o in objects]
        return LookGain(belief, idx, mode, views=False).site_gains(), mode

    def choose(self, belief, objects: Sequence[str], relevance: Mapping[str, float],
               distances: DistanceModel, inspected: Mapping[str, int],
               excluded_sites: frozenset[str] = frozenset(), views=None) -> Decision:
        """Score every (object, eligible site) pair by eq. 16 and return the argmin (eq. 17).

        With `views` (a :class:`~fg_tea.beliefs.detection.ViewModel`), candidates are
        (object, viewpoint) pairs scored over what each look sees (:meth:`choose_view`).
        """
        if views is not None:
            return self.choose_view(belief, objects, relevance, distances, inspected,
                                    excluded_sites, views)
        obj_idx, eligible = check_inputs(belief, objects, relevance, excluded_sites)
        w = self.weights
        sites = list(belief.sites)
        q = belief.location_matrix()[obj_idx]  # (n, K)
        gain, mode = self.information_gain(belief, objects)  # (n, K)
        d = distance_vector(distances, sites)  # (K,)
        counts = repeat_counts(inspected, sites)  # (K,)
        r = np.array([float(relevance[o]) for o in objects])  # (n,)
        base = (w.distance_weight * d[None, :] - w.probability_weight * q
                - w.information_weight * gain
                + w.repeat_penalty * counts[None, :].astype(float))  # eq. 12 (repeats counted)
        total = base - w.relevance_weight * r[:, None]  # eq. 16
        candidates = [Candidate(o, sites[j], float(d[j]), float(q[i, j]), float(gain[i, j]),
                                int(counts[j]), float(r[i]), float(base[i, j]), float(total[i, j]))
                      for i, o in enumerate(objects) for j in eligible]
        sub = total[:, eligible]
        i, jj = np.unravel_index(int(np.argmin(sub)), sub.shape)  # first minimum: object, then site
        info: dict[str, float | str] = {"information": mode, "w_d": w.distance_weight, "w_p": w.probability_weight,
                "w_e": w.information_weight, "w_a": w.repeat_penalty, "lambda": w.relevance_weight,
                "distance": str(getattr(distances, "kind", w.distance))}
        return Decision(objects[int(i)], sites[eligible[int(jj)]], float(sub[i, jj]), tuple(candidates),
                        self.name, info)


    def choose_view(self, belief, objects: Sequence[str], relevance: Mapping[str, float],
                    distances: DistanceModel, inspected: Mapping[str, int],
                    excluded: frozenset[str], views) -> Decision:
        """Eq. 16 over viewpoints (docs/design.md, "Planning over viewpoints"):

            G(o, v) = w_d d_v - w_p find(o, v) - w_e I(o, v) + w_a n_v - lambda r_o,

        find(o, v) = sum_{j in view} q(L_o = j) p_{o,j} / p_max; I from
        :func:`view_factorised_information_gain` (factorised mode) or the exact mutual
        information of :func:`view_joint_information_gain` (joint mode: on the dense joint, by
        the structured solver beyond it, and, with one object to find, in closed form from its
        marginal, :func:`one_object_information_gain`, logged ``gain_solver = "one_object"``);
        n_v counts earlier looks from v that left an object unseen.

        With the structured joint gain and ``prune`` (docs/design.md §6.2, eq. 56), a candidate
        whose score with its gain's upper bound is above the smallest score with a lower bound
        cannot be chosen: its exact gain is skipped and it is logged with the upper bound
        (``Candidate.gain_bound``; ``info["bounded_gains"]`` counts them). The argmin is taken
        over the exact scores only, so the choice and its tie-breaking are unchanged.
        """
        obj_idx, _ = check_inputs(belief, objects, relevance, excluded, views)
        w = self.weights
        sites = list(belief.sites)
        k = len(sites)
        eligible = [v for v in views.views if v.name not in excluded]
        if not eligible:
            raise ValueError("planner: every viewpoint is excluded")
        mode = information_mode(self.information, belief)
        q = belief.location_matrix()[obj_idx]
        n, m = len(objects), len(eligible)
        gains = LookGain(belief, obj_idx, mode, views=True)  # one route for every look
        if gains.batched:
            prob_all = np.stack([v.probability_over_sites(k)[obj_idx] for v in eligible])
            find = ((q[None] * prob_all).sum(axis=2) / views.max_probability).T
        else:
            find = np.empty((n, m))
            for c, v in enumerate(eligible):
                find[:, c] = (q * v.probability_over_sites(k)[obj_idx]).sum(axis=1) / views.max_probability
        d = np.array([float(distances.from_agent(v.name)) for v in eligible])
        counts = np.array([int(inspected.get(v.name, 0)) for v in eligible])
        if np.any(counts < 0):
            raise ValueError("planner: inspection counts must be non-negative")
        r = np.array([float(relevance[o]) for o in objects])

        def scores(information: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            base = (w.distance_weight * d[None, :] - w.probability_weight * find
                    - w.information_weight * information
                    + w.repeat_penalty * counts[None, :].astype(float))
            return base, base - w.relevance_weight * r[:, None]

        def need(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
            # Exact pruning (docs/design.md §6.2, eq. 56): a candidate whose score with the
            # gain's upper bound is above the best score with a gain's lower bound cannot be
            # the argmin, nor tie with it; its exact gain is not computed.
            least, most = scores(upper)[1], scores(lower)[1]
            if self.rank == 1:
                return least <= most.min() + PRUNE_SLACK
            # A viewpoint makes the `rank` best only if its least possible score is at
            # most the rank-th smallest of the viewpoints' largest possible scores; of
            # its objects, only those that could be its best need the exact gain.
            view_most = most.min(axis=0)
            kth = np.sort(view_most)[min(self.rank, m) - 1]
            return ((least.min(axis=0) <= kth + PRUNE_SLACK)[None, :]
                    & (least <= view_most[None, :] + PRUNE_SLACK))

        gain, bound = gains.view_gains(eligible, views.max_probability, need if self.prune else None)
        base, total = scores(gain)
        # Python numbers once per array (tolist) rather than once per candidate: the same values.
        dl, fl, gl, cl, rl = d.tolist(), find.tolist(), gain.tolist(), counts.tolist(), r.tolist()
        bl, tl, bd = base.tolist(), total.tolist(), bound.tolist()
        candidates = [Candidate(o, v.name, dl[c], fl[i][c], gl[i][c], int(cl[c]), rl[i], bl[i][c],
                                tl[i][c], v.kind, bd[i][c])
                      for i, o in enumerate(objects) for c, v in enumerate(eligible)]
        exact = np.where(bound, np.inf, total)      # a bounded score is a lower bound, never the min
        i, c = (int(x) for x in np.unravel_index(int(np.argmin(exact)), exact.shape))
        info: dict[str, float | str] = {"information": mode, "w_d": w.distance_weight, "w_p": w.probability_weight,
                "w_e": w.information_weight, "w_a": w.repeat_penalty, "lambda": w.relevance_weight,
                "distance": str(getattr(distances, "kind", w.distance)), "viewpoints": m}
        info.update(gains.info())
        if gains.route == "structured" and self.prune:
            info["bounded_gains"] = int(bound.sum())
        return Decision(objects[i], eligible[c].name, float(total[i, c]), tuple(candidates),
                        self.name, info)


class FactorisedEFEPlanner(EFEPlanner):
    """The original design's information gain: docs/design.md eqs. (10)-(11) on the marginals, even if joint."""

    name = "factorised_efe"

    def __init__(self, weights: PlanningWeights) -> None:
        super().__init__(weights, information="factorised")


__all__ = ["EFEPlanner", "FactorisedEFEPlanner", "coupling_strength", "structured_gain", "factorised_information_gain",
           "joint_information_gain", "view_factorised_information_gain",
           "view_joint_information_gain", "one_object_information_gain", "entropies"]
