"""Detection probabilities that know the turn tolerance and what shares a site (docs/design.md §3.4,
"Facing and company").

The expected detection probability of eq. (33) imagines an object standing *alone* at one of its
site's slots, seen from a viewpoint facing the site exactly. Two things make real looks differ:

- **Facing.** A look ends within the turn tolerance of facing its site, not exactly on it. With
  ``[perception] facing_tolerance = true`` the probability at a slot is the mean of the curve over
  the heading offsets of the environment's company table (the midpoints of equal bins of the
  tolerance), an average of probabilities as in eq. (33).
- **Company.** Objects on the same site take its first free slots in the order they came and can
  stand in front of one another. With ``[perception] occlusion = true`` the probability of seeing o
  at j is conditioned on the set M of the other objects standing at j:

      p_o(j, v | M) = mean over arrival orders of o and M (each order equally likely; the i-th
                      arrival takes slot i) and heading offsets h of
                      P_c(o)(seen | n(c(o), s_o, h) * prod_{o' in M} r(c(o), s_o | c(o'), s_o'))

  where n(c, s, h) is the category alone at slot s and heading offset h, and r(c, s | c', s') the
  share of those pixels left when an object of category c' stands at slot s' (rendered pairs,
  facing exactly, at most 1). Three or more objects on a site multiply their pairs' shares.

The planner and the give-up rule use the probability *under the belief* (eq. 60): for object o at
site j, the mean of p_o(j, v | M) weighted by the belief's probability of each companion set given
that o is at j, taking the other objects' presence at j as independent given o there.

The exact likelihood of a look couples the objects' locations (a miss of the teabag on the counter
is likelier when the kettle stands there); it factorises over the sites in view into site-local
factors over which objects stand there (:func:`look_weights`). A joint belief keeps them exactly
(:class:`CompanyEvidence`, multiplied into the dense joint and the subset program); a factorised
belief absorbs each object's miss with 1 - p̄, object by object, which is the approximation
``experiments/occlusion_error.py`` measures against :func:`coupled_likelihood`.

Nothing here imports a simulator: the counts arrive as numbers.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Mapping, Sequence

import numpy as np

from fg_tea.world.visibility import VisibilityCurve

#: Smallest unary miss factor of a coupled look (see :func:`alone_miss`).
ALONE_FLOOR = 1e-300
#: A row of :class:`CompanyEvidence` weights is rescaled to a maximum of 1 above this.
RESCALE_ABOVE = 1e250
#: The company table handed over by an environment: {"offsets_deg": [...], "views": viewpoint ->
#: site -> {"facing": category -> [[px per heading] per slot], "company": "c|c2" -> [[px] ...]}}.
CompanyTable = Mapping[str, Any]


def curve_values(curve: VisibilityCurve, category: str, pixels: np.ndarray) -> np.ndarray:
    """The curve of `category` at every entry of `pixels` (0 where no pixel is covered)."""
    c = curve.params(category)
    n = np.asarray(pixels, dtype=float)
    out = np.zeros(n.shape)
    pos = n > 0.0
    z = np.minimum(c.slope * (np.log(c.half_pixels) - np.log(n[pos])), 700.0)
    out[pos] = curve.max_probability / (1.0 + np.exp(z))
    return out


@lru_cache(maxsize=64)
def _orders(companions: int, slots: int) -> np.ndarray:
    """Slots of (o, companion 1, ...) in every arrival order, shape (orders, companions + 1); the
    i-th arrival takes slot i, clipped to the site's last slot."""
    rows = [tuple(min(i, slots - 1) for i in perm)
            for perm in itertools.permutations(range(companions + 1))]
    return np.array(rows, dtype=np.int64).reshape(len(rows), companions + 1)


def slot_probability(curve: VisibilityCurve, category: str, facing: np.ndarray) -> float:
    """Mean of the curve over heading offsets and slots of one site's facing counts (shape
    (slots, headings)): eq. (33) with the turn tolerance averaged in."""
    return float(curve_values(curve, category, facing).mean())


def company_probability(curve: VisibilityCurve, category: str, facing: np.ndarray,
                        shares: Sequence[np.ndarray]) -> float:
    """p_o(j, v | M) for one object of `category` with companions whose share matrices are
    `shares` (each (slots, slots): share of o's pixels left at o's slot s when the companion
    stands at s2), `facing` the object's (slots, headings) counts alone."""
    n_slots = facing.shape[0]
    orders = _orders(len(shares), n_slots)
    own = orders[:, 0]
    factor = np.ones(len(orders))
    for i, share in enumerate(shares):
        other = orders[:, i + 1]
        factor *= np.where(own == other, 1.0, share[own, np.minimum(other, n_slots - 1)])
    pixels = facing[own] * factor[:, None]
    return float(curve_values(curve, category, pixels).mean())


