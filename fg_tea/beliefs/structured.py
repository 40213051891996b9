"""Exact location marginals of joint models by dynamic programming over subsets of objects.

Which question it answers: the same as dense enumeration of P(L_1, ..., L_N) — the partition
function, every single marginal q(L_o = j) and every pairwise marginal P(L_o = a, L_p = b) — for
joint models whose relational factors are all *site-local* or *room-local*, at a cost of about
K * 3^N instead of K^N (see docs/design.md §4.4).

The joint of a location block (docs/design.md eqs. (2)-(6) for the unary part; the whole is eq. (36)) is

    P(L) ∝ prod_o u_o(L_o) * prod_j cap_j(|S_j|) * prod_{a<b} psi_ab(L_a, L_b)

where u_o is the prior [2] times every detection [4] and miss [5, 6] of object o, S_j is the set of
objects at site j, cap_j(n) = penalty^max(0, n - c_j) is the site capacity factor and psi_ab is a
pair factor that depends only on whether a and b share a site (weight s_ab) or a room (weight
r_ab > 0) — exclusivity and co-location. Writing psi_ab = r_ab^[same room] (s_ab / r_ab)^[same site],
the joint factorises over which objects share a site and a room:

    P(L) ∝ prod_rooms rho(T_R) prod_{j in R} g_j(S_j),
    g_j(S) = cap_j(|S|) prod_{o in S} u_o(j) prod_{a<b in S} s_ab / r_ab,   rho(T) = prod_{a<b in T} r_ab,

with T_R the objects in room R. Every sum over arrangements is then a chain of *subset
convolutions* (F * G)(U) = sum_{A ⊔ B = U} F(A) G(B), evaluated over the 3^N ordered pairs of
disjoint subsets. Marginals come from "exclusion" products (everything but one site, or two sites,
or two rooms) — in the style of forward-backward — so that

    Z P(S_j = S)                  = g_j(S) D_j(S),
    Z P(S_a = S, S_b = S')        = g_a(S) g_b(S') E_ab(S ⊔ S')            (a, b in one room),
    Z P(T_R1 = T, T_R2 = T', ...) = ... O_R1R2(rest)                        (two rooms).

Numerics: every quantity is a sum of products of non-negative numbers — nothing is ever
subtracted, so there is no cancellation (the Möbius-transform form of subset convolution would
subtract and lose precision when many objects crowd few sites). As a guard, each object's single
marginals are summed over all sites through their own exclusion products and checked against the
separately computed partition function; a mismatch beyond 1e-9 raises
:class:`NumericalGuardError` so the engine can fall back to dense enumeration.

The max-product version of the same chain gives the most probable arrangement (MAP).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Sequence

import numpy as np

from fg_tea.common.errors import ContradictionError

MAX_OBJECTS = 11  # 3^11 = 177,147 disjoint pairs; memory grows as rows x 3^N
GUARD_TOLERANCE = 1e-9
REUSE_TOLERANCE = 1e-13  # relative: a room's unaries count as rescaled copies of the previous ones


class NumericalGuardError(ArithmeticError):
    """The structured solver's internal consistency check failed (do not trust its numbers)."""


@dataclass(frozen=True)
class SubsetIndex:
    """Index arrays over the 3^N ordered pairs (A, B) of disjoint subsets of N objects.

    Subsets are bit masks (bit o set = object o in the subset). Two orderings of the same pairs are
    kept: by union A | B (for convolutions) and by A (for "superset" sums over completions of A).

    Attributes:
        n: number of objects.
        a, b, union: the pairs sorted by union; ``starts`` are the first index of each union.
        xa, xb, xunion: the same pairs sorted by A; ``xstarts`` the first index of each A.
        members: (2^N, N) 0/1 float array, members[S, o] = [o in S].
        size: (2^N,) number of objects in each subset.
    """

    n: int
    a: np.ndarray
    b: np.ndarray
    union: np.ndarray
    starts: np.ndarray
    xa: np.ndarray
    xb: np.ndarray
    xunion: np.ndarray
    xstarts: np.ndarray
    members: np.ndarray
    size: np.ndarray

    @property
    def full(self) -> int:
        return (1 << self.n) - 1


