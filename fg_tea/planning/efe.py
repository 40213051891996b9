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

The original factorised score on a joint belief (eqs. 10-11 applied to the marginals) is
:class:`FactorisedEFEPlanner`, a baseline.
"""

from __future__ import annotations

import math
import string
from typing import Mapping, Sequence

import numpy as np

from fg_tea.beliefs.graph import DENSE_LIMIT
from fg_tea.beliefs.structured import NumericalGuardError
from fg_tea.common.errors import PlannerRefused
from fg_tea.common.stats import entropy
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
from fg_tea.planning.eliminated_gain import (check_gain, eliminated_gain_model, site_information_gain,
                                             view_information_gain)
from fg_tea.planning.joint_gain import JointViewGain

INFORMATION_MODES = ("auto", "factorised", "joint")
DENSE_GAIN_LIMIT = 50_000  # joint states up to which the dense joint answers the joint gain
CHUNK_ENTRIES = 1 << 22  # largest (sites x outcomes x joint states) product held at once
PRUNE_SLACK = 1e-9       # score units: a candidate is skipped only if its lower bound exceeds the
                         # best upper bound by more than this (rounding of the two scores)


def entropies(q: np.ndarray) -> np.ndarray:
    """Entropy (nats, eq. 7) of each distribution along the last axis."""
    return entropy(q, axis=-1)


def factorised_information_gain(q: np.ndarray, mu: float) -> np.ndarray:
    """Eqs. 10-11 for every object and site.

    Args:
        q: location marginals, shape (N, K), rows sum to 1.
        mu: miss likelihood of eq. 5, in (0, 1].

    Returns:
        I, shape (N, K), nats: I[o, j] = H(q_o) - (1 - q_oj) H(q_o^{-j}).
    """
    q = np.asarray(q, dtype=float)
    n, k = q.shape
    lik = np.ones((k, k))
    np.fill_diagonal(lik, mu)  # (j, i): eq. 5
    post = q[:, None, :] * lik[None, :, :]  # (o, j, i)
    post /= post.sum(axis=2, keepdims=True)  # eq. 6
    expected_after = (1.0 - q) * entropies(post)  # eq. 10
    return entropies(q)[:, None] - expected_after  # eq. 11


def joint_information_gain(joint: np.ndarray, unresolved: Sequence[int], mu: float, fp: float,
                           sites: Sequence[int] | np.ndarray | None = None) -> np.ndarray:
    """Exact I(o, j) = H(L_o) + H(D_j) - H(L_o, D_j) over the joint outcome of one inspection.

    Args:
        joint: P(L_1, ..., L_N), shape (K,) * N (every object of the belief, belief order).
        unresolved: axes of `joint` (object indices) whose detection is observed, |U| >= 1,
            no repeats; the result's rows follow this order.
        mu: P(not seen | at the inspected site), in (0, 1].
        fp: P(seen | elsewhere), in [0, 1).
        sites: the inspected sites to evaluate (indices); all K by default.

    Returns:
        I, shape (|U|, len(sites)), nats.
    """
    joint = np.asarray(joint, dtype=float)
    n_all, k = joint.ndim, joint.shape[0]
    unresolved = list(unresolved)
    n = len(unresolved)
    others = tuple(a for a in range(n_all) if a not in unresolved)
    p_u = joint.sum(axis=others) if others else joint
    # Axes of p_u are the unresolved objects in increasing index order; reorder to `unresolved`.
    order = sorted(unresolved)
    p_u = np.transpose(p_u, [order.index(u) for u in unresolved])
    sites = np.arange(k) if sites is None else np.asarray(list(sites), dtype=int)

    # Detection model per object, f[j, d, a] = P(D = d | L = a) at inspected site j; d: 0 miss, 1 seen.
    f = np.empty((k, 2, k))
    f[:, 1, :] = fp
    f[:, 0, :] = 1.0 - fp
    idx = np.arange(k)
    f[idx, 1, idx] = 1.0 - mu
    f[idx, 0, idx] = mu
    f = f[sites]

    letters = iter(string.ascii_letters)
    j_ax = next(letters)
    d_ax = [next(letters) for _ in range(n)]
    a_ax = [next(letters) for _ in range(n)]
    spec = ",".join(["".join(a_ax)] + [j_ax + d_ax[u] + a_ax[u] for u in range(n)])
    spec += "->" + j_ax + "".join(d_ax) + "".join(a_ax)

    h_marg = entropies(np.stack([p_u.sum(axis=tuple(b for b in range(n) if b != u))
                                 for u in range(n)]))  # (|U|,)
    out = np.empty((n, len(sites)))
    per_site = (2 ** n) * k ** n
    step = max(1, CHUNK_ENTRIES // per_site)
    for start in range(0, len(sites), step):
        fs = f[start:start + step]
        r = np.einsum(spec, p_u, *([fs] * n))  # (J, 2,...,2, K,...,K): P(D_j = d, L_U = a)
        m = len(fs)
        flat_d = r.reshape((m, 2 ** n) + (k,) * n)
        h_d = entropies(flat_d.reshape(m, 2 ** n, -1).sum(axis=2))  # H(D_j), (J,)
        for u in range(n):
            rest = tuple(2 + b for b in range(n) if b != u)
            p_od = flat_d.sum(axis=rest) if rest else flat_d  # (J, 2^n, K): P(D_j, L_o)
            h_joint = entropies(p_od.reshape(m, -1))  # H(L_o, D_j)
            out[u, start:start + m] = h_marg[u] + h_d - h_joint
    return out


def view_factorised_information_gain(q: np.ndarray, prob: np.ndarray, miss: np.ndarray,
                                    p_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Eqs. 10-11 over what one look sees, for every object (docs/design.md, "Planning over
    viewpoints").

    Args:
        q: location marginals, shape (n, K).
        prob: p_{o,a}, shape (n, K): the chance the look shows o if o stands at site a (0 for
            sites out of view).
        miss: the miss likelihood l(a) of the look, shape (n, K) (1 for sites out of view).
        p_max: the detector's best detection probability (a clear close look).

    Returns:
        (find, gain), each shape (n,): find = sum_a q(a) p(a) / p_max, the chance the look finds
        o relative to a clear close look (q(L_o = j) for a close look at j with the threshold
        detector); gain = H(q) - (1 - find) H(q^{-v}) with q^{-v} ∝ q l, the miss posterior.
    """
    find = (q * prob).sum(axis=1) / p_max
    post = q * miss
    post = post / post.sum(axis=1, keepdims=True)
    return find, entropies(q) - (1.0 - find) * entropies(post)


