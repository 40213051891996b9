"""Exact location queries by variable elimination, for relational factors of any scope.

The engine's fourth exact location method (docs/design.md §4.8), for graphs whose relational
factors include user factors (:attr:`~fg_tea.beliefs.graph.BeliefGraph.extra`) over a K^N joint
too large to hold. The location block is

    P(L) ∝ prod_o u_o(L_o) x prod_{a<b} psi_ab(L_a, L_b) x prod_f f(L_scope(f)) x prod_j W_j(S_j(L)),

with u_o the engine's unary evidence (prior, detections, misses), psi the pair factors (eq. 35),
f the extra factors, and W_j a site-local weight of the set S_j of objects on site j: the capacity
penalty (penalty^(|S_j| - c_j) beyond capacity c_j) and occlusion's coupled looks (eq. 59). The
site-local part is a function of counts, never a K^N table: each object gets a copy C_o of its
location coarsened to "which of the J weighted sites, or none" (a deterministic link factor), and
the W_j meet in one factor over (C_1, ..., C_N) of (J + 1)^N entries.

Every query is variable elimination in log space (:mod:`fg_tea.beliefs.elimination`) over each
connected component, with a min-fill order computed once per (component, kept variables) and
reused across evidence; singles, pairwise marginals, joints of any set, MAP and K-best come from
one :class:`EliminatedLocationModel` per evidence state, which caches what it has computed. A
query whose elimination would build a table above the budget is refused in one line naming the
variables, the elimination width and the table size (:class:`EliminationRefused`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from fg_tea.beliefs.elimination import (LogFactor, log_product, logsumexp, max_assignment, min_fill_order,
                                        order_cost, sum_out)
from fg_tea.beliefs.graph import DENSE_LIMIT
from fg_tea.beliefs.kbest import kbest_partition, merge_independent
from fg_tea.common.errors import ContradictionError

#: Largest table (entries) one elimination step may build: the dense joint's limit, so the
#: engine never holds more than it would for a dense joint.
ELIMINATION_BUDGET = 1 << 22
#: Joint states above which "auto" answers a graph with extra factors by elimination rather than
#: the dense joint. Measured (one update + hypothetical_all, CPU ms, a three-object factor,
#: teabag-kettle co-location and capacity 1 on every sixth site), dense vs elimination: 4 x 20
#: (160,000 states) 2.4 vs 3.7; 4 x 24 (331,776) 4.0 vs 4.0; 5 x 12 (248,832) 5.3 vs 5.7;
#: 5 x 16 (1,048,576) 31 vs 5.6; 5 x 20 (3,200,000) 50 vs 6.3.
ELIMINATION_FROM = 250_000


#: Largest sum, over a component's factors, of each factor's log range (max - min nonzero, nats)
#: for which its queries run in scaled linear space (products by ``numpy.einsum``): every product
#: of those factors, each scaled to a maximum of 1, then lies within e^-600 of its maximum and far
#: above the smallest float, so nothing underflows. Wider ranges (thousands of misses) run in log
#: space (:mod:`fg_tea.beliefs.elimination`); both are exact.
LINEAR_RANGE = 600.0


def _log_range(log_table: np.ndarray) -> float:
    finite = log_table[np.isfinite(log_table)]
    return float(finite.max() - finite.min()) if finite.size else 0.0


def _sum_product_linear(factors: Sequence[LogFactor], order: Sequence[int], keep: Sequence[int],
                        cards: dict[int, int]) -> tuple[np.ndarray, float]:
    """The product of `factors` summed over `order`, as (table over `keep`, log scale): the sum is
    table x exp(scale). Each factor and each message is scaled to a maximum of 1."""
    pool: list[tuple[tuple[int, ...], np.ndarray]] = []
    scale = 0.0
    for scope, log_t in factors:
        finite = log_t[np.isfinite(log_t)]
        top = float(finite.max()) if finite.size else 0.0
        pool.append((tuple(scope), np.exp(log_t - top)))
        scale += top
    for v in order:
        touching = [f for f in pool if v in f[0]]
        if not touching:
            scale += math.log(cards[v])
            continue
        pool = [f for f in pool if v not in f[0]]
        out: list[int] = []
        for s, _ in touching:
            out += [w for w in s if w != v and w not in out]
        msg = np.einsum(*[x for s, t in touching for x in (t, list(s))], out, optimize=True)
        top = float(msg.max()) if msg.size else 0.0
        if top > 0:
            msg = msg / top
            scale += math.log(top)
        pool.append((tuple(out), msg))
    operands = [x for s, t in pool for x in (t, list(s))]
    table = np.einsum(*operands, list(keep), optimize=True) if operands else np.ones(())
    return table, scale


class EliminationRefused(ValueError):
    """Exact elimination would build a table above the budget (one line: variables, width, size)."""


@dataclass(frozen=True)
class _Component:
    ids: tuple[int, ...]                  # variable ids (objects first, then their coarse copies)
    objects: tuple[int, ...]              # the objects among them
    factors: tuple[LogFactor, ...]        # relational factors (no unary evidence)


def _site_weight_table(n: int, sites: Sequence[int], weights: np.ndarray) -> np.ndarray:
    """prod_j W[j, S_j] over every coarse placement (C_1..C_N), C_o = position in `sites` or
    len(sites) for "none of them"; `weights` is (len(sites), 2^N), indexed by object bit masks."""
    c = len(sites) + 1
    out = np.ones((c,) * n)
    for pos in range(len(sites)):
        mask = np.zeros((c,) * n, dtype=np.int64)
        for o in range(n):
            shape = [1] * n
            shape[o] = c
            mask = mask + ((np.arange(c) == pos).astype(np.int64) << o).reshape(shape)
        out = out * weights[pos][mask]
    return out


class EliminationPlan:
    """The fixed part of an eliminated location block: factors, components and orders.

    Args:
        names: object names (N), for refusals.
        k: number of sites.
        rooms: room of each site.
        same_site, same_room: (N, N) pair weights (1 = none), as :class:`PairWeights`.
        extra: relational factors as (object indices, natural-log table of shape (K,) * len(indices),
            -inf where the factor is zero).
        capacities, penalty: site capacities and the capacity penalty (None = no capacity).
        site_weights: occlusion's W[j, S] of shape (K, 2^N), or None.
        budget: largest table one elimination step may build.

    Raises:
        EliminationRefused: some query of the block would exceed the budget.
    """

    def __init__(self, names: Sequence[str], k: int, rooms: Sequence[str], same_site: np.ndarray,
                 same_room: np.ndarray, extra: Sequence[tuple[Sequence[int], np.ndarray]] = (),
                 capacities: Sequence[int | None] = (), penalty: float | None = None,
                 site_weights: np.ndarray | None = None, budget: int = ELIMINATION_BUDGET) -> None:
        n = len(names)
        self.names, self.n, self.k, self.budget = tuple(names), n, k, budget
        self.cards: dict[int, int] = {o: k for o in range(n)}
        room = np.array([[rooms[i] == rooms[j] for j in range(k)] for i in range(k)])
        factors: list[LogFactor] = []
        with np.errstate(divide="ignore"):
            for a in range(n):
                for b in range(a + 1, n):
                    if same_site[a, b] != 1.0 or same_room[a, b] != 1.0:
                        table = np.where(room, same_room[a, b], 1.0)
                        np.fill_diagonal(table, same_site[a, b])
                        factors.append(((a, b), np.log(table)))
            factors += [(tuple(int(v) for v in scope), np.asarray(log_table, dtype=float))
                        for scope, log_table in extra]
            factors += self._site_local(capacities, penalty, site_weights)
        self.components = self._split(factors)
        self.ranges = tuple(sum(_log_range(t) for _, t in comp.factors) for comp in self.components)
        self._orders: dict[tuple[int, tuple[int, ...]], list[int]] = {}
        self._outcome_orders: dict[tuple, list[int]] = {}
        for c, comp in enumerate(self.components):   # refuse now what any query would need
            if len(comp.objects) > 1:
                for keep in [(o,) for o in comp.objects] + [(a, b) for i, a in enumerate(comp.objects)
                                                              for b in comp.objects[i + 1:]]:
                    self.order(c, keep)

    def _site_local(self, capacities: Sequence[int | None], penalty: float | None,
                    site_weights: np.ndarray | None) -> list[LogFactor]:
        """The capacity and company weights as one factor over coarse copies of the locations."""
        n, k = self.n, self.k
        cap = {j: c for j, c in enumerate(capacities) if penalty is not None and c is not None and c < n}
        company = [] if site_weights is None else \
            [j for j in range(k) if not np.all(site_weights[j] == 1.0)]
        sites = sorted(set(cap) | set(company))
        if not sites or n < 2:
            return []
        size = (len(sites) + 1) ** n
        if size > self.budget:
            raise self.refusal(tuple(range(n)), n - 1, size, "the site-local (capacity, company) factor")
        counts = np.array([bin(s).count("1") for s in range(1 << n)])
        weights = np.ones((len(sites), 1 << n))
        rate = 1.0 if penalty is None else float(penalty)
        for pos, j in enumerate(sites):
            if j in cap:
                weights[pos] *= np.where(counts > cap[j], rate ** np.maximum(counts - cap[j], 0), 1.0)
            if site_weights is not None:
                weights[pos] *= site_weights[j]
        link = np.full((k, len(sites) + 1), -np.inf)
        where = {j: pos for pos, j in enumerate(sites)}
        for a in range(k):
            link[a, where.get(a, len(sites))] = 0.0
        out: list[LogFactor] = []
        for o in range(n):
            self.cards[n + o] = len(sites) + 1
            out.append(((o, n + o), link))
        with np.errstate(divide="ignore"):
            out.append((tuple(range(n, 2 * n)), np.log(_site_weight_table(n, sites, weights))))
        return out

    def _split(self, factors: list[LogFactor]) -> tuple[_Component, ...]:
        parent = {v: v for v in self.cards}

        def root(v: int) -> int:
            while parent[v] != v:
                parent[v] = parent[parent[v]]
                v = parent[v]
            return v
        for scope, _ in factors:
            for v in scope[1:]:
                parent[root(v)] = root(scope[0])
        groups: dict[int, list[int]] = {}
        for v in sorted(self.cards):
            groups.setdefault(root(v), []).append(v)
        out = []
        for ids in sorted(groups.values()):
            members = set(ids)
            out.append(_Component(tuple(ids), tuple(v for v in ids if v < self.n),
                                  tuple(f for f in factors if f[0][0] in members)))
        return tuple(out)

    def component_of(self, o: int) -> int:
        return next(c for c, comp in enumerate(self.components) if o in comp.objects)

    def order(self, c: int, keep: tuple[int, ...]) -> list[int]:
        """The min-fill order eliminating every variable of component `c` but `keep` (cached).

        Raises:
            EliminationRefused: the order would build a table above the budget.
        """
        key = (c, tuple(sorted(keep)))
        found = self._orders.get(key)
        if found is None:
            comp = self.components[c]
            scopes = [s for s, _ in comp.factors] + [(o,) for o in comp.objects]
            rest = [v for v in comp.ids if v not in keep]
            found = min_fill_order(scopes, rest, self.cards)
            width, largest = order_cost(scopes, found, list(keep), self.cards)
            if largest > self.budget:
                raise self.refusal(comp.ids, width, largest, "variable elimination")
            self._orders[key] = found
        return found

    def outcome_order(self, o: int, outcomes: dict[int, int]) -> tuple[list[int], dict[int, int]]:
        """(order, cards) keeping L_o and one outcome variable per object of `outcomes` (object ->
        number of outcomes; ids 3N + u) (cached).

        Raises:
            EliminationRefused: the order would build a table above the budget.
        """
        n = self.n
        cards = dict(self.cards)
        cards.update({3 * n + u: m for u, m in outcomes.items()})
        key = (o, tuple(sorted(outcomes.items())))
        order = self._outcome_orders.get(key)
        if order is None:
            keep = [o] + [3 * n + u for u in sorted(outcomes)]
            scopes = [s for comp in self.components for s, _ in comp.factors]
            scopes += [(u,) for u in range(n)] + [(u, 3 * n + u) for u in outcomes]
            order = min_fill_order(scopes, [v for v in cards if v not in keep], cards)
            width, largest = order_cost(scopes, order, keep, cards)
            if largest > self.budget:
                raise self.refusal(tuple(range(n)), width, largest,
                                   "variable elimination with a look's outcomes")
            self._outcome_orders[key] = order
        return order, cards

    def refusal(self, ids: Sequence[int], width: int, size: int, how: str) -> EliminationRefused:
        shown = ", ".join(f"L[{self.names[v]}]" for v in ids if v < self.n)
        return EliminationRefused(f"exact inference over {shown} by {how} needs a table of {size:,} "
                                  f"entries (elimination width {width}), above the budget of "
                                  f"{self.budget:,}; refused (no approximation is made)")


class EliminatedLocationModel:
    """Exact location queries for one evidence state (cache it until the evidence changes).

    Args:
        plan: the block's :class:`EliminationPlan`.
        unary: (N, K) per-object evidence (prior x detections x misses), non-negative.
    """

    def __init__(self, plan: EliminationPlan, unary: np.ndarray) -> None:
        self.plan = plan
        with np.errstate(divide="ignore"):
            self._log_unary = np.log(np.asarray(unary, dtype=float))
        self._tables: dict[tuple[int, ...], np.ndarray] = {}
        self._log_z: dict[int, float] = {}
        self._singles: np.ndarray | None = None
        self._pairwise: np.ndarray | None = None

    def _factors(self, c: int) -> list[LogFactor]:
        comp = self.plan.components[c]
        return list(comp.factors) + [((o,), self._log_unary[o]) for o in comp.objects]

    def _component_table(self, c: int, keep: tuple[int, ...]) -> np.ndarray:
        """Normalised P(keep) within component `c`, axes in `keep`'s order."""
        key = (c,) + keep
        cached = self._tables.get(key)
        if cached is None:
            cards, order = self.plan.cards, self.plan.order(c, keep)
            spread = self.plan.ranges[c] + sum(_log_range(self._log_unary[o])
                                               for o in self.plan.components[c].objects)
            if spread <= LINEAR_RANGE:
                table, scale = _sum_product_linear(self._factors(c), order, keep, cards)
                total = float(table.sum())
                if not total > 0 or not math.isfinite(total):
                    raise ContradictionError("location evidence has probability zero under the model")
                self._log_z[c] = scale + math.log(total)
                cached = table / total
            else:
                log_t = log_product(sum_out(self._factors(c), order, cards), list(keep), cards)
                log_z = float(logsumexp(log_t, axis=None))
                if not np.isfinite(log_z):
                    raise ContradictionError("location evidence has probability zero under the model")
                self._log_z[c] = log_z
                cached = np.exp(log_t - log_z)
            self._tables[key] = cached
        return cached

    def singles(self) -> np.ndarray:
        """q(L_o) of every object, shape (N, K)."""
        if self._singles is None:
            out = np.empty((self.plan.n, self.plan.k))
            for c, comp in enumerate(self.plan.components):
                for o in comp.objects:
                    if self._pairwise is not None:
                        out[o] = np.diag(self._pairwise[o, o])
                    elif len(comp.objects) == 1 and len(comp.ids) == 1:
                        row = np.exp(self._log_unary[o] - np.max(self._log_unary[o]))
                        if not np.isfinite(row.sum()) or row.sum() <= 0:
                            raise ContradictionError("location evidence has probability zero")
                        out[o] = row / row.sum()
                    else:
                        out[o] = self._component_table(c, (o,))
            self._singles = out
        return self._singles

    def pairwise(self) -> np.ndarray:
        """P(L_o = a, L_p = b), shape (N, N, K, K); diagonal blocks are diag(q_o)."""
        if self._pairwise is None:
            m = self.singles()
            n, k = m.shape
            out = np.empty((n, n, k, k))
            for o in range(n):
                out[o, o] = np.diag(m[o])
                co = self.plan.component_of(o)
                for p in range(o + 1, n):
                    if self.plan.component_of(p) == co:
                        block = self._component_table(co, (o, p))
                    else:
                        block = np.outer(m[o], m[p])
                    out[o, p], out[p, o] = block, block.T
            self._pairwise = out
        return self._pairwise

    def joint(self, objects: Sequence[int]) -> np.ndarray:
        """P(L_objects), axes in the order given (any number of objects, no repeats).

        Raises:
            EliminationRefused: the joint or its elimination exceeds the budget.
        """
        objects = tuple(int(o) for o in objects)
        size = self.plan.k ** len(objects)
        if size > self.plan.budget:
            raise self.plan.refusal(objects, len(objects) - 1, size, "a joint table")
        out = np.ones(())
        axes: list[int] = []
        for c, comp in enumerate(self.plan.components):
            keep = tuple(o for o in objects if o in comp.objects)
            if not keep:
                continue
            table = self.singles()[keep[0]] if len(keep) == 1 else self._component_table(c, keep)
            out = np.multiply.outer(out, table)
            axes += keep
        return np.transpose(out, [axes.index(o) for o in objects])

    def _log_z_of(self, c: int) -> float:
        if c not in self._log_z:
            first = self.plan.components[c].objects[0]
            self._component_table(c, (first,))
        return self._log_z[c]

    def outcome_joint(self, o: int, tables: dict[int, np.ndarray]) -> np.ndarray:
        """P(L_o, D_u for u in `tables`): the joint of one location and the outcomes of a look.

        Args:
            o: the object whose location is kept.
            tables: object u -> its outcome model P(D_u = d | L_u = a), shape (K, M_u); the D_u
                are independent given the locations (a detector's report per object).

        Returns:
            Shape (K, M_u1, M_u2, ...), outcome axes in increasing object order, summing to 1.

        Raises:
            EliminationRefused: the elimination would build a table above the budget.
            ContradictionError: the evidence has probability zero.
        """
        plan, n = self.plan, self.plan.n
        observed = sorted(tables)
        order, cards = plan.outcome_order(o, {u: tables[u].shape[1] for u in observed})
        factors = [f for c in range(len(plan.components)) for f in self._factors(c)]
        with np.errstate(divide="ignore"):
            factors += [((u, 3 * n + u), np.log(tables[u])) for u in observed]
        keep = [o] + [3 * n + u for u in observed]
        if sum(_log_range(t) for _, t in factors) <= LINEAR_RANGE:
            table, _ = _sum_product_linear(factors, order, keep, cards)
        else:
            log_t = log_product(sum_out(factors, order, cards), keep, cards)
            table = np.exp(log_t - np.max(log_t)) if np.isfinite(np.max(log_t)) else np.zeros_like(log_t)
        total = float(table.sum())
        if not total > 0 or not math.isfinite(total):
            raise ContradictionError("location evidence has probability zero under the model")
        return table / total

    def kbest(self, count: int) -> list[tuple[float, tuple[int, ...]]]:
        """The `count` most probable arrangements (probability, site index per object), best
        first; ties in value-index order (Lawler-Nilsson partitioning, exact)."""
        lists = []
        for c, comp in enumerate(self.plan.components):
            found = kbest_partition(self._factors(c), list(comp.ids), self.plan.cards, count)
            log_z = self._log_z_of(c) if len(comp.ids) > 1 else float(logsumexp(self._log_unary[comp.ids[0]],
                                                                                  axis=None))
            keep = [i for i, v in enumerate(comp.ids) if v < self.plan.n]
            lists.append([(w - log_z, tuple(x[i] for i in keep)) for w, x in found])
        merged = merge_independent(lists, count)
        order = [o for comp in self.plan.components for o in comp.objects]
        return [(math.exp(w), tuple(x[order.index(o)] for o in range(self.plan.n))) for w, x in merged]

    def map_assignment(self) -> np.ndarray:
        """The most probable arrangement (site index per object); ties to the lowest index."""
        out = np.zeros(self.plan.n, dtype=np.int64)
        for c, comp in enumerate(self.plan.components):
            order = self.plan.order(c, ()) if len(comp.ids) > 1 else list(comp.ids)
            top, values = max_assignment(self._factors(c), order, self.plan.cards)
            if not np.isfinite(top):
                raise ContradictionError("location evidence has probability zero under the model")
            for o in comp.objects:
                out[o] = values[o]
        return out


