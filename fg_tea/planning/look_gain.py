"""The information gain of a look, whatever the belief's structure (docs/design.md eqs. 10-11, §6.2).

One question, one home: *how much does a look tell about where an object is?* The EFE planner
(:mod:`fg_tea.planning.efe`) asks it once per decision through :class:`LookGain`, which picks the
route the belief allows and keeps it for every look of that decision:

- ``"factorised"``: eqs. 10-11 on the marginals (:func:`factorised_information_gain` for close
  looks at sites, :func:`view_factorised_information_gain` for viewpoints);
- ``"one_object"``: the exact mutual information of a look with one object to find, in closed
  form from its marginal (:func:`one_object_information_gain`; viewpoints only);
- ``"structured"``: the subset program's joint gain beyond the dense limit
  (:class:`~fg_tea.planning.joint_gain.JointViewGain`, with exact bounds for pruning);
- ``"elimination"``: one variable elimination per object and look for beliefs with extra factors
  beyond the dense limit (:mod:`fg_tea.planning.eliminated_gain`);
- ``"dense"``: the dense joint P(L_U) (:func:`joint_information_gain`,
  :func:`view_joint_information_gain`).

The formulas are documented on :mod:`fg_tea.planning.efe` (its module docstring) and on each
function here; every route answers the same quantity as the dense one, to rounding.
"""

from __future__ import annotations

import math
import string
from typing import Callable, Sequence

import numpy as np

from fg_tea.beliefs.graph import DENSE_LIMIT
from fg_tea.beliefs.structured import NumericalGuardError
from fg_tea.common.errors import PlannerRefused
from fg_tea.common.stats import entropy
from fg_tea.planning.eliminated_gain import (check_gain, eliminated_gain_model, site_information_gain,
                                             view_information_gain)
from fg_tea.planning.joint_gain import JointViewGain

INFORMATION_MODES = ("auto", "factorised", "joint")
DENSE_GAIN_LIMIT = 50_000  # joint states up to which the dense joint answers the joint gain
CHUNK_ENTRIES = 1 << 22  # largest (sites x outcomes x joint states) product held at once


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


def information_mode(information: str, belief) -> str:
    """``"joint"`` or ``"factorised"``: the formula `information` (``"auto"``, ``"factorised"``,
    ``"joint"``) means for this belief (``"auto"``: joint when the belief is correlated)."""
    if information == "auto":
        return "joint" if belief.correlated else "factorised"
    return information


def check_information(belief, objects: Sequence[str], mode: str, planner: str) -> None:
    """Refuse a belief whose exact joint gain has no route: a joint above the dense limit without a
    subset program or the elimination method (docs/design.md §4.6).

    Raises:
        PlannerRefused: kind ``"belief"``, naming the sizes and the way out.
    """
    size = len(belief.sites) ** len(belief.objects)
    elim = eliminated_gain_model(belief) if mode == "joint" else None
    if elim is not None:
        return check_gain(elim, [belief.objects.index(o) for o in objects], planner)
    if mode != "joint" or size <= DENSE_LIMIT or belief.structured_model() is not None:
        return
    raise PlannerRefused(f"{planner} planner: the exact joint information gain needs the joint of "
                         f"{len(belief.objects)} objects x {len(belief.sites)} sites ({size:,} states), "
                         f"above the dense limit {DENSE_LIMIT:,}, and this belief has neither a subset "
                         "program nor the elimination method; use information = 'factorised'",
                         "belief", planner)


#: How a pruning caller turns a gain's (lower, upper) bounds, shape (n, m), into the candidates
#: whose exact gain it needs (boolean, same shape).
NeedFromBounds = Callable[[np.ndarray, np.ndarray], np.ndarray]


