"""How much does one look tell about each object's location when beliefs are joint — without the
dense joint?

The exact mutual information I(L_o ; Y_v) between an unresolved object's location L_o and the
joint outcome Y_v = (Y_u)_u of a look from viewpoint v (for every unresolved u: seen at in-view
site c, or not seen) is computed from the subset dynamic program of
:mod:`fg_tea.beliefs.structured` (docs/design.md §4.4, §6.2, eqs. 44-45), never from a K^N table.

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

Pruning. :meth:`JointViewGain.gain_bounds` bounds every gain from the marginals alone (eq. 56),
and :meth:`JointViewGain.gains` takes a mask of the gains wanted, so the planner computes exactly
only the candidates that could still be chosen (docs/design.md §6.2).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Sequence

import numpy as np

from fg_tea.beliefs.structured import StructuredLocationModel, subset_index
from fg_tea.common.stats import entropy
from fg_tea.planning.view_weights import ViewWeights

CHUNK_ENTRIES = 1 << 16  # looks per step of the out-of-view tables: about this many entries (half
                         # a megabyte, a core's L2 cache here; larger batches measured slower)
OUTCOME_LIMIT = 1 << 17  # entries of one object's P(L_o = a, Y_{-o}) table before restricting
MI_TOLERANCE = 1e-12     # gains are clipped at 0 from below within this tolerance
BOUND_TOLERANCE = 1e-9   # nats each bound of gain_bounds is widened by: far above the rounding of
                         # either side (agreement with brute force is checked to 1e-9 and holds
                         # to about 1e-13), far below any difference of scores that matters




def _outcomes(x: np.ndarray, tables: Sequence[np.ndarray], nb: int) -> np.ndarray:
    """Turn the trailing class axes of x into outcome axes: axis c_b becomes
    y_b = sum_c x[..., c, ...] tables[b][..., c, y].

    Args:
        x: shape B + E + (m + 1,) * s, with B the first `nb` axes (one table per index of B)
            and E any further axes.
        tables: s arrays of shape B + (m + 1, m + 1), class -> outcome.

    Each step contracts the first class axis by one batched matrix product (BLAS) and appends
    the outcome axis at the end; after s steps the order is the original one, and no step
    copies its input.
    """
    s = len(tables)
    if s == 0:
        return x
    shape = x.shape
    bshape = shape[:nb]
    nbatch = int(np.prod(bshape, dtype=np.int64))
    tail = shape[nb:]
    e = int(np.prod(tail[:len(tail) - s], dtype=np.int64))
    cls = tail[len(tail) - s:]
    x = x.reshape((nbatch, e, -1))
    for b in range(s):
        c = cls[b]
        tab = np.asarray(tables[b]).reshape(nbatch, 1, c, -1)
        x = np.matmul(x.reshape(nbatch, e, c, -1).transpose(0, 1, 3, 2), tab)
        x = x.reshape(nbatch, e, -1)
    return x.reshape(shape[:len(shape) - s] + tuple(np.asarray(t).shape[-1] for t in tables))


def _kron(tab: np.ndarray, objs: Sequence[int]) -> np.ndarray:
    """Kronecker product of the 2 x 2 tables tab[:, b] for b in objs (first = most significant),
    batched over the first axis, shape (G, 2^len, 2^len); the identity (1 x 1) when empty."""
    out = np.ones((tab.shape[0], 1, 1))
    for b in objs:
        r, c = out.shape[1:]
        out = (out[:, :, None, :, None] * tab[:, b][:, None, :, None, :]).reshape(-1, 2 * r, 2 * c)
    return out


def detection_table(prob: np.ndarray, fp: float) -> np.ndarray:
    """P(Y_u = y | C_u = c), shape (..., m + 1, m + 1): rows class, columns outcome.

    Args:
        prob: p_{u,c} for the m in-view sites, shape (..., m): one object, or a batch of them.
        fp: P(seen at one given in-view site | standing elsewhere), per site.
    """
    prob = np.asarray(prob, float)
    m = prob.shape[-1]
    f = np.zeros(prob.shape[:-1] + (m + 1, m + 1))
    f[..., 1:] = fp
    c = np.arange(1, m + 1)
    f[..., c, c] = prob
    f[..., 0] = 1.0 - f[..., 1:].sum(axis=-1)
    return np.clip(f, 0.0, 1.0)


@dataclass(frozen=True)
class _Layout:
    """Index arrays of one batch shape (objects, in-view sites, tracked objects), reused across
    decisions: class configurations in C order over the tracked objects' axes, their in-view
    object masks, and the embedding of the free (untracked) objects' subsets."""

    f: int
    codes: np.ndarray      # (n_c, s) class of each tracked object
    bits: np.ndarray       # (s,) 1 << tracked object
    emb: np.ndarray        # (2^f,) free-object subset index -> object mask
    sub: np.ndarray        # (2^s,) tracked subset index -> object mask
    a_mask: np.ndarray     # (m, n_c) mask of the tracked objects on in-view site t
    a_idx: np.ndarray      # (m, n_c) the same as a tracked subset index
    masks: np.ndarray      # (n_c, 2^f) in-view object mask of (configuration, free subset)
    by_a: tuple            # per t: (order, inverse, ((A, start, stop), ...)): configurations
                           # sorted by a_idx[t] (stable), and the run of each A in that order