def view_joint_information_gain(joint: np.ndarray, unresolved: Sequence[int], sites: Sequence[int],
                                prob: np.ndarray, fp: float) -> np.ndarray:
    """Exact I(L_o; D_v) over the joint outcome of one look covering `sites`.

    Each unresolved object u's outcome D_u is "seen at in-view site c" (c = 1..m) or "not seen"
    (0), independently given the locations:

        P(D_u = c | L_u = a) = p_{u,c} if a = s_c, else fp;   P(D_u = 0 | a) = 1 - sum_c P(D_u = c | a).

    I(L_o; D_v) = H(L_o) + H(D_v) - H(L_o, D_v), with D_v = (D_u)_u. The outcome model depends on
    every other object's site only through its class (which in-view site, or outside), so each
    other axis of P(L_U) is contracted against its (K, m + 1) outcome table once.

    Args:
        joint: P(L_1, ..., L_N), shape (K,) * N, belief order.
        unresolved: object axes whose outcome the look reports; the result follows this order.
        sites: in-view site indices s_1..s_m.
        prob: p_{u,c}, shape (len(unresolved), m).
        fp: P(seen at one in-view site | elsewhere), per site.

    Returns:
        I, shape (len(unresolved),), nats.
    """
    joint = np.asarray(joint, dtype=float)
    n_all, k = joint.ndim, joint.shape[0]
    unresolved = list(unresolved)
    n, m = len(unresolved), len(sites)
    others = tuple(a for a in range(n_all) if a not in unresolved)
    p_u = joint.sum(axis=others) if others else joint
    order = sorted(unresolved)
    p_u = np.transpose(p_u, [order.index(u) for u in unresolved])
    # F[u][a, d] = P(D_u = d | L_u = a), shape (K, m + 1).
    tables = []
    for u in range(n):
        f = np.zeros((k, m + 1))
        f[:, 1:] = fp
        for c, s in enumerate(sites):
            f[s, 1:] = fp
            f[s, 1 + c] = prob[u, c]
        f[:, 0] = 1.0 - f[:, 1:].sum(axis=1)
        tables.append(np.clip(f, 0.0, 1.0))
    out = np.empty(n)
    for u in range(n):
        r = p_u
        # Contract every other axis against its outcome table; the object's own axis stays first.
        r = np.moveaxis(r, u, 0)
        rest = [b for b in range(n) if b != u]
        for b in rest:
            r = np.tensordot(r, tables[b], axes=([1], [0]))  # consumes axis 1, appends outcome axis
        r = r.reshape(k, -1)                                   # P(L_o = a, D_{-o})
        full = tables[u][:, :, None] * r[:, None, :]           # P(L_o = a, D_o, D_{-o})
        h_joint = entropies(full.reshape(1, -1))[0]
        h_d = entropies(full.sum(axis=0).reshape(1, -1))[0]
        h_o = entropies(full.sum(axis=(1, 2)).reshape(1, -1))[0]
        out[u] = h_o + h_d - h_joint
    return out