def share_matrix(company: Sequence[Sequence[float | None]], alone: Sequence[float]) -> np.ndarray:
    """r(c, s | c2, s2): pixels with the companion over pixels alone (facing exactly), in [0, 1];
    1 where the object alone covers nothing or the two slots coincide."""
    n = len(alone)
    out = np.ones((n, n))
    for s in range(n):
        for s2 in range(n):
            value = company[s][s2]
            if s != s2 and value is not None and alone[s] > 0:
                out[s, s2] = min(1.0, float(value) / float(alone[s]))
    return out


class CompanyModel:
    """p_o(j, v | M) for every viewpoint, in-view site, object and companion set.

    Args:
        categories: the category of each object, in belief order.
        curve: the agent's assumed visibility curve.
        views: (viewpoint name, in-view site names) in the order of the view model.
        table: an environment's company table (:data:`CompanyTable`).
        alone: viewpoint -> site -> category -> pixels alone at each slot, facing exactly
            (the expected pixel table), the denominators of the shares.
        occlusion: condition on the companions (else only the facing average, over the site's
            slots taken as equally likely, as eq. (33)).

    Raises:
        ValueError: the table lacks a viewpoint, site, category or pair.
    """

    def __init__(self, categories: Sequence[str], curve: VisibilityCurve,
                 views: Sequence[tuple[str, Sequence[str]]], table: CompanyTable,
                 alone: Mapping[str, Mapping[str, Mapping[str, Any]]], occlusion: bool) -> None:
        self.n = len(categories)
        self.occlusion = occlusion
        #: viewpoint -> (objects, in-view sites, 2^N companion masks) probabilities; a mask
        #: holding the object itself is unused (0).
        self.tables: dict[str, np.ndarray] = {}
        views_table = table.get("views", {})
        for name, sites in views:
            out = np.zeros((self.n, len(sites), 1 << self.n if occlusion else 1))
            entry = views_table.get(name)
            if entry is None:
                raise ValueError(f"no company pixel counts for viewpoint {name!r}")
            for c, site in enumerate(sites):
                try:
                    cell = entry[site]
                    facing = {k: np.asarray(v, dtype=float) for k, v in cell["facing"].items()}
                except (KeyError, TypeError):
                    raise ValueError(f"no company pixel counts for site {site!r} from viewpoint "
                                     f"{name!r}") from None
                for o, cat in enumerate(categories):
                    if cat not in facing:
                        raise ValueError(f"no company pixel count for category {cat!r} at site "
                                         f"{site!r} from viewpoint {name!r}")
                    if not occlusion:
                        out[o, c, 0] = slot_probability(curve, cat, facing[cat])
                        continue
                    shares = {}
                    for o2, cat2 in enumerate(categories):
                        if o2 == o:
                            continue
                        rows = cell["company"].get(f"{cat}|{cat2}")
                        if rows is None:
                            raise ValueError(f"no company pixel counts for {cat!r} beside {cat2!r} "
                                             f"at site {site!r} from viewpoint {name!r}")
                        shares[o2] = share_matrix(rows, [float(x) for x in np.atleast_1d(alone[name][site][cat])])
                    for mask in range(1 << self.n):
                        if mask >> o & 1:
                            continue
                        members = [shares[o2] for o2 in range(self.n) if mask >> o2 & 1]
                        out[o, c, mask] = company_probability(curve, cat, facing[cat], members)
            self.tables[name] = out

    def expected(self, name: str, sites: Sequence[int], together: np.ndarray,
                 table: np.ndarray | None = None) -> np.ndarray:
        """p̄_{o,j}: the probabilities of viewpoint `name` under a belief, shape (N, in-view sites).

        Args:
            sites: belief indices of the in-view sites.
            together: (N, N, K) with together[o, o2, j] = P(o2 at j | o at j) under the belief.
            table: the conditional table to weigh (default the viewpoint's own; see
                :func:`fixed_companions`).
        """
        table = self.tables[name] if table is None else table
        if not self.occlusion:
            return table[:, :, 0].copy()
        n = self.n
        bits = (np.arange(1 << n)[:, None] >> np.arange(n)[None, :]) & 1 == 1  # (masks, N)
        p = np.transpose(together[:, :, list(sites)], (0, 2, 1))[:, :, None, :]  # (N, C, 1, N)
        factors = np.where(bits[None, None], p, 1.0 - p)  # (N, C, masks, N)
        factors[np.arange(n), :, :, np.arange(n)] = 1.0  # o's own bit carries no weight
        weight = factors.prod(axis=3)
        weight[bits.T[:, None, :].repeat(len(sites), axis=1)] = 0.0  # masks holding o itself
        return np.einsum("ocm,ocm->oc", weight, table)