@lru_cache(maxsize=16)
def subset_index(n: int) -> SubsetIndex:
    """The (cached) disjoint-pair index for `n` objects.

    Args:
        n: number of objects, 1 <= n <= MAX_OBJECTS.
    """
    if not 1 <= n <= MAX_OBJECTS:
        raise ValueError(f"the structured solver handles 1 to {MAX_OBJECTS} objects, not {n}")
    codes = np.arange(3 ** n)
    a = np.zeros(3 ** n, dtype=np.int64)
    b = np.zeros(3 ** n, dtype=np.int64)
    for o in range(n):
        digit = (codes // 3 ** o) % 3
        a |= (digit == 1).astype(np.int64) << o
        b |= (digit == 2).astype(np.int64) << o
    union = a | b
    order = np.argsort(union, kind="stable")
    xorder = np.argsort(a, kind="stable")
    masks = np.arange(1 << n)
    members = ((masks[:, None] >> np.arange(n)[None, :]) & 1).astype(float)
    return SubsetIndex(
        n=n,
        a=a[order], b=b[order], union=union[order],
        starts=np.searchsorted(union[order], masks),
        xa=a[xorder], xb=b[xorder], xunion=union[xorder],
        xstarts=np.searchsorted(a[xorder], masks),
        members=members,
        size=members.sum(axis=1).astype(np.int64),
    )


def subset_products(values: np.ndarray) -> np.ndarray:
    """prod_{o in S} values[o] for every subset S, by doubling (no logarithms, zeros allowed).

    Args:
        values: shape (N,) or (N, K).

    Returns:
        shape (2^N,) or (2^N, K).
    """
    values = np.asarray(values, dtype=float)
    out = np.ones((1,) + values.shape[1:])
    for o in range(values.shape[0]):
        out = np.concatenate([out, out * values[o]], axis=0)
    return out


def subset_pair_products(weights: np.ndarray) -> np.ndarray:
    """prod_{a<b in S} weights[a, b] for every subset S (weights symmetric, diagonal ignored)."""
    weights = np.asarray(weights, dtype=float)
    out = np.ones(1)
    for o in range(weights.shape[0]):
        row = subset_products(weights[o, :o]) if o else np.ones(1)
        out = np.concatenate([out, out * row])
    return out


class SubsetAlgebra:
    """Subset convolution and its relatives over one :class:`SubsetIndex` (no subtraction)."""

    def __init__(self, n: int) -> None:
        self.ix = subset_index(n)

    def delta(self) -> np.ndarray:
        """The unit of convolution: 1 on the empty set."""
        out = np.zeros(1 << self.ix.n)
        out[0] = 1.0
        return out

    def conv(self, f: np.ndarray, g: np.ndarray) -> np.ndarray:
        """(f * g)(U) = sum_{A ⊔ B = U} f(A) g(B); f, g broadcast over leading axes."""
        ix = self.ix
        return np.add.reduceat(f[..., ix.a] * g[..., ix.b], ix.starts, axis=-1)

    def completions(self, c: np.ndarray, w: np.ndarray) -> np.ndarray:
        """D(X) = sum_{B disjoint from X} c(B) w(X ⊔ B) — weight of completing X by c, scored by w."""
        ix = self.ix
        return np.add.reduceat(c[..., ix.xb] * w[..., ix.xunion], ix.xstarts, axis=-1)

    def conv_matrix(self, g: np.ndarray) -> np.ndarray:
        """M with f @ M = conv(f, g) for any rows f: M[A, U] = g(U minus A) if A ⊆ U else 0,
        shape (2^N, 2^N). One matrix product (BLAS) then replaces a batch of convolutions with
        one shared g."""
        ix = self.ix
        out = np.zeros((ix.full + 1, ix.full + 1))
        out[ix.a, ix.union] = g[ix.b]
        return out

    def completion_matrix(self, w: np.ndarray) -> np.ndarray:
        """M with c @ M = completions(c, w) for any rows c: M[B, X] = w(X ⊔ B) if B ∩ X = ∅,
        shape (2^N, 2^N)."""
        ix = self.ix
        out = np.zeros((ix.full + 1, ix.full + 1))
        out[ix.xb, ix.xa] = w[ix.xunion]
        return out

    def pair_sums(self, f: np.ndarray, g: np.ndarray, e: np.ndarray) -> np.ndarray:
        """M[r, s] = sum_{A ⊔ B disjoint} f[r, A] g[s, B] e(A ⊔ B); f (R, 2^N), g (S, 2^N)."""
        ix = self.ix
        return (f[:, ix.a] * e[ix.union]) @ g[:, ix.b].T

    def max_conv(self, f: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(f ⋆ g)(U) = max_{A ⊔ B = U} f(A) g(B), and the maximising B for every U."""
        ix = self.ix
        vals = f[ix.a] * g[ix.b]
        order = np.lexsort((vals, ix.union))  # by union, then value: the last of a run is its max
        last = np.append(ix.starts[1:], len(vals)) - 1
        best = order[last]
        return vals[best], ix.b[best]


@dataclass(frozen=True)
class PairWeights:
    """Site-local and room-local pair interactions between objects.

    Attributes:
        same_site: (N, N) symmetric, weight when a and b share a site (1 = no interaction).
        same_room: (N, N) symmetric, positive, weight when they share a room on different sites.
    """

    same_site: np.ndarray
    same_room: np.ndarray


class StructuredLocationModel:
    """Exact sums over arrangements of N objects on K sites with site/room-local factors.

    Args:
        unary: (N, K) non-negative unary weights u_o(j) (prior times evidence).
        rooms: room label of each site (length K).
        capacities: capacity of each site, None for unlimited (length K).
        penalty: capacity penalty per object beyond capacity, in [0, 1]; None = no capacity factor.
        pairs: pairwise same-site / same-room weights; None = no pair factors.
        previous: an earlier model of the same house, objects and pair weights (typically the
            belief before the last look). A room whose unaries equal the previous ones up to one
            factor c_o per object (a renormalised row; relative tolerance
            :data:`REUSE_TOLERANCE`) reuses its per-room products (prefix, suffix, exclusion),
            rescaled by prod_{o in S} c_o — exact, since every one is a sum over arrangements
            of the room's objects S. A look that changes one room's evidence thus recomputes
            that room only.
        site_weights: (K, 2^N) non-negative factors W_j(S) on which set S of objects stands at
            site j, multiplied into g_j (the coupled detection evidence of
            :class:`fg_tea.beliefs.occlusion.CompanyEvidence`); None = none.

    Raises:
        ValueError: more objects than :data:`MAX_OBJECTS` or a non-positive same-room weight.
    """

    def __init__(self, unary: np.ndarray, rooms: Sequence[str], capacities: Sequence[int | None],
                 penalty: float | None, pairs: PairWeights | None,
                 previous: "StructuredLocationModel | None" = None,
                 site_weights: np.ndarray | None = None) -> None:
        unary = np.asarray(unary, dtype=float)
        n, k = unary.shape
        self.n, self.k = n, k
        self.alg = SubsetAlgebra(n)
        ix = self.alg.ix
        same_site = np.ones((n, n)) if pairs is None else np.asarray(pairs.same_site, dtype=float)
        same_room = np.ones((n, n)) if pairs is None else np.asarray(pairs.same_room, dtype=float)
        if np.any(same_room <= 0):
            raise ValueError("the structured solver needs positive same-room weights")
        self.same_site, self.same_room = same_site, same_room         # (N, N) pair weights
        self.rho = subset_pair_products(same_room)                    # (2^N,)
        site_pairs = subset_pair_products(same_site / same_room)      # (2^N,)
        cap = np.ones((1 << n, k))
        self.penalty = penalty
        self.capacity_binds = np.zeros(k, dtype=bool)   # sites whose capacity factor is not 1
        if penalty is not None:
            for j, c in enumerate(capacities):
                if c is not None and c < n:
                    self.capacity_binds[j] = True
                    excess = np.maximum(ix.size - c, 0)
                    cap[:, j] = np.where(excess > 0, float(penalty) ** excess, 1.0)
        # g_j(S) for every site: capacity, unaries, and same-site pair corrections.
        self.unary = unary.copy()                      # the caller may change its array later
        self._cap_pairs = cap * site_pairs[:, None]
        if site_weights is not None:  # site-local evidence over who stands there (occlusion)
            self._cap_pairs = self._cap_pairs * np.asarray(site_weights, dtype=float).T
        self.g = (subset_products(unary) * self._cap_pairs).T             # (K, 2^N)
        room_names = list(dict.fromkeys(rooms))
        self.room_sites = [np.array([j for j in range(k) if rooms[j] == r]) for r in room_names]
        self.room_of = np.array([room_names.index(r) for r in rooms])
        self._done_singles = False
        self._same_rooms = self._unchanged_rooms(previous)
        self._previous = previous if any(x is not None for x in self._same_rooms) else None
        self._forward()
        self._previous_excl = None
        if self._previous is not None and self._previous._done_singles:
            self._previous_excl = self._previous._excl
        self._previous = None                              # keep no chain of earlier models

    def _unchanged_rooms(self, previous: "StructuredLocationModel | None") -> list[np.ndarray | None]:
        """For each room: prod_{o in S} c_o over subsets S (shape (2^N,)) when `previous` holds
        the same room with unaries u_o = c_o u'_o, else None."""
        rooms = len(self.room_sites)
        if (previous is None or previous.n != self.n or previous.k != self.k
                or len(previous.room_sites) != rooms
                or not np.array_equal(previous.room_of, self.room_of)
                or not np.array_equal(previous.rho, self.rho)
                or not np.array_equal(previous._cap_pairs, self._cap_pairs)):
            return [None] * rooms
        out: list[np.ndarray | None] = []
        for sites in self.room_sites:
            new, old = self.unary[:, sites], previous.unary[:, sites]
            if not np.array_equal(new > 0, old > 0):
                out.append(None)
                continue
            first = np.argmax(old > 0, axis=1)
            rows = np.arange(self.n)
            base = old[rows, first]
            scale = np.where(base > 0, new[rows, first] / np.where(base > 0, base, 1.0), 1.0)
            same = np.all(np.abs(new - scale[:, None] * old) <= REUSE_TOLERANCE * new)
            out.append(subset_products(scale) if same else None)
        return out

    # ------------------------------------------------------------------ partition function
    def _forward(self) -> None:
        alg = self.alg
        self.pre: list[list[np.ndarray]] = []   # per room: prefix products over its sites
        self.suf: list[list[np.ndarray]] = []
        h: list[np.ndarray] = []
        for r, sites in enumerate(self.room_sites):
            scale = self._same_rooms[r]
            if scale is not None:
                prev = self._previous
                assert prev is not None            # set whenever some room is unchanged
                self.pre.append([x * scale for x in prev.pre[r]])
                self.suf.append([x * scale for x in prev.suf[r]])
                h.append(prev.h[r] * scale)
                continue
            pre = [alg.delta()]
            for j in sites:
                pre.append(alg.conv(pre[-1], self.g[j]))
            suf = [alg.delta()]
            for j in sites[::-1]:
                suf.append(alg.conv(self.g[j], suf[-1]))
            self.pre.append(pre)
            self.suf.append(suf[::-1])
            h.append(self.rho * pre[-1])
        self.h: list[np.ndarray] = h
        rpre = [alg.delta()]
        for hr in h:
            rpre.append(alg.conv(rpre[-1], hr))
        rsuf = [alg.delta()]
        for hr in h[::-1]:
            rsuf.append(alg.conv(hr, rsuf[-1]))
        self.rpre, self.rsuf = rpre, rsuf[::-1]
        self.z = float(rpre[-1][self.alg.ix.full])
        if not np.isfinite(self.z) or self.z <= 0:
            raise ContradictionError("location evidence has probability zero under the model")

    def _outside(self, r: int) -> np.ndarray:
        """W_r(T) = rho(T) * (weight of placing every object not in T in the other rooms)."""
        full = self.alg.ix.full
        other = self.alg.conv(self.rpre[r], self.rsuf[r + 1])
        return self.rho * other[full ^ np.arange(full + 1)]

    def _room_exclusions(self, r: int) -> list[np.ndarray]:
        """C_{R minus j}: convolution of every site of room r except its t-th, for each t."""
        pre, suf = self.pre[r], self.suf[r]
        return [self.alg.conv(pre[t], suf[t + 1]) for t in range(len(self.room_sites[r]))]

    # ------------------------------------------------------------------ marginals
    def singles(self) -> np.ndarray:
        """q(L_o = j) for every object and site, shape (N, K); rows sum to 1 (checked)."""
        self._singles()
        return self._q.copy()

    def _singles(self) -> None:
        if self._done_singles:
            return
        alg, ix = self.alg, self.alg.ix
        q = np.zeros((self.n, self.k))
        same = np.zeros((self.k, self.n, self.n))
        self._w, self._excl, self._m = [], [], {}
        for r, sites in enumerate(self.room_sites):
            w = self._outside(r)
            if self._same_rooms[r] is not None and self._previous_excl is not None:
                excl = [x * self._same_rooms[r] for x in self._previous_excl[r]]
            else:
                excl = self._room_exclusions(r)
            self._w.append(w)
            self._excl.append(excl)
            done = alg.completions(np.stack(excl), w)     # every site of the room in one call
            for t, j in enumerate(sites):
                m = self.g[j] * done[t] / self.z                    # P(S_j = S)
                self._m[int(j)] = m
                q[:, j] = m @ ix.members
                same[j] = (ix.members * m[:, None]).T @ ix.members
        self._previous_excl = None
        total = q.sum(axis=1)
        if not np.all(np.abs(total - 1.0) <= GUARD_TOLERANCE):
            raise NumericalGuardError(f"structured marginals sum to {total} instead of 1")
        self._q = q / total[:, None]
        self._same = same
        self._done_singles = True

    def pairwise(self) -> np.ndarray:
        """P(L_o = a, L_p = b), shape (N, N, K, K); the diagonal blocks are diag(q_o)."""
        self._singles()
        alg, ix = self.alg, self.alg.ix
        n, k = self.n, self.k
        full = ix.full
        out = np.zeros((n, n, k, k))
        mem = ix.members.T                                            # (N, 2^N)
        for j in range(k):
            out[:, :, j, j] = self._same[j]
        # Two sites of one room: E_ab = completions of (all other sites of the room) by W_R.
        for r, sites in enumerate(self.room_sites):
            pre, suf, w = self.pre[r], self.suf[r], self._w[r]
            for ta in range(len(sites)):
                before = pre[ta]                                      # sites before a
                for tb in range(ta + 1, len(sites)):
                    rest = alg.conv(before, suf[tb + 1])
                    e = alg.completions(rest, w)
                    block = alg.pair_sums(mem * self.g[sites[ta]], mem * self.g[sites[tb]], e)
                    out[:, :, sites[ta], sites[tb]] = block / self.z
                    out[:, :, sites[tb], sites[ta]] = block.T / self.z
                    before = alg.conv(before, self.g[sites[tb]])     # sites before a, and a..b
        # Two rooms: each room's weight split by where object o stands inside it.
        split = []
        for r, sites in enumerate(self.room_sites):
            rows = [self.rho * alg.conv(mem * self.g[j], self._excl[r][t]) for t, j in enumerate(sites)]
            split.append(np.concatenate(rows))                        # (len(sites) * N, 2^N)
        comp = full ^ np.arange(full + 1)
        for r1 in range(len(self.room_sites)):
            between = self.rpre[r1]                                   # rooms before r1
            for r2 in range(r1 + 1, len(self.room_sites)):
                outside = alg.conv(between, self.rsuf[r2 + 1])[comp]  # O(full minus X)
                block = alg.pair_sums(split[r1], split[r2], outside) / self.z
                s1, s2 = self.room_sites[r1], self.room_sites[r2]
                block = block.reshape(len(s1), n, len(s2), n)
                out[:, :, s1[:, None], s2[None, :]] = block.transpose(1, 3, 0, 2)
                out[:, :, s2[:, None], s1[None, :]] = block.transpose(3, 1, 2, 0)
                between = alg.conv(between, self.h[r2])
        for o in range(n):
            out[o, o] = np.diag(self._q[o])
        return out

    # ------------------------------------------------------------------ reweighted batches
    def reweighted(self, weights: np.ndarray, singles: bool = True,
                   chunk: int | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        """The model's sums with extra per-object weights, for a batch of weight sets.

        Weight set b multiplies every unary: u_o(j) -> u_o(j) w_b[o, j], the other factors
        unchanged. With w_b a likelihood prod_o w_b[o, L_o] (a hypothetical look's outcome, or
        the chance that a search is over), ratio_b = Z_b / Z is its probability under the
        model, E[prod_o w_b[o, L_o]], and q_b its posterior marginals: the same chain of subset
        convolutions as the model's own (docs/design.md §4.4), with the batch on a leading axis.

        Args:
            weights: shape (B, N, K), non-negative.
            singles: also compute the marginals (forward and backward passes; else forward only).
            chunk: weight sets per pass (default: as many as hold about 2^22 floats of site
                products; the backward pass keeps about twice that).

        Returns:
            (ratio, q): shape (B,), and (B, N, K) with rows summing to 1 (None without
            `singles`; a weight set of probability 0 gets zero rows).
        """
        w = np.asarray(weights, dtype=float)
        if w.ndim != 3 or w.shape[1:] != (self.n, self.k):
            raise ValueError(f"reweighted: weights must have shape (B, {self.n}, {self.k}), got {w.shape}")
        if chunk is None:
            chunk = max(1, (1 << 22) // (self.k << self.n))
        if len(w) > chunk:
            parts = [self.reweighted(w[i:i + chunk], singles, chunk) for i in range(0, len(w), chunk)]
            ratio = np.concatenate([r for r, _ in parts])
            return ratio, (np.concatenate([q for _, q in parts]) if singles else None)
        ix = self.alg.ix
        count, size = len(w), ix.full + 1
        # Subset-major layout, (2^N, B): the gathers then move whole rows of the batch (several
        # times faster than (B, 2^N) for large batches; the same sums in the same order).

        def conv(f: np.ndarray, g: np.ndarray) -> np.ndarray:
            return np.add.reduceat(f[ix.a] * g[ix.b], ix.starts, axis=0)

        delta = np.zeros((size, count))
        delta[0] = 1.0
        rho = self.rho[:, None]
        # g_j(S) for every site, set and batch member: subset products of the reweighted unaries.
        g = subset_products(np.moveaxis(self.unary[None] * w, 1, 0))           # (2^N, B, K)
        g = np.moveaxis(g * self._cap_pairs[:, None, :], 2, 0)                   # (K, 2^N, B)
        pres, h = [], []
        for sites in self.room_sites:
            pre = [delta]
            for j in sites:
                pre.append(conv(pre[-1], g[j]))
            pres.append(pre)
            h.append(rho * pre[-1])
        rpre = [delta]
        for hr in h:
            rpre.append(conv(rpre[-1], hr))
        z = rpre[-1][ix.full]
        ratio = z / self.z
        if not singles:
            return ratio, None
        rsuf = [delta]
        for hr in h[::-1]:
            rsuf.append(conv(hr, rsuf[-1]))
        rsuf = rsuf[::-1]
        comp = ix.full ^ np.arange(size)
        inverse = 1.0 / np.where(z > 0, z, 1.0)
        members = ix.members.T                                                  # (N, 2^N)
        q = np.zeros((count, self.n, self.k))
        for r, sites in enumerate(self.room_sites):
            outside = rho * conv(rpre[r], rsuf[r + 1])[comp]                    # (2^N, B)
            suf = [delta]
            for j in sites[::-1]:
                suf.append(conv(g[j], suf[-1]))
            suf = suf[::-1]
            excl = np.stack([conv(pres[r][t], suf[t + 1]) for t in range(len(sites))], axis=1)
            done = np.add.reduceat(excl[ix.xb] * outside[ix.xunion][:, None, :], ix.xstarts,
                                   axis=0)                                      # (2^N, T, B)
            for t, j in enumerate(sites):
                q[:, :, j] = (members @ (g[j] * done[:, t])).T * inverse[:, None]
        q[z <= 0] = 0.0
        return ratio, q

    # ------------------------------------------------------------------ most probable arrangement
    def map_assignment(self) -> np.ndarray:
        """The most probable site of every object (max-product over the same chain), shape (N,)."""
        alg, ix = self.alg, self.alg.ix
        room_best, room_arg = [], []
        for sites in self.room_sites:
            f, args = alg.delta(), []
            for j in sites:
                f, arg = alg.max_conv(f, self.g[j])
                args.append(arg)
            room_best.append(self.rho * f)
            room_arg.append(args)
        f, args = alg.delta(), []
        for hr in room_best:
            f, arg = alg.max_conv(f, hr)
            args.append(arg)
        if not f[ix.full] > 0:
            raise ContradictionError("location evidence has probability zero under the model")
        site = np.full(self.n, -1)
        u = ix.full
        for r in range(len(self.room_sites) - 1, -1, -1):
            t_room = int(args[r][u])
            u ^= t_room
            v = t_room
            for t in range(len(self.room_sites[r]) - 1, -1, -1):
                s = int(room_arg[r][t][v])
                site[ix.members[s] > 0] = self.room_sites[r][t]
                v ^= s
        return site


__all__ = ["MAX_OBJECTS", "NumericalGuardError", "PairWeights", "StructuredLocationModel",
           "SubsetAlgebra", "subset_index", "subset_pair_products", "subset_products"]