def one_object_information_gain(q: np.ndarray, looks: Sequence[tuple[Sequence[int], np.ndarray]],
                                fp: float) -> np.ndarray:
    """Exact I(L_o; D_v) of :func:`view_joint_information_gain` when o is the only object whose
    outcome the look reports, for every look at once, from o's marginal alone.

    With one reported object the outcome D_v is o's own ("seen at in-view site c", c = 1..m, or
    not seen), which depends on the other objects only through P(L_o): the exact mutual
    information is H(D_v) - H(D_v | L_o), with P(D_v = c) = q(s_c) p_c + (1 - q(s_c)) fp and the
    outcome rows of the detection model (docs/design.md §6.2). No joint, and no subset program,
    is needed.

    A look whose outcome rows are not distributions (p_c + (m - 1) fp > 1, or m fp > 1: the
    dense form clips them) is left to :func:`view_joint_information_gain` itself, so the two
    agree on every input.

    Args:
        q: P(L_o), shape (K,), summing to 1 (the engine's marginal; within rounding).
        looks: per look, (in-view site indices s_1..s_m, p_{o,c} of shape (m,)).
        fp: P(seen at one in-view site | elsewhere), per site.

    Returns:
        I, shape (len(looks),), nats.

    Raises:
        ValueError: no looks, a look whose probabilities do not match its sites, or a q whose
            total is not positive and finite.
    """
    if not looks:
        raise ValueError("one_object_information_gain: no looks")
    if any(np.shape(prob) != (len(sites),) for sites, prob in looks):
        raise ValueError("one_object_information_gain: each look needs one probability per in-view site")
    total = float(q.sum())
    if not (math.isfinite(total) and total > 0):
        raise ValueError(f"one_object_information_gain: P(L_o) sums to {total}")
    width = max(len(sites) for sites, _ in looks)
    m = np.array([len(sites) for sites, _ in looks], dtype=float)[:, None]       # (V, 1)
    at = np.zeros((len(looks), width), dtype=np.int64)
    p = np.zeros((len(looks), width))
    used = np.zeros((len(looks), width), dtype=bool)
    for v, (sites, prob) in enumerate(looks):
        at[v, :len(sites)], p[v, :len(sites)], used[v, :len(sites)] = sites, prob, True

    def h(x):                                               # -x log x, 0 at 0
        return -x * np.log(np.maximum(x, 1e-300))

    q_in = np.where(used, q[at], 0.0)                       # P(L_o = s_c), (V, M)
    q_out = total - q_in.sum(axis=1)                        # P(L_o out of view), (V,)
    row_miss = np.clip(1.0 - p - (m - 1.0) * fp, 0.0, 1.0)  # P(D = 0 | L_o = s_c)
    out_miss = np.clip(1.0 - m[:, 0] * fp, 0.0, 1.0)        # P(D = 0 | L_o out of view)
    seen = q_in * p + (total - q_in) * fp                   # P(D = c)
    unseen = (q_in * row_miss).sum(axis=1) + q_out * out_miss
    h_d = np.where(used, h(seen), 0.0).sum(axis=1) + h(unseen)
    h_in = h(p) + (m - 1.0) * h(fp) + h(row_miss)           # H(D | L_o = s_c)
    h_out = m[:, 0] * h(fp) + h(out_miss)                   # H(D | L_o out of view)
    h_given = np.where(used, q_in * h_in, 0.0).sum(axis=1) + q_out * h_out
    gain = h_d - h_given
    clipped = ((used & (p + (m - 1.0) * fp > 1.0)).any(axis=1)) | (m[:, 0] * fp > 1.0)
    for bad in map(int, np.flatnonzero(clipped)):
        sites, prob = looks[bad]
        gain[bad] = view_joint_information_gain(q, [0], sites, np.asarray(prob)[None], fp)[0]
    return gain