def coupled_likelihood(conditional: np.ndarray, sites: Sequence[int], k: int,
                       found: Mapping[int, int | None], false_positive: float) -> np.ndarray:
    """P(observation | L_1, ..., L_N) of one look under the company model, shape (K,) * N: the
    exact coupled likelihood that the belief update approximates object by object.

    Args:
        conditional: (N, in-view sites, 2^N) p_o(j, v | M) of the viewpoint
            (:attr:`CompanyModel.tables`).
        sites: belief indices of the in-view sites, in the table's column order.
        k: number of sites.
        found: object index -> the site index it was seen at, or None (looked, not seen);
            objects left out are no observation.
        false_positive: P(seen at j | the object stands elsewhere), eq. (31).
    """
    n = conditional.shape[0]
    masks = site_masks(n, k, sites)
    out = np.ones((k,) * n)
    for o, seen_at in found.items():
        factor = np.ones((k,) * n) if seen_at is None else np.full((k,) * n, float(false_positive))
        for c, j in enumerate(sites):
            here = masks[c] >> o & 1 == 1
            p = conditional[o, c][masks[c] & ~(1 << o)]
            if seen_at is None:
                factor = np.where(here, 1.0 - p, factor)
            elif j == seen_at:
                factor = np.where(here, p, factor)
        out *= factor
    return out


def site_masks(n: int, k: int, sites: Sequence[int]) -> list[np.ndarray]:
    """For each site j of `sites`, the bit mask of the objects standing at j in every joint
    placement, shape (K,) * N (bit o set when L_o = j)."""
    axes = [np.arange(k).reshape([k if a == o else 1 for a in range(n)]) for o in range(n)]
    return [np.broadcast_to(sum((axes[o] == j).astype(np.int64) << o for o in range(n)), (k,) * n)
            for j in sites]


def look_weights(conditional: np.ndarray, sites: Sequence[int],
                 found: Mapping[int, int | None]) -> np.ndarray:
    """The site-local factors of one look beyond its unary part, shape (in-view sites, 2^N).

    The likelihood of a look, for the c-th in-view site j and a set S of objects standing there,
    is the product over the objects o in S the look considered of 1 - p_o(j, v | S minus o) if it
    missed o, or p_o(j, v | S minus o) if it saw o at j (an o seen elsewhere cannot be at j; its
    unary factor says so). A miss's part that does not depend on the company, 1 - p_o(j, v | {}),
    is the unary miss factor the engine keeps in log space (exact however many misses); this
    returns the rest: (1 - p_o(j | S minus o)) / (1 - p_o(j | {})) for a miss, p_o(j | S minus o)
    for a detection."""
    n = conditional.shape[0]
    masks = np.arange(1 << n)
    out = np.ones((len(sites), 1 << n))
    for o, seen_at in found.items():
        has = masks >> o & 1 == 1
        for c, j in enumerate(sites):
            p = conditional[o, c][masks & ~(1 << o)]
            if seen_at is None:
                alone = max(1.0 - float(conditional[o, c, 0]), ALONE_FLOOR)
                out[c] = np.where(has, out[c] * (1.0 - p) / alone, out[c])
            elif seen_at == j:
                out[c] = np.where(has, out[c] * p, out[c])
    return out


def alone_miss(conditional: np.ndarray) -> np.ndarray:
    """1 - p_o(j, v | nobody else there), shape (N, in-view sites): a miss's unary part (eq. 34),
    at least :data:`ALONE_FLOOR` (a curve whose p_max is 1 would otherwise rule the site out)."""
    return np.maximum(1.0 - conditional[:, :, 0], ALONE_FLOOR)


