"""How much does one look tell about each object's location when beliefs are joint — without the
dense joint?

The exact mutual information I(L_o ; Y_v) between an unresolved object's location L_o and the
joint outcome Y_v = (Y_u)_u of a look from viewpoint v (for every unresolved u: seen at in-view
site c, or not seen) is computed from the subset dynamic program of
:mod:`fg_tea.beliefs.structured` (docs/design.md §4.4, §6.2, eq. 43), never from a K^N table.

Why it is tractable. Given the locations, each Y_u depends on L_u only through its **class**
C_u: which in-view site u stands on (1..m), or "outside the view" (0), because the detection
model is p_{u,c} at in-view site c and the false-positive rate fp at every other site. The class
configuration of all objects is the tuple of in-view site sets (S_1, ..., S_m), and the
structured model gives its probability in closed form. The in-view sites of a look all lie in
one room R (a close look: one site; a glance: the room's sites), so

    Z P(S_1 = A_1, ..., S_m = A_m) = prod_t g_{s_t}(A_t) * W_v(A_1 ∪ ... ∪ A_m)
    W_v(T) = sum_{X disjoint T} C_D(X) rho(T ∪ X) O_R(all objects not in T ∪ X)

with g, rho as in eq. (36), D the sites of R out of view, C_D the subset convolution of their g,
and O_R the convolution of every other room's weight. Fixing L_o = a for an out-of-view site a
changes only W_v (o's factor moves into the room of a), giving W_{v,o,a}; then

    Z P(L_o = a, S_1 = A_1, ..., S_m = A_m) = prod_t g_{s_t}(A_t) * W_{v,o,a}(A_1 ∪ ... ∪ A_m).

Objects whose outcome is not tracked (objects already found) are summed over in-view sites by
a subset convolution over them. The outcome likelihood factorises over objects given classes,
so P(L_o = a, Y) follows by one (m+1) x (m+1) matrix per axis, and

    I(L_o ; Y_v) = H(L_o) + H(Y_v) - H(L_o, Y_v)                              (eq. 42)

exactly, with H(L_o, Y_v) split into in-view a (L_o determined by C_o) and out-of-view a
(Y_o independent of everything else given C_o = 0).

Cost. Per decision: one batched subset convolution per pair of rooms (the W_{v,o,a} of
glances) and one "completion" per close look, about (K + R) N K 3^N; per viewpoint the class
tables, about N K (m+1)^(N-1). The latter is exponential in the number of tracked objects with
base m + 1: a glance over m = 5 sites with 8 unresolved objects has 6^8 = 1.7 million joint
outcomes, each needed for every (o, a). Above :data:`OUTCOME_LIMIT` entries per object the
outcome is restricted to o and the objects most strongly coupled to it (the *tracked* set);
the others' outcomes are summed out. That gives I(L_o ; Y_{v,tracked}) <= I(L_o ; Y_v), a lower
bound whose error is measured in ``tests/test_planning_joint_gain.py`` and by
``experiments/bench_planning.py``.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from fg_tea.beliefs.structured import StructuredLocationModel, SubsetAlgebra

OUTCOME_LIMIT = 1 << 17  # entries of one object's P(L_o = a, Y_{-o}) table before restricting
MI_TOLERANCE = 1e-12     # gains are clipped at 0 from below within this tolerance


def _neg_xlogx_sum(p: np.ndarray, axis=None) -> np.ndarray:
    """sum -p log p (nats), 0 where p = 0."""
    p = np.asarray(p, dtype=float)
    safe = np.where(p > 0, p, 1.0)
    return -(p * np.log(safe)).sum(axis=axis)


def detection_table(prob: np.ndarray, fp: float) -> np.ndarray:
    """P(Y_u = y | C_u = c) for one object, shape (m + 1, m + 1): rows class, columns outcome.

    Args:
        prob: p_{u,c} for the m in-view sites, shape (m,).
        fp: P(seen at one given in-view site | standing elsewhere), per site.
    """
    m = len(prob)
    f = np.zeros((m + 1, m + 1))
    f[:, 1:] = fp
    for c in range(m):
        f[1 + c, 1 + c] = prob[c]
    f[:, 0] = 1.0 - f[:, 1:].sum(axis=1)
    return np.clip(f, 0.0, 1.0)


def _transform(t: np.ndarray, tables: Sequence[np.ndarray | None], lead: int = 0) -> np.ndarray:
    """Apply tables[i] (class -> outcome) to axis lead + i of `t` (None leaves the axis alone)."""
    for i, f in enumerate(tables):
        if f is None:
            continue
        ax = lead + i
        t = np.moveaxis(np.tensordot(t, f, axes=([ax], [0])), -1, ax)
    return t


class JointViewGain:
    """Exact I(L_o ; Y_v) for every unresolved object and viewpoint of one decision.

    Args:
        model: the structured location model of the current belief (forward pass done).
        observed: belief indices of the unresolved objects whose outcome a look reports.
        fp: false-positive rate per in-view site.
        outcome_limit: largest P(L_o = a, Y_{-o}) table (entries) computed exactly per object
            and viewpoint; above it the tracked outcome set is restricted (module docstring).
            None = always exact.

    Attributes:
        restricted: number of (object, viewpoint) gains computed on a restricted outcome set in
            the last :meth:`gains` call (0 = every gain exact).
    """

    def __init__(self, model: StructuredLocationModel, observed: Sequence[int], fp: float,
                 outcome_limit: int | None = OUTCOME_LIMIT, coupling: np.ndarray | None = None) -> None:
        self.sm = model
        self.observed = [int(u) for u in observed]
        if len(set(self.observed)) != len(self.observed):
            raise ValueError(f"observed objects repeated: {self.observed}")
        self.fp = float(fp)
        self.outcome_limit = outcome_limit
        sm = model
        sm._singles()
        self.q = sm._q                                   # (N, K) exact marginals
        self.n, self.k = sm.n, sm.k
        self.alg: SubsetAlgebra = sm.alg
        ix = self.alg.ix
        self.full = ix.full
        self.comp = self.full ^ np.arange(self.full + 1)
        self.mem = ix.members.T                          # (N, 2^N)
        n = self.n
        self.coupling = (np.zeros((n, n)) if coupling is None else np.asarray(coupling, float))
        self._split: dict[int, np.ndarray] = {}
        self._out: dict[int, np.ndarray] = {}
        self.restricted = 0

    # ------------------------------------------------------------------ per-room weights
    def _room_split(self, r: int) -> np.ndarray:
        """h_R^{o@a}(X) = rho(X) * sum_{B ∋ o} g_a(B) C_{R∖a}(X∖B), shape (|R|, N, 2^N)."""
        cached = self._split.get(r)
        if cached is None:
            sm, alg = self.sm, self.alg
            excl = sm._excl[r]
            cached = np.stack([sm.rho * alg.conv(self.mem * sm.g[a], excl[t])
                               for t, a in enumerate(sm.room_sites[r])])
            self._split[r] = cached
        return cached

    def _room_out(self, r0: int) -> np.ndarray:
        """Out[a, o, T] = rho(T) * (weight of every object not in T outside room r0, with o at a),
        for a outside r0 (rows of r0's sites are 0), shape (K, N, 2^N)."""
        cached = self._out.get(r0)
        if cached is None:
            sm, alg = self.sm, self.alg
            others = [r for r in range(len(sm.room_sites)) if r != r0]
            pre = [alg.delta()]
            for r in others:
                pre.append(alg.conv(pre[-1], sm.h[r]))
            suf = [alg.delta()]
            for r in others[::-1]:
                suf.append(alg.conv(sm.h[r], suf[-1]))
            suf = suf[::-1]
            oa = np.zeros((self.k, self.n, self.full + 1))
            for i, r in enumerate(others):
                excl = alg.conv(pre[i], suf[i + 1])              # every room but r0 and r
                oa[sm.room_sites[r]] = alg.conv(self._room_split(r), excl)
            cached = sm.rho * oa[:, :, self.comp]
            self._out[r0] = cached
        return cached

    def _view_weights(self, sites: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """W_v(T), shape (2^N,), and W_{v,o,a}(T), shape (K, N, 2^N) (0 for a in view)."""
        sm, alg = self.sm, self.alg
        rooms = {int(sm.room_of[j]) for j in sites}
        if len(rooms) != 1:
            raise ValueError("the structured gain needs every in-view site in one room")
        r0 = rooms.pop()
        in_view = set(int(j) for j in sites)
        rest = [int(j) for j in sm.room_sites[r0] if int(j) not in in_view]
        pre = [alg.delta()]
        for j in rest:
            pre.append(alg.conv(pre[-1], sm.g[j]))
        suf = [alg.delta()]
        for j in rest[::-1]:
            suf.append(alg.conv(sm.g[j], suf[-1]))
        suf = suf[::-1]
        w_room = sm._w[r0]
        out = self._room_out(r0)
        if rest:
            c_d = pre[-1]
            w_v = alg.completions(c_d, w_room)
            w_oa = alg.completions(c_d, out)
            for i, a in enumerate(rest):
                c_oa = alg.conv(self.mem * sm.g[a], alg.conv(pre[i], suf[i + 1]))   # (N, 2^N)
                w_oa[a] = alg.completions(c_oa, w_room)
        else:
            w_v, w_oa = w_room, out
        return w_v, w_oa

    # ------------------------------------------------------------------ class tables
    def _tables(self, sites: Sequence[int], tracked: Sequence[int], w_v: np.ndarray,
                w_oa: np.ndarray, targets: Sequence[int]) -> tuple[np.ndarray, dict]:
        """Z-normalised P(C_tracked) (shape (m+1,)*s) and, for each target position i,
        P(L_o = a, C_{tracked∖o}) for out-of-view a (shape (K_out,) + (m+1,)*(s-1))."""
        sm = self.sm
        m, s = len(sites), len(tracked)
        free = [o for o in range(self.n) if o not in tracked]
        codes = np.indices((m + 1,) * s).reshape(s, -1).T if s else np.zeros((1, 0), int)
        bits = np.array([1 << o for o in tracked], dtype=np.int64)
        a_mask = [(codes == t + 1) @ bits for t in range(m)]              # per site, (n_c,)
        t_mask = (codes > 0) @ bits
        f = len(free)
        emb = np.zeros(1 << f, dtype=np.int64)
        for b, o in enumerate(free):
            emb[(np.arange(1 << f) >> b) & 1 == 1] |= 1 << o
        psi = np.zeros((len(codes), 1 << f))
        psi[:, 0] = 1.0
        fa = SubsetAlgebra(f) if f else None
        for t, j in enumerate(sites):
            kern = sm.g[j][a_mask[t][:, None] | emb[None, :]]            # (n_c, 2^f)
            psi = fa.conv(psi, kern) if f else psi * kern
        masks = t_mask[:, None] | emb[None, :]                             # (n_c, 2^f)
        shape = (m + 1,) * s
        p_c = (psi * w_v[masks]).sum(axis=1).reshape(shape) / sm.z
        out_sites = np.array([a for a in range(self.k) if a not in set(sites)], dtype=int)
        outs = {}
        for i in targets:
            rows = codes[:, i] == 0
            o = tracked[i]
            vals = w_oa[out_sites][:, o][:, masks[rows]]                  # (K_out, n_rows, 2^f)
            tab = np.einsum("arf,rf->ar", vals, psi[rows]) / sm.z
            outs[i] = tab.reshape((len(out_sites),) + (m + 1,) * (s - 1))
        return p_c, outs

    # ------------------------------------------------------------------ mutual information
    def _gains_for(self, sites: Sequence[int], prob: np.ndarray, tracked: Sequence[int],
                   targets: Sequence[int], w_v: np.ndarray, w_oa: np.ndarray) -> np.ndarray:
        """I(L_o ; Y_tracked) for o = tracked[i], i in targets."""
        prob_of = {u: prob[p] for p, u in enumerate(self.observed)}
        tables = [detection_table(prob_of[u], self.fp) for u in tracked]
        p_c, outs = self._tables(sites, tracked, w_v, w_oa, targets)
        s, m = len(tracked), len(sites)
        h_y = _neg_xlogx_sum(_transform(p_c, tables))
        res = []
        for i in targets:
            o = tracked[i]
            part = _transform(p_c, [None if b == i else tables[b] for b in range(s)])
            by_class = np.moveaxis(part, i, 0)                       # P(C_o = c, Y_{-o})
            p_class = by_class.reshape(m + 1, -1).sum(axis=1)
            h_own = _neg_xlogx_sum(tables[i], axis=1)                 # H(Y_o | C_o = c)
            h_in = _neg_xlogx_sum(by_class[1:]) + float(p_class[1:] @ h_own[1:])
            out = _transform(outs[i], [tables[b] for b in range(s) if b != i], lead=1)
            p_out = float(outs[i].sum())
            h_out = _neg_xlogx_sum(out) + p_out * _neg_xlogx_sum(tables[i][0])
            h_o = _neg_xlogx_sum(self.q[o])
            res.append(h_o + h_y - h_in - h_out)
        gain = np.array(res)
        return np.where(np.abs(gain) < MI_TOLERANCE, np.maximum(gain, 0.0), gain)

    def _tracked_for(self, o: int, m: int) -> list[int]:
        """o and the observed objects most coupled to it, as many as the outcome limit allows."""
        n_out = self.k
        others = [u for u in self.observed if u != o]
        order = sorted(others, key=lambda u: (-self.coupling[o, u], self.observed.index(u)))
        tracked = [o]
        for u in order:
            size = n_out * (m + 1) ** len(tracked) * 2 ** (self.n - len(tracked) - 1)
            if size > self.outcome_limit:
                break
            tracked.append(u)
        return sorted(tracked)

    def gain(self, sites: Sequence[int], prob: np.ndarray) -> np.ndarray:
        """I(L_u ; Y_v) for every observed u (constructor order), shape (len(observed),), nats.

        Args:
            sites: belief indices of the in-view sites s_1..s_m (all in one room).
            prob: p_{u,c}, shape (len(observed), m).
        """
        sites = [int(j) for j in sites]
        prob = np.asarray(prob, dtype=float).reshape(len(self.observed), len(sites))
        m = len(sites)
        w_v, w_oa = self._view_weights(sites)
        full_size = self.k * (m + 1) ** (len(self.observed) - 1) * 2 ** (self.n - len(self.observed))
        if self.outcome_limit is None or full_size <= self.outcome_limit:
            tracked = sorted(self.observed)
            g = self._gains_for(sites, prob, tracked, range(len(tracked)), w_v, w_oa)
            by_obj = dict(zip(tracked, g))
            return np.array([by_obj[u] for u in self.observed])
        out = np.empty(len(self.observed))
        for p, o in enumerate(self.observed):
            tracked = self._tracked_for(o, m)
            out[p] = self._gains_for(sites, prob, tracked, [tracked.index(o)], w_v, w_oa)[0]
            self.restricted += 1
        return out

    def gains(self, views: Sequence[tuple[Sequence[int], np.ndarray]]) -> np.ndarray:
        """I(L_u ; Y_v) for every observed u and view, shape (len(observed), len(views)), nats."""
        self.restricted = 0
        return np.stack([self.gain(s, p) for s, p in views], axis=1) if views else \
            np.zeros((len(self.observed), 0))


__all__ = ["JointViewGain", "OUTCOME_LIMIT", "detection_table"]