def coupling_strength(belief) -> np.ndarray:
    """How strongly each pair of objects' locations interact, shape (N, N): |ln s_ab| + |ln r_ab|
    of eq. (35) (0 without a relation). Orders the outcomes kept when a look's joint outcome is
    too large to enumerate (:class:`~fg_tea.planning.joint_gain.JointViewGain`)."""
    pw = getattr(belief, "pair_weights", None)
    if pw is None:
        n = len(belief.objects)
        return np.zeros((n, n))
    with np.errstate(divide="ignore"):
        return np.abs(np.log(pw.same_site)) + np.abs(np.log(pw.same_room))


def structured_gain(belief, obj_idx: Sequence[int]) -> JointViewGain | None:
    """The structured joint-gain solver for this belief, or None where the dense joint is the
    cheaper exact route (at most :data:`DENSE_GAIN_LIMIT` joint states) or the only one
    (relational factors that are not site/room-local; a failed numerical guard)."""
    size = len(belief.sites) ** len(belief.objects)
    if size <= DENSE_GAIN_LIMIT:
        return None
    sm = belief.structured_model() if hasattr(belief, "structured_model") else None
    if sm is None:
        return None
    try:
        return JointViewGain(sm, obj_idx, belief.model.false_positive_rate,
                             coupling=coupling_strength(belief))
    except NumericalGuardError:
        return None


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
        mode = self.information if self.information != "auto" else \
            ("joint" if belief.correlated else "factorised")
        size = len(belief.sites) ** len(belief.objects)
        elim = eliminated_gain_model(belief) if mode == "joint" else None
        if elim is not None:
            return check_gain(elim, [belief.objects.index(o) for o in objects], self.name)
        if mode != "joint" or size <= DENSE_LIMIT or belief.structured_model() is not None:
            return
        raise PlannerRefused(f"{self.name} planner: the exact joint information gain needs the joint of "
                             f"{len(belief.objects)} objects x {len(belief.sites)} sites ({size:,} states), "
                             f"above the dense limit {DENSE_LIMIT:,}, and this belief has neither a subset "
                             "program nor the elimination method; use information = 'factorised'",
                             "belief", self.name)

    def information_gain(self, belief, objects: Sequence[str]) -> tuple[np.ndarray, str]:
        """I(o, j) for the objects (caller's order) and every site, shape (|objects|, K), nats.

        Returns:
            (gain, mode) with mode ``"joint"`` or ``"factorised"``: the formula used.
        """
        idx = [belief.objects.index(o) for o in objects]
        mode = self.information
        if mode == "auto":
            mode = "joint" if belief.correlated else "factorised"
        model = belief.model
        if mode == "joint":
            solver = structured_gain(belief, idx)
            if solver is not None:
                close = np.full((len(idx), 1), 1.0 - model.miss_likelihood)
                return solver.gains([([j], close) for j in range(len(belief.sites))]), mode
            elim = eliminated_gain_model(belief)
            if elim is not None:
                return site_information_gain(elim, idx, model.miss_likelihood, model.false_positive_rate), mode
            return joint_information_gain(belief.location_joint(), idx, model.miss_likelihood,
                                          model.false_positive_rate), mode
        q = belief.location_matrix()[idx]
        return factorised_information_gain(q, model.miss_likelihood), mode

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
        mode = self.information
        if mode == "auto":
            mode = "joint" if belief.correlated else "factorised"
        q_all = belief.location_matrix()
        q = q_all[obj_idx]
        n, m = len(objects), len(eligible)
        # One object to find: its exact gain needs only its marginal (closed form).
        one = mode == "joint" and n == 1
        solver = structured_gain(belief, obj_idx) if mode == "joint" and not one else None
        elim = eliminated_gain_model(belief) if mode == "joint" and solver is None and not one else None
        joint = belief.location_joint() if mode == "joint" and solver is None and elim is None and not one else None
        fp = belief.model.false_positive_rate
        find, gain = np.empty((n, m)), np.empty((n, m))
        if solver is not None or one:
            prob_all = np.stack([v.probability_over_sites(k)[obj_idx] for v in eligible])
            find[:] = ((q[None] * prob_all).sum(axis=2) / views.max_probability).T
            if one:
                gain[0] = one_object_information_gain(
                    q[0], [(v.sites, v.probability[obj_idx[0]]) for v in eligible], fp)
        else:
            for c, v in enumerate(eligible):
                prob = v.probability_over_sites(k)[obj_idx]
                miss = np.ones((n, k))
                miss[:, list(v.sites)] = v.miss[obj_idx]
                find[:, c], factorised = view_factorised_information_gain(q, prob, miss,
                                                                          views.max_probability)
                if joint is not None:
                    gain[:, c] = view_joint_information_gain(joint, obj_idx, v.sites,
                                                             v.probability[obj_idx], fp)
                elif elim is not None:
                    gain[:, c] = view_information_gain(elim, obj_idx, v.sites, v.probability[obj_idx], fp)
                else:
                    gain[:, c] = factorised
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

        bound = np.zeros((n, m), dtype=bool)
        if solver is not None:
            look = [(v.sites, v.probability[obj_idx]) for v in eligible]
            if self.prune:
                # Exact pruning (docs/design.md §6.2, eq. 56): a candidate whose score with the
                # gain's upper bound is above the best score with a gain's lower bound cannot be
                # the argmin, nor tie with it; its exact gain is not computed.
                lower, upper = solver.gain_bounds(look)
                least, most = scores(upper)[1], scores(lower)[1]
                if self.rank == 1:
                    need = least <= most.min() + PRUNE_SLACK
                else:
                    # A viewpoint makes the `rank` best only if its least possible score is at
                    # most the rank-th smallest of the viewpoints' largest possible scores; of
                    # its objects, only those that could be its best need the exact gain.
                    view_most = most.min(axis=0)
                    kth = np.sort(view_most)[min(self.rank, m) - 1]
                    need = ((least.min(axis=0) <= kth + PRUNE_SLACK)[None, :]
                            & (least <= view_most[None, :] + PRUNE_SLACK))
                gain = solver.gains(look, need)
                bound = np.isnan(gain)
                gain = np.where(bound, upper, gain)
            else:
                gain = solver.gains(look)
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
        if one:
            info["gain_solver"] = "one_object"
        if elim is not None:
            info["gain_solver"] = "elimination"
        if solver is not None:
            info["gain_solver"] = "structured"
            info["restricted_gains"] = solver.restricted
            if self.prune:
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