@dataclass(frozen=True)
class CompanyEvidence:
    """The looks of a joint belief under the company model, kept exactly (eq. 59).

    The likelihood of a look is a unary part, each missed object's 1 - p_o(j | nobody else)
    (kept with the other unary evidence, in log space), times site-local factors over which
    objects stand at each site in view (:func:`look_weights`). Their product over looks, W[j, S],
    multiplies the joint as the capacity factor does, so the dense joint and the subset program
    (docs/design.md §4.4) hold it exactly. With the unary part taken out, W[j, S] is 1 for an
    empty site and grows only by the company's ratios, so it stays within floating point for any
    realistic run of looks (the look budget of a search is tens of looks); a row whose ratios
    would overflow (hundreds of misses at one site of an object its company hides) is rescaled.

    Attributes:
        weights: (K, 2^N) W[j, S].
        log_miss: (N, K) the sum over the looks that missed o of log((1 - p̄_{o,j}) /
            (1 - p_o(j | nobody else))), p̄ the probability under the belief the look was taken
            with (eq. 60): what the give-up rule's R_o (docs/design.md §7.8) adds to the unary
            misses so that each miss counts with p̄.
    """

    weights: np.ndarray
    log_miss: np.ndarray

    @classmethod
    def empty(cls, n: int, k: int) -> "CompanyEvidence":
        return cls(np.ones((k, 1 << n)), np.zeros((n, k)))

    def absorb(self, conditional: np.ndarray, sites: Sequence[int], found: Mapping[int, int | None],
               mean: np.ndarray) -> "CompanyEvidence":
        """This evidence and one more look (`mean`: the look's p̄, shape (N, in-view sites))."""
        weights = self.weights.copy()
        rows = weights[list(sites)] * look_weights(conditional, sites, found)
        top = rows.max(axis=1, keepdims=True)
        # W[j, {}] stays 1 (a look weighs nobody at j by 1); a row is rescaled, a factor common to
        # every placement, only if its company ratios near overflow (hundreds of misses at one
        # site of an object its company hides).
        weights[list(sites)] = np.where(top > RESCALE_ABOVE, rows / np.where(top > 0, top, 1.0), rows)
        log_miss = self.log_miss.copy()
        alone = alone_miss(conditional)
        for o, seen_at in found.items():
            if seen_at is None:
                with np.errstate(divide="ignore", invalid="ignore"):
                    log_miss[o, list(sites)] += (np.log1p(-np.asarray(mean[o], dtype=float))
                                                 - np.log(alone[o]))
        return CompanyEvidence(weights, np.nan_to_num(log_miss, nan=0.0, posinf=0.0))

    def dense(self) -> np.ndarray:
        """prod_j W[j, S_j(L)] over every joint placement L, shape (K,) * N."""
        k, full = self.weights.shape
        n = full.bit_length() - 1
        touched = [j for j in range(k) if not np.all(self.weights[j] == 1.0)]
        out = np.ones((k,) * n)
        for j, mask in zip(touched, site_masks(n, k, touched)):
            out = out * self.weights[j][mask]
        return out


def fixed_companions(table: np.ndarray, sites: Sequence[int],
                     placed: Mapping[int, int | None]) -> np.ndarray:
    """The conditional table of a look once some objects have been moved by the agent.

    The belief's location variables are where objects stood when the episode began; an object
    the agent has picked up stands where it put it (`placed`: object index -> site index, or None
    while it is held or inside another), whatever its start site. Its company effect on a look is
    then fixed: table'[o, c, M] = table[o, c, (M without moved objects) + moved objects at the
    c-th site]."""
    n = table.shape[0]
    masks = np.arange(1 << n)
    moved = sum(1 << o for o in placed)
    out = np.empty_like(table)
    for c, j in enumerate(sites):
        here = sum(1 << o for o, s in placed.items() if s == j)
        for o in range(n):
            out[o, c] = table[o, c][((masks & ~moved) | here) & ~(1 << o)]
    return out


def together_from(marginals: np.ndarray, pairwise: np.ndarray | None) -> np.ndarray:
    """P(o2 at j | o at j), shape (N, N, K): from the pairwise marginals P(L_o = a, L_o2 = b)
    where the belief is joint, else the other object's own marginal (a factorised belief)."""
    n, k = marginals.shape
    if pairwise is None:
        return np.broadcast_to(marginals[None, :, :], (n, n, k)).copy()
    diag = pairwise[:, :, np.arange(k), np.arange(k)]  # (N, N, K): P(L_o = j, L_o2 = j)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(marginals[:, None, :] > 0, diag / marginals[:, None, :], 0.0)
    return np.clip(out, 0.0, 1.0)


__all__ = ["CompanyEvidence", "CompanyModel", "CompanyTable", "alone_miss", "fixed_companions", "look_weights",
           "site_masks", "company_probability", "coupled_likelihood", "curve_values", "share_matrix",
           "slot_probability", "together_from"]