@lru_cache(maxsize=64)
def _layout(n: int, m: int, tracked: tuple[int, ...]) -> _Layout:
    s = len(tracked)
    free = [o for o in range(n) if o not in tracked]
    f = len(free)
    codes = np.indices((m + 1,) * s).reshape(s, -1).T
    bits = np.array([1 << o for o in tracked], dtype=np.int64)
    emb = np.zeros(1 << f, dtype=np.int64)
    for b, o in enumerate(free):
        emb[(np.arange(1 << f) >> b) & 1 == 1] |= 1 << o
    sub = np.array([sum(int(bits[b]) for b in range(s) if a >> b & 1) for a in range(1 << s)],
                   dtype=np.int64)
    on = [(codes == t + 1) for t in range(m)]
    a_mask = np.stack([(x * bits).sum(axis=1) for x in on]) if m else np.zeros((0, len(codes)), np.int64)
    a_idx = np.stack([(x * (1 << np.arange(s))).sum(axis=1) for x in on]) if m else a_mask
    masks = ((codes > 0) * bits).sum(axis=1)[:, None] | emb[None, :]
    by_a = []
    for t in range(m):
        order = np.argsort(a_idx[t], kind="stable")
        keys = a_idx[t][order]
        cuts = np.flatnonzero(np.diff(keys)) + 1
        starts, stops = np.r_[0, cuts], np.r_[cuts, len(keys)]
        by_a.append((order, np.argsort(order),
                     tuple((int(keys[a]), int(a), int(b)) for a, b in zip(starts, stops))))
    for x in (codes, bits, emb, sub, a_mask, a_idx, masks):
        x.setflags(write=False)
    return _Layout(f, codes, bits, emb, sub, a_mask, a_idx, masks, tuple(by_a))