class LookGain:
    """I(o, look) for the unresolved objects `idx` (caller's order) of one decision, by the one
    route the belief allows (module docstring); built once per decision.

    Args:
        belief: the belief (read only).
        idx: the objects' indices in ``belief.objects``.
        mode: ``"joint"`` or ``"factorised"`` (:func:`information_mode`).
        views: the looks are viewpoints (:meth:`view_gains`) rather than close looks at every site
            (:meth:`site_gains`); with one object, viewpoints take the closed form.

    Attributes:
        route: ``"factorised"``, ``"one_object"``, ``"structured"``, ``"elimination"`` or ``"dense"``.
    """

    def __init__(self, belief, idx: Sequence[int], mode: str, views: bool) -> None:
        self.belief, self.idx, self.mode = belief, list(idx), mode
        self.solver: JointViewGain | None = None
        self.elim = None
        if mode != "joint":
            self.route = "factorised"
        elif views and len(self.idx) == 1:
            self.route = "one_object"
        elif (solver := structured_gain(belief, self.idx)) is not None:
            self.route, self.solver = "structured", solver
        elif (elim := eliminated_gain_model(belief)) is not None:
            self.route, self.elim = "elimination", elim
        else:
            self.route = "dense"
        self._joint: np.ndarray | None = None

    @property
    def batched(self) -> bool:
        """The route answers all looks at once (structured, one object), not one look at a time."""
        return self.route in ("structured", "one_object")

    def _dense(self) -> np.ndarray:
        if self._joint is None:
            self._joint = self.belief.location_joint()
        return self._joint

    def site_gains(self) -> np.ndarray:
        """I(o, j) for a close look at every site j, shape (|idx|, K), nats."""
        belief, idx = self.belief, self.idx
        model = belief.model
        if self.solver is not None:
            close = np.full((len(idx), 1), 1.0 - model.miss_likelihood)
            return self.solver.gains([([j], close) for j in range(len(belief.sites))])
        if self.elim is not None:
            return site_information_gain(self.elim, idx, model.miss_likelihood, model.false_positive_rate)
        if self.route == "dense":
            return joint_information_gain(self._dense(), idx, model.miss_likelihood, model.false_positive_rate)
        q = belief.location_matrix()[idx]
        return factorised_information_gain(q, model.miss_likelihood)

    def view_gains(self, eligible: Sequence, p_max: float,
                   need_from_bounds: NeedFromBounds | None = None) -> tuple[np.ndarray, np.ndarray]:
        """I(o, v) for each viewpoint of `eligible` (:class:`~fg_tea.beliefs.detection.View`), shape
        (|idx|, m), nats, and which entries are a gain's upper bound rather than the gain.

        Args:
            eligible: the looks.
            p_max: the detector's best detection probability (the factorised route's `find`).
            need_from_bounds: on the structured route, skip the exact gain of every candidate this
                maps the gains' bounds to False (docs/design.md §6.2, eq. 56); its entry is then the
                upper bound, flagged. None computes every gain exactly.
        """
        belief, idx = self.belief, self.idx
        n, m, k = len(idx), len(eligible), len(belief.sites)
        fp = belief.model.false_positive_rate
        bound = np.zeros((n, m), dtype=bool)
        if self.route == "one_object":
            q = belief.location_matrix()[idx]
            gain = one_object_information_gain(q[0], [(v.sites, v.probability[idx[0]]) for v in eligible], fp)
            return gain[None, :], bound
        if self.solver is not None:
            look = [(v.sites, v.probability[idx]) for v in eligible]
            if need_from_bounds is None:
                return self.solver.gains(look), bound
            lower, upper = self.solver.gain_bounds(look)
            gain = self.solver.gains(look, need_from_bounds(lower, upper))
            bound = np.isnan(gain)
            return np.where(bound, upper, gain), bound
        gain = np.empty((n, m))
        q = belief.location_matrix()[idx] if self.route == "factorised" else None
        for c, v in enumerate(eligible):
            if self.route == "dense":
                gain[:, c] = view_joint_information_gain(self._dense(), idx, v.sites, v.probability[idx], fp)
            elif self.elim is not None:
                gain[:, c] = view_information_gain(self.elim, idx, v.sites, v.probability[idx], fp)
            else:
                assert q is not None  # the factorised route
                miss = np.ones((n, k))
                miss[:, list(v.sites)] = v.miss[idx]
                gain[:, c] = view_factorised_information_gain(q, v.probability_over_sites(k)[idx], miss,
                                                              p_max)[1]
        return gain, bound

    def info(self) -> dict[str, float | str]:
        """What a decision logs about the route (``gain_solver``; the structured solver's
        ``restricted_gains``); nothing for the factorised and dense routes."""
        if self.route in ("one_object", "elimination"):
            return {"gain_solver": self.route}
        if self.solver is not None:
            return {"gain_solver": "structured", "restricted_gains": self.solver.restricted}
        return {}


__all__ = ["INFORMATION_MODES", "DENSE_GAIN_LIMIT", "CHUNK_ENTRIES", "LookGain", "NeedFromBounds",
           "information_mode", "check_information", "entropies", "factorised_information_gain",
           "joint_information_gain", "view_factorised_information_gain", "view_joint_information_gain",
           "one_object_information_gain", "coupling_strength", "structured_gain"]
