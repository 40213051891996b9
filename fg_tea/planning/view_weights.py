"""The weights of a look's classes for joint beliefs: W_{v,o,a} of every room, from the subset
dynamic program (docs/design.md §4.4, §6.2, eqs. 44-45).

:class:`ViewWeights` holds, for one decision, the per-room subset convolutions a look's class
probabilities are made of: C_D of the out-of-view sites of the look's room, O_R of every other
room, and W_{v,o,a} with object o moved to out-of-view site a. :class:`~fg_tea.planning.joint_gain.
JointViewGain` turns them into outcome tables and mutual information; the two are split by what
each computes (weights here, outcomes and gains there).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Sequence

import numpy as np

from fg_tea.beliefs.structured import (
    StructuredLocationModel,
    SubsetAlgebra,
    subset_index,
)

MATRIX_OBJECTS = 9       # up to this many objects, batches of subset convolutions with one
                         # shared operand run as one dense 2^N x 2^N matrix product (BLAS): 4^N
                         # multiplications instead of 3^N gathered ones, faster up to about N = 9


@dataclass(frozen=True)
class _Reduced:
    """Index arrays over the 3^(N-1) disjoint pairs (A, B) of subsets of the N - 1 objects other
    than o, for every o, in full masks (see JointViewGain.red): a_with = A ∪ o, b = B; with_o =
    each set without o, plus o; red = the sets without o; flat = A * 2^(N-1) + (A ∪ B), the
    position of the pair in a flattened 2^(N-1)-square convolution matrix; flip = complement
    within the N - 1 objects."""

    a_with: np.ndarray   # (N, 3^(N-1))
    b: np.ndarray        # (N, 3^(N-1))
    with_o: np.ndarray   # (N, 2^(N-1))
    red: np.ndarray      # (N, 2^(N-1))
    flat: np.ndarray     # (3^(N-1),)
    flip: np.ndarray     # (2^(N-1),)


@lru_cache(maxsize=16)
def _reduced_positions(n: int) -> _Reduced:
    ix = subset_index(n - 1)
    half = 1 << (n - 1)
    low = np.arange(half)
    red = np.stack([((low >> o) << (o + 1)) | (low & ((1 << o) - 1)) for o in range(n)])
    bits = (1 << np.arange(n))[:, None]
    out = _Reduced(red[:, ix.a] | bits, red[:, ix.b], red | bits, red, ix.a * half + ix.union,
                   (half - 1) ^ low)
    for x in (out.a_with, out.b, out.with_o, out.red, out.flat, out.flip):
        x.setflags(write=False)
    return out


class ViewWeights:
    """The room weights of one decision's looks (module docstring); the base of
    :class:`~fg_tea.planning.joint_gain.JointViewGain`.

    Args:
        model: the structured location model of the current belief (forward pass done).
        observed: belief indices of the unresolved objects whose outcome a look reports.
        fp: false-positive rate per in-view site.
        coupling: how strongly each pair of objects is coupled (for choosing tracked sets).
    """

    def __init__(self, model: StructuredLocationModel, observed: Sequence[int], fp: float,
                 coupling: np.ndarray | None = None) -> None:
        self.sm = model
        self.observed = [int(u) for u in observed]
        if len(set(self.observed)) != len(self.observed):
            raise ValueError(f"observed objects repeated: {self.observed}")
        self.fp = float(fp)
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
        # W_{v,o,a}(T) is 0 whenever o is in T (o stands out of view), so it is kept "reduced":
        # red[o] lists the 2^(N-1) sets without o in increasing order, W[a, o, i] = W(red[o][i]).
        low = np.arange(1 << (n - 1))
        self.red = np.stack([((low >> o) << (o + 1)) | (low & ((1 << o) - 1)) for o in range(n)])
        self._split: dict[int, np.ndarray] = {}
        self._out: dict[int, np.ndarray] = {}
        self._close: dict[int, dict] = {}

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
        for a outside r0 (rows of r0's sites are 0), on the sets T without o (reduced, see red),
        shape (K, N, 2^(N-1))."""
        cached = self._out.get(r0)
        if cached is None:
            if 2 <= self.n <= MATRIX_OBJECTS:
                self._out.update(self._room_out_all())
            else:
                self._out[r0] = self._reduce(self._room_out_full(r0))
            cached = self._out[r0]
        return cached

    def _room_out_all(self) -> dict[int, np.ndarray]:
        """_room_out for every room at once, on the sets without o throughout: for a in room r,
        Out[a, o](T) = rho(T) (split_{a,o} * E_{r0 r})(complement of T), with E_{r0 r} the
        convolution of every room but r0 and r. split_{a,o} lives on sets with o and the
        complement of T contains o, so each object's part is a 2^(N-1)-square problem. E_{r0 r}
        = E_{r r0} serves both rooms of the pair: one matrix per (pair of rooms, object), the
        splits of both rooms' sites as its rows, the matrices of all objects in one reused
        buffer (about 2^(2N-1) numbers, a core's cache at N = 8) and one batched product."""
        sm, alg = self.sm, self.alg
        n, half = self.n, 1 << (self.n - 1)
        ix = subset_index(n - 1)
        rooms = len(sm.room_sites)
        pos = _reduced_positions(n)
        out = {r0: np.zeros((self.k, n, half)) for r0 in range(rooms)}
        # split_{a,o}(Y ∪ o) = rho(Y ∪ o) sum_{B ⊔ Y' = Y} g_a(B ∪ o) C_{R∖a}(Y'), every o at once
        split = []
        for r in range(rooms):
            sites = sm.room_sites[r]
            c_rest = np.stack(sm._excl[r])                                  # C_{R∖a}, (L, 2^N)
            prods = sm.g[sites][:, pos.a_with] * c_rest[:, pos.b]           # (L, N, 3^(N-1))
            split.append(np.add.reduceat(prods, ix.starts, axis=2) * sm.rho[pos.with_o])
        mats = np.zeros((n, half * half))          # the same nonzeros for every pair: zeroed once
        rho_red = sm.rho[pos.red]                                           # (N, 2^(N-1))
        for r0 in range(rooms - 1):                # E_{r0 r}: rooms before r0, between, after r
            accs = [sm.rpre[r0]]
            for r in range(r0 + 1, rooms - 1):
                accs.append(alg.conv(accs[-1], sm.h[r]))
            excl = alg.conv(np.stack(accs), np.stack([sm.rsuf[r + 1] for r in range(r0 + 1, rooms)]))
            s0 = sm.room_sites[r0]
            for x, r in enumerate(range(r0 + 1, rooms)):
                s1 = sm.room_sites[r]
                mats[:, pos.flat] = excl[x][pos.b]
                rows = np.concatenate([split[r], split[r0]]).transpose(1, 0, 2)   # (N, L1 + L0, .)
                res = np.matmul(rows, mats.reshape(n, half, half))[:, :, pos.flip] * rho_red[:, None]
                out[r0][s1] = res[:, :len(s1)].transpose(1, 0, 2)
                out[r][s0] = res[:, len(s1):].transpose(1, 0, 2)
        return out

    def _room_out_full(self, r0: int) -> np.ndarray:
        """_room_out on all sets, shape (K, N, 2^N) (for N = 1 or above MATRIX_OBJECTS)."""
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
            split = self._room_split(r)
            if self.n <= MATRIX_OBJECTS:                     # one matrix product (BLAS)
                oa[sm.room_sites[r]] = split @ alg.conv_matrix(excl)
            else:
                oa[sm.room_sites[r]] = alg.conv(split, excl)
        return sm.rho * oa[:, :, self.comp]

    def _close_weights(self, r0: int, wanted: Sequence[int] | None = None
                       ) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """W_v and W_{v,o,a} of the close looks at the `wanted` sites of room r0 (default: every
        site of the room), see _view_weights; cached per site, so a later call computes only
        the sites not yet asked for. Each site's weights are computed the same way whichever
        other sites are asked for with it."""
        cached = self._close.setdefault(r0, {})
        sm, alg = self.sm, self.alg
        room = [int(j) for j in sm.room_sites[r0]]
        want = set(room if wanted is None else (int(j) for j in wanted))
        sel = [t for t, j in enumerate(room) if j in want and j not in cached]
        if not sel:
            return cached
        excl = np.stack([sm._excl[r0][t] for t in sel])       # C_{R∖j} for each j, (L', 2^N)
        w_room = sm._w[r0]
        out = self._room_out(r0)
        w_v = alg.completions(excl, w_room)                   # (L', 2^N)
        outside = np.array([a for a in range(self.k) if int(sm.room_of[a]) != r0], dtype=int)
        w_oa = np.zeros((len(sel), self.k, self.n, self.red.shape[1]))
        if len(outside):
            w_oa[:, outside] = self._completions_without_o(excl, out[outside])
        # o at another site a of the same room: W_{v,o,a}(T) = sum_{B ∋ o, B disjoint T}
        # g_a(B) D_{ja}(T ⊔ B) with D_{ja} = completions(C_{R∖{j,a}}, W_R) (completing by a
        # convolution is completing by each factor in turn), for the sets T without o.
        # C_{R∖{j,a}} for every pair with j asked for, from the room's prefix and suffix
        # products (the sites before the earlier of j and a, those between them, those after
        # the later one).
        n_s = len(room)
        pre, suf = sm.pre[r0], sm.suf[r0]
        chosen = set(sel)
        c_pair: dict[tuple[int, int], np.ndarray] = {}
        for ti in range(n_s - 1):
            last = n_s - 1 if ti in chosen else max((t for t in chosen if t > ti), default=ti)
            if last <= ti:
                continue
            accs = [pre[ti]]
            for ta in range(ti + 1, last):
                accs.append(alg.conv(accs[-1], sm.g[room[ta]]))
            both = alg.conv(np.stack(accs), np.stack([suf[ta + 1] for ta in range(ti + 1, last + 1)]))
            for x, ta in enumerate(range(ti + 1, last + 1)):
                c_pair[(ti, ta)] = c_pair[(ta, ti)] = both[x]
        pairs = [(x, room[ta]) for x, t in enumerate(sel) for ta in range(n_s) if ta != t]
        if pairs:
            c_rest = np.stack([c_pair[(t, ta)] for t in sel for ta in range(n_s) if ta != t])
            if self.n <= MATRIX_OBJECTS:
                d = c_rest @ alg.completion_matrix(w_room)
            else:
                d = alg.completions(c_rest, w_room)
            t_idx = np.array([p[0] for p in pairs])
            a_idx = np.array([p[1] for p in pairs])
            w_oa[t_idx, a_idx] = self._place_o(sm.g[a_idx], d)
        for x, t in enumerate(sel):
            cached[room[t]] = (w_v[x], w_oa[x])
        return cached

    def _place_o(self, g: np.ndarray, d: np.ndarray) -> np.ndarray:
        """out[p, o, i] = sum_{B ∋ o, B disjoint T} g[p, B] d[p, T ⊔ B] for T = red[o][i] (the sets
        without o), shape (P, N, 2^(N-1)): o placed on the site of g, the rest completed by d."""
        n = self.n
        out = np.zeros((g.shape[0], n, self.red.shape[1]))
        if n == 1:
            out[:, 0, 0] = g[:, 1] * d[:, 1]
            return out
        ix = subset_index(n - 1)
        for o in range(n):
            expand = self.red[o]                                           # reduced -> full mask
            prods = g[:, expand[ix.xb] | (1 << o)] * d[:, expand[ix.xunion] | (1 << o)]
            out[:, o] = np.add.reduceat(prods, ix.xstarts, axis=1)
        return out

    def _completions_without_o(self, c: np.ndarray, w: np.ndarray) -> np.ndarray:
        """completions(c[l], w[a, o]) on the sets without o (w and the result reduced, see red),
        for every l, a, o, shape (L, A, N, 2^(N-1)), using that
        w[a, o](T) = 0 whenever o is in T (o stands outside): only sets without o take part, as
        one matrix product per object over the 2^(N-1) such sets."""
        n, alg = self.n, self.alg
        if n == 1:                                    # only the empty set: c(empty) w(empty)
            return c[:, None, None, :1] * w[None]
        ix = subset_index(n - 1)
        out = np.zeros((c.shape[0],) + w.shape[:2] + (1 << (n - 1),))
        half = self.red.shape[1]                            # 2^(N-1) sets without o
        mat = np.zeros((half, c.shape[0], half))           # one product for every l; the same
        for o in range(n):                                 # nonzeros for every o
            expand = self.red[o]                                           # reduced -> full mask
            mat[ix.xunion, :, ix.xa] = c[:, expand[ix.xb]].T
            res = w[:, o] @ mat.reshape(half, -1)                   # (A, L * 2^(N-1))
            out[:, :, o] = res.reshape(w.shape[0], c.shape[0], -1).transpose(1, 0, 2)
        return out

    def _view_weights(self, sites: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """W_v(T), shape (2^N,), and W_{v,o,a}(T) on the sets T without o, shape (K, N, 2^(N-1))
        (reduced, see red; 0 for a in view)."""
        sm, alg = self.sm, self.alg
        rooms = {int(sm.room_of[j]) for j in sites}
        if len(rooms) != 1:
            raise ValueError("the structured gain needs every in-view site in one room")
        r0 = rooms.pop()
        in_view = set(int(j) for j in sites)
        rest = [int(j) for j in sm.room_sites[r0] if int(j) not in in_view]
        if not rest:                                           # a glance over the whole room
            return sm._w[r0], self._room_out(r0)
        if len(sites) == 1:
            return self._close_weights(r0, [int(sites[0])])[int(sites[0])]
        pre = [alg.delta()]
        for j in rest:
            pre.append(alg.conv(pre[-1], sm.g[j]))
        suf = [alg.delta()]
        for j in rest[::-1]:
            suf.append(alg.conv(sm.g[j], suf[-1]))
        suf = suf[::-1]
        w_room = sm._w[r0]
        c_d = pre[-1]
        w_v = alg.completions(c_d, w_room)
        w_oa = self._completions_without_o(c_d[None], self._room_out(r0))[0]
        for i, a in enumerate(rest):
            c_oa = alg.conv(self.mem * sm.g[a], alg.conv(pre[i], suf[i + 1]))   # (N, 2^N)
            w_oa[a] = self._reduce(alg.completions(c_oa, w_room))
        return w_v, w_oa

    def _reduce(self, w: np.ndarray) -> np.ndarray:
        """W over all sets (..., N, 2^N) -> over the sets without each o (..., N, 2^(N-1))."""
        return np.take_along_axis(w, np.broadcast_to(self.red, w.shape[:-1] + self.red.shape[1:]),
                                  axis=-1)