def plan_for(graph, pair_weights, site_weights: np.ndarray | None = None,
             budget: int = ELIMINATION_BUDGET) -> EliminationPlan:
    """The :class:`EliminationPlan` of a :class:`~fg_tea.beliefs.graph.BeliefGraph`.

    Raises:
        EliminationRefused: a query would exceed the budget, or an extra factor is not over
            location variables.
    """
    index = {f"L[{o}]": i for i, o in enumerate(graph.objects)}
    extra = []
    for f in graph.extra:
        unknown = [v for v in f.variables if v not in index]
        if unknown:
            raise EliminationRefused(f"relational factor {f.label!r} names {', '.join(unknown)}, "
                                     "not location variables of this belief")
        extra.append(([index[v] for v in f.variables], f.log_values()))
    return EliminationPlan(graph.objects, len(graph.sites), graph.rooms, pair_weights.same_site,
                           pair_weights.same_room, extra, graph.capacities,
                           graph.capacity_penalty if graph.capacity_active else None, site_weights, budget)


def elimination_plan(graph, pair_weights, location_solver: str = "auto") -> EliminationPlan | None:
    """The plan when elimination answers this graph's location queries, else None.

    ``auto`` keeps every graph without extra factors on its old method, and a graph with extra
    factors on the dense joint up to :data:`ELIMINATION_FROM` joint states (measured cheaper
    there); above, elimination, unless its tables would exceed the budget while the dense joint
    fits. ``elimination`` forces it on a correlated graph.

    Raises:
        EliminationRefused: elimination is needed (or asked for) and exceeds the budget.
    """
    if not graph.correlated or location_solver not in ("auto", "elimination"):
        return None
    if location_solver == "auto" and (not graph.extra or graph.joint_size <= ELIMINATION_FROM):
        return None
    try:
        return plan_for(graph, pair_weights)
    except EliminationRefused:
        if location_solver == "auto" and graph.joint_size <= DENSE_LIMIT:
            return None
        raise


def eliminated_model(plan: EliminationPlan, graph, pair_weights, unary: np.ndarray,
                     company=None) -> EliminatedLocationModel:
    """The queries of one evidence state; occlusion's coupled looks (`company`, eq. 59) enter
    the site-local factor, so the plan is rebuilt with them (and refused if over budget)."""
    if company is not None:
        plan = plan_for(graph, pair_weights, site_weights=company.weights, budget=plan.budget)
    return EliminatedLocationModel(plan, unary)


__all__ = ["ELIMINATION_BUDGET", "ELIMINATION_FROM", "EliminatedLocationModel", "EliminationPlan",
           "EliminationRefused", "eliminated_model", "elimination_plan", "plan_for"]