class JointViewGain(ViewWeights):
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
        super().__init__(model, observed, fp, coupling)
        self.outcome_limit = outcome_limit
        self.restricted = 0

    # ------------------------------------------------------------------ batched class tables
    def _batch(self, sites: np.ndarray, prob: np.ndarray, tracked: Sequence[int],
               targets: Sequence[int], w_v: np.ndarray, w_oa: np.ndarray) -> np.ndarray:
        """I(L_o ; Y_tracked) for o = tracked[i], i in targets, for G looks of m sites each.

        Args:
            sites: in-view sites, shape (G, m).
            prob: p_{u,c} of the tracked objects, shape (G, s, m).
            w_v, w_oa: shapes (G, 2^N) and (G, K, N, 2^(N-1)) (reduced, see red).

        Returns:
            shape (G, len(targets)), nats.
        """
        sm = self.sm
        g_n, m = sites.shape
        s, targets = len(tracked), list(targets)
        n_t = len(targets)
        lay = _layout(self.n, m, tuple(int(o) for o in tracked))
        codes, bits, emb, sub = lay.codes, lay.bits, lay.emb, lay.sub
        f = lay.f
        psi = np.ones((g_n, len(codes), 1 << f))
        psi[:, :, 1:] = 0.0
        fix = subset_index(f) if f else None
        for t in range(m):
            a_mask = lay.a_mask[t]
            if not f:
                psi = psi * sm.g[sites[:, t]][:, a_mask, None]
                continue
            # psi <- conv(psi, g_{s_t}(A ∪ ·)) by object set A of the tracked objects on s_t:
            # one matrix M_A[E, U] = g_{s_t}(A ∪ (U ∖ E)) per A, a product (BLAS) per A, on
            # the configurations sorted by A (each A's rows one contiguous run).
            assert fix is not None  # f > 0 here
            mats = np.zeros((g_n, len(sub), 1 << f, 1 << f))
            vals = sm.g[sites[:, t]][:, sub[:, None] | emb[None, :]]        # (G, 2^s, 2^f)
            mats[:, :, fix.a, fix.union] = vals[:, :, fix.b]
            order, inverse, runs = lay.by_a[t]
            x = psi[:, order]
            psi = np.concatenate([np.matmul(x[:, lo:hi], mats[:, a]) for a, lo, hi in runs],
                                 axis=1)[:, inverse]
        masks = lay.masks                                                   # (n_c, 2^f)
        cls = (g_n,) + (m + 1,) * s
        p_c = (psi * w_v[:, masks]).sum(axis=2).reshape(cls) / sm.z
        o_sel = np.array([tracked[i] for i in targets])
        # Detection tables per look and tracked object: (G, s, class, outcome).
        tab = detection_table(prob, self.fp)                              # (G, s, class, outcome)
        y = _outcomes(p_c, [tab[:, b] for b in range(s)], 1)
        h_y = entropy(y, axis=tuple(range(1, 1 + s)))                          # (G,)
        # -sum P ln P of P(C_o = c, Y_{-o}) over o's in-view classes c >= 1 (C_o = c is L_o = s_c):
        # every tracked axis but o's turned into outcomes, o's axis last (cyclic products).
        c1 = m + 1
        h_part = np.zeros((g_n, n_t))
        for t, i in enumerate(targets):
            x = np.moveaxis(np.take(p_c, np.arange(1, c1), axis=1 + i), 1 + i, -1)
            for b in range(s):
                if b != i:
                    x = np.matmul(x.reshape(g_n, c1, -1).transpose(0, 2, 1), tab[:, b])
            h_part[:, t] = entropy(x.reshape(g_n, -1), axis=1)
        h_out = self._out_of_view(sites, tracked, targets, psi, tab, w_oa, emb)
        own = tab[:, targets]                                                         # (G, T, c, y)
        h_own = entropy(own, axis=3)                                           # (G, T, c)
        q = self.q[o_sel]                                                             # (T, K)
        p_in = q[:, sites].transpose(1, 0, 2)                          # q(L_o = s_c), (G, T, m)
        p_out = 1.0 - p_in.sum(axis=2)
        h_in = h_part + (p_in * h_own[:, :, 1:]).sum(axis=2)
        h_o = entropy(q, axis=1)                                               # (T,)
        h_lo_y = h_in + h_out + p_out * h_own[:, :, 0]
        gain = h_o[None, :] + h_y[:, None] - h_lo_y
        return np.where(np.abs(gain) < MI_TOLERANCE, np.maximum(gain, 0.0), gain)

    def _out_of_view(self, sites: np.ndarray, tracked: Sequence[int], targets: Sequence[int],
                     psi: np.ndarray, tab: np.ndarray, w_oa: np.ndarray,
                     emb: np.ndarray) -> np.ndarray:
        """-sum P ln P over (a out of view, Y_{tracked∖o}) for each look and target, shape (G, T),
        nats.

        With o at an out-of-view site a (so o not in view), Z P(L_o = a, Y) = sum_T W_{v,o,a}(T)
        M_o(T, Y) over the sets T of objects in view, T not containing o, where the kernel
        M_o(T, Y) = sum over class configurations c and free-object sets E with in-view set
        mask(c) ∪ E = T of psi(c, E) P(Y | c) does not depend on a. M_o is built by turning each
        tracked class axis c into the pair (in view?, outcome) — a (m+1) x 2(m+1) table per
        axis — so the table for every a is one matrix product with the weights, and the outcome
        transform is done once per look instead of once per site.
        """
        g_n, m = sites.shape
        s, f = len(tracked), len(emb).bit_length() - 1
        c1 = m + 1
        # Class -> (in view?, outcome): tabp[g, b, c, bit, y] = [bit = (c > 0)] P(y | c).
        tabp = np.zeros((g_n, s, c1, 2, c1))
        tabp[:, :, 0, 0, :] = tab[:, :, 0, :]
        tabp[:, :, 1:, 1, :] = tab[:, :, 1:, :]
        tabp = tabp.reshape(g_n, s, c1, 2 * c1)
        in_view = np.zeros((g_n, self.k), dtype=bool)
        in_view[np.arange(g_n)[:, None], sites] = True
        psi = psi.reshape((g_n,) + (c1,) * s + (1 << f,))
        h_out = np.zeros((g_n, len(targets)))
        s1 = s - 1
        per_look = (((1 << f) << s1) + self.k) * c1 ** s1       # kernel and table entries
        chunk = max(1, CHUNK_ENTRIES // per_look)
        bits = np.indices((2,) * s1).reshape(s1, 1 << s1).astype(np.int64)
        for t, i in enumerate(targets):
            o = tracked[i]
            others = [b for b in range(s) if b != i]
            tb = np.zeros(1 << s1, dtype=np.int64)
            for k, b in enumerate(others):
                tb |= bits[k] << tracked[b]
            masks = (emb[:, None] | tb[None, :]).reshape(-1)      # kernel row -> set
            sort = np.argsort(masks)                                # -> increasing, as red[o]
            order = None if np.array_equal(sort, np.arange(len(masks))) else sort
            kron = m == 1 and f == 0 and s1 > 0
            for lo in range(0, g_n, chunk):                     # chunks that stay in cache
                hi = min(g_n, lo + chunk)
                gc = hi - lo
                x = np.take(psi[lo:hi], 0, axis=1 + i)              # (g, c.., 2^f), C_o = 0
                if kron:
                    # One site in view, every object tracked: class = in view, so the kernel is
                    # diag(psi) times the Kronecker product of the objects' 2 x 2 tables, applied
                    # as two factors (rows in increasing set order: highest object first).
                    x = x.reshape((gc,) + (2,) * s1).transpose((0,) + tuple(range(s1, 0, -1)))
                    w = w_oa[lo:hi, :, o][~in_view[lo:hi]].reshape(gc, -1, len(masks))
                    w = w * x.reshape(gc, 1, -1)
                    desc = others[::-1]
                    h = s1 // 2
                    k_hi, k_lo = _kron(tab[lo:hi], desc[:h]), _kron(tab[lo:hi], desc[h:])
                    n_hi, n_lo, n_a = k_hi.shape[1], k_lo.shape[1], w.shape[1]
                    p = np.matmul(w.reshape(gc, n_a * n_hi, n_lo), k_lo)
                    p = p.reshape(gc, n_a, n_hi, n_lo).transpose(0, 2, 1, 3).reshape(gc, n_hi, -1)
                    p = np.matmul(k_hi.transpose(0, 2, 1), p)
                    p /= self.sm.z
                    h_out[lo:hi, t] = entropy(p.reshape(gc, -1), axis=1)
                    continue
                else:
                    for b in others:                                # cyclic: class axis -> end
                        x = np.matmul(x.reshape(gc, c1, -1).transpose(0, 2, 1), tabp[lo:hi, b])
                    # x: (g, 2^f, (bit, y) per other tracked object) -> (g, sets, outcomes)
                    x = x.reshape((gc, 1 << f) + (2, c1) * s1)
                    x = x.transpose((0, 1) + tuple(2 + 2 * k for k in range(s1))
                                    + tuple(3 + 2 * k for k in range(s1)))
                    kernel = x.reshape(gc, len(masks), c1 ** s1)
                    if order is not None:
                        kernel = kernel[:, order]
                w = w_oa[lo:hi, :, o][~in_view[lo:hi]].reshape(gc, -1, len(masks))
                p = np.matmul(w, kernel)                          # Z P(a, Y), (g, K - m, Y)
                p /= self.sm.z
                h_out[lo:hi, t] = entropy(p.reshape(gc, -1), axis=1)
        return h_out

    def _tracked_for(self, o: int, m: int) -> list[int]:
        """o and the observed objects most coupled to it, as many as the outcome limit allows."""
        others = [u for u in self.observed if u != o]
        order = sorted(others, key=lambda u: (-self.coupling[o, u], self.observed.index(u)))
        tracked = [o]
        for u in order:
            size = self.k * (m + 1) ** len(tracked) * 2 ** (self.n - len(tracked) - 1)
            if size > self.outcome_limit:
                break
            tracked.append(u)
        return sorted(tracked)

    def _exact(self, m: int) -> bool:
        s = len(self.observed)
        size = self.k * (m + 1) ** (s - 1) * 2 ** (self.n - s)
        return self.outcome_limit is None or size <= self.outcome_limit

    def gain(self, sites: Sequence[int], prob: np.ndarray) -> np.ndarray:
        """I(L_u ; Y_v) for every observed u (constructor order), shape (len(observed),), nats.

        Args:
            sites: belief indices of the in-view sites s_1..s_m (all in one room).
            prob: p_{u,c}, shape (len(observed), m).
        """
        return self.gains([(sites, prob)])[:, 0]

    def gains(self, views: Sequence[tuple[Sequence[int], np.ndarray]],
              need: np.ndarray | None = None) -> np.ndarray:
        """I(L_u ; Y_v) for every observed u and view, shape (len(observed), len(views)), nats.

        Looks with the same number of in-view sites are evaluated together.

        Args:
            views: (in-view sites, p_{u,c} of shape (len(observed), m)) per look.
            need: optional boolean mask, shape (len(observed), len(views)): the gains asked
                for. Only looks with some gain asked for are evaluated, and within them only the
                objects asked for in some look of the same batch; every gain not computed is NaN.
                A computed gain has the same value as without the mask. None = every gain.
        """
        self.restricted = 0
        n_obs = len(self.observed)
        if need is None:
            need = np.ones((n_obs, len(views)), dtype=bool)
        need = np.asarray(need, dtype=bool)
        if need.shape != (n_obs, len(views)):
            raise ValueError(f"need has shape {need.shape}, expected {(n_obs, len(views))}")
        out = np.full((n_obs, len(views)), np.nan)
        view_sites = [[int(j) for j in v[0]] for v in views]
        active = [c for c in range(len(views)) if need[:, c].any()]
        close: dict[int, list[int]] = {}          # the close looks of each room, done together
        for c in active:
            if len(view_sites[c]) == 1:
                close.setdefault(int(self.sm.room_of[view_sites[c][0]]), []).append(view_sites[c][0])
        for r0, wanted in close.items():
            self._close_weights(r0, wanted)
        groups: dict[int, list[int]] = {}
        weights = {}
        for c in active:
            weights[c] = self._view_weights(view_sites[c])
            groups.setdefault(len(view_sites[c]), []).append(c)
        order = np.argsort(self.observed)
        tracked_all = sorted(self.observed)
        pos = {u: p for p, u in enumerate(self.observed)}
        for m, members in groups.items():
            if self._exact(m):
                asked = np.asarray(need[:, members].any(axis=1))      # constructor order
                targets = [i for i in range(n_obs) if asked[order[i]]]
                g = self._batch_of(views, members, m, order, tracked_all, targets, weights)
                out[order[targets][:, None], np.array(members)[None, :]] = g.T
                continue
            by_set: dict[tuple[int, ...], list[int]] = {}     # objects sharing a tracked set
            for o in self.observed:
                by_set.setdefault(tuple(self._tracked_for(o, m)), []).append(o)
            for tracked_set, objs in by_set.items():
                objs = [o for o in objs if need[pos[o], members].any()]
                looks = [c for c in members if need[[pos[o] for o in objs], c].any()]
                if not looks:
                    continue
                tracked = list(tracked_set)
                g = self._batch_of(views, looks, m, [pos[u] for u in tracked], tracked,
                                   [tracked.index(o) for o in objs], weights)
                for i, o in enumerate(objs):
                    out[pos[o], looks] = g[:, i]
                self.restricted += len(looks) * len(objs)
        return out

    def _batch_of(self, views, looks: list[int], m: int, rows, tracked: Sequence[int],
                  targets: Sequence[int], weights: dict) -> np.ndarray:
        """_batch over the looks `looks` (indices into views) of m sites each; `rows` picks the
        tracked objects' rows of each look's p_{u,c}."""
        n_obs = len(self.observed)
        sites = np.array([[int(j) for j in views[c][0]] for c in looks], dtype=int)
        probs = np.stack([np.asarray(views[c][1], float).reshape(n_obs, m) for c in looks])
        w_v = np.stack([weights[c][0] for c in looks])
        w_oa = np.stack([weights[c][1] for c in looks])
        return self._batch(sites, probs[:, rows], tracked, targets, w_v, w_oa)

    def gain_bounds(self, views: Sequence[tuple[Sequence[int], np.ndarray]]
                    ) -> tuple[np.ndarray, np.ndarray]:
        """Bounds on I(L_u ; Y_v) from the marginals alone, for every observed u and view.

        With C_u the class of u (which in-view site, or outside) and Y_u its outcome,
        I(C_u ; Y_u) needs only q(L_u = s_c) and u's detection table, and (docs/design.md §6.2,
        eq. 56)

            I(C_o ; Y_o)  <=  I(L_o ; Y_v)  <=  min( H(L_o), I(C_o ; Y_o) + min(B_o, sum_{u != o} I(C_u ; Y_u)) ):

        the left because Y_o is part of Y_v. The right: I(L_o ; Y_v) = I(L_o ; Y_o) +
        I(L_o ; Y_{-o} | Y_o), and the second term is at most I(L_o ; Y_{-o}) (Y_o depends on
        nothing but L_o), which is at most I(L_{-o} ; Y_{-o}) <= sum_{u != o} I(C_u ; Y_u)
        (outcomes are independent given the locations and depend on L_u only through C_u) and
        at most I(L_o ; L_{-o}) <= B_o (data processing; B_o from :meth:`_independence_bound`,
        finite for objects without pair factors). A restricted gain (o's outcome and some
        others) lies between the same bounds. Both are widened by :data:`BOUND_TOLERANCE`
        against rounding.

        Returns:
            (lower, upper), each shape (len(observed), len(views)), nats.
        """
        n_obs = len(self.observed)
        q = self.q[self.observed]                                          # (n_obs, K)
        own = np.zeros((n_obs, len(views)))
        groups: dict[int, list[int]] = {}
        for c, (view_sites, _) in enumerate(views):
            groups.setdefault(len(view_sites), []).append(c)
        for m, members in groups.items():
            sites = np.array([[int(j) for j in views[c][0]] for c in members], dtype=int)
            prob = np.stack([np.asarray(views[c][1], float).reshape(n_obs, m) for c in members])
            g_n = len(members)
            p_in = q[:, sites].transpose(1, 0, 2)                           # (G, n_obs, m)
            p_c = np.concatenate([np.maximum(1.0 - p_in.sum(axis=2, keepdims=True), 0.0), p_in],
                                 axis=2)                                    # (G, n_obs, m + 1)
            tab = detection_table(prob, self.fp)
            p_y = np.einsum("gnc,gncy->gny", p_c, tab)
            info = entropy(p_y, axis=2) - (p_c * entropy(tab, axis=3)).sum(axis=2)
            own[:, members] = np.maximum(info, 0.0).T
        h_o = entropy(q, axis=1)
        rest = own.sum(axis=0)[None, :] - own                           # sum over u != o
        rest = np.minimum(rest, self._independence_bound()[self.observed][:, None])
        upper = np.minimum(h_o[:, None], own + rest) + BOUND_TOLERANCE
        return own - BOUND_TOLERANCE, upper

    def _independence_bound(self) -> np.ndarray:
        """B_o >= I(L_o ; L_{-o}), nats, per object (inf where no bound is known).

        An object with no pair factor (same-site and same-room weights 1 with every other
        object) depends on the others only through capacity: given them, its location is its
        unary u_o reweighted by w(a) in [penalty, 1], below 1 only at sites whose capacity can
        bind (S). With rho = u_o normalised, I(L_o ; L_{-o}) <= E KL(P(L_o | L_{-o}) || rho)
        <= -ln sum_a rho(a) w(a) <= -ln(1 - (1 - penalty) rho(S)).
        """
        sm = self.sm
        out = np.full(self.n, np.inf)
        if sm.penalty is None or not sm.capacity_binds.any():
            binding = 0.0
        else:
            binding = 1.0 - float(sm.penalty)
        for o in range(self.n):
            others = np.arange(self.n) != o
            if np.any(sm.same_site[o, others] != 1.0) or np.any(sm.same_room[o, others] != 1.0):
                continue
            u = sm.unary[o]
            share = float(u[sm.capacity_binds].sum() / u.sum()) if binding else 0.0
            if binding * share < 1.0:
                out[o] = -np.log1p(-binding * share)
        return out


__all__ = ["BOUND_TOLERANCE", "JointViewGain", "OUTCOME_LIMIT", "detection_table"]
