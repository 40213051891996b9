"""The search problem one planning decision solves, and the exact value of a fixed look sequence.

Which question it answers: given the belief, the distances and the viewpoints, what is the
search the planners of docs/design.md §6.5-§6.9 reason about, and what does following a fixed
sequence of looks cost in expectation? The lookahead (§6.6), the peers (§6.7), the exact
policy and the search limit (§6.9) all plan on a :class:`SearchProblem`:

- **Truths.** The sites L_U of the required objects U over the open sites, distributed as the
  current belief (truths that put an object on an excluded site are conditioned away, unless
  that leaves nothing), held exactly in one of three forms: the dense joint (a correlated
  belief up to :data:`MAX_TRUTHS` truths), the engine's subset program times one weight vector
  per object (a correlated belief beyond that, docs/design.md §4.4), or the per-object
  marginals (a factorised belief, whose product *is* the joint: O(|U| K') per operation).
- **Looks.** A look from viewpoint v shows each unfound u standing at an in-view site a with
  probability p_{u,a}(v) (1 - mu for a threshold close look; the visibility curve otherwise),
  independently given the truth, and costs the travel to v plus ``look`` metres per image.
- **Rollout** (most probable per metre, :func:`rollout_values`): the exact expected cost of the
  fixed sequence of looks that repeatedly takes the most expected new finds per metre (eq. 47).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from fg_tea.beliefs.engine import DENSE_LIMIT
from fg_tea.beliefs.structured import StructuredLocationModel
from fg_tea.planning.base import DistanceModel, distance_matrix

#: Metres-equivalent of one image: 8 frames held still x 0.018 m per frame (EnvConfig defaults).
LOOK_COST = 8 * 0.018
MAX_TRUTHS = 50_000          # largest dense truth table held (K^|U|); beyond it, the subset program
EXPECTATION_CHUNK = 8        # nodes per batch of the rollout's joint contraction
STOP_PROBABILITY = 1e-3      # a rollout ends once the search is over with at least 1 - this

# ---------------------------------------------------------------------------- the search problem
@dataclass
class SearchProblem:
    """The search problem one decision solves, derived from the belief, distances and views.

    The belief over the truths L_U is held in one of three exact forms: ``joint``, the dense
    table of shape (K',) * |U| (correlated beliefs up to :data:`MAX_TRUTHS` truths);
    ``structured``, the engine's subset program with one weight vector per object of U
    (correlated beliefs beyond that: a node's belief is the model times prod_u w_u(L_u), shape
    (|U|, K') per node); or ``factors``, the per-object marginals of shape (|U|, K') whose
    outer product is the table (factorised beliefs; O(|U| K') however many truths).
    K' = ``len(allowed)``, the open sites.

    Attributes:
        objects: the required objects U (caller's order).
        names: viewpoint names (actions), kinds and ``probability[a]`` of shape (|U|, K): the
            chance look a shows u if u stands at site k (0 out of view).
        start: shape (A,), metres from the agent to each viewpoint.
        between: shape (A, A), metres between viewpoints.
        look: shape (A,), metres-equivalent look cost of each viewpoint.
        p_max: the detector's best detection probability (for eq. 40's normalisation).
        n_sites: K, the belief's sites.
        allowed: shape (K',), the open sites (indices into the belief's sites) the truths range over.
        joint: the dense P(L_U) over ``allowed`` (correlated beliefs), or None.
        factors: shape (|U|, K'), P(L_u) over ``allowed`` when P(L_U) is their product, or None.
        structured: the engine's subset program and U's rows in it (:class:`StructuredTruths`),
            or None.
    """

    objects: tuple[str, ...]
    names: tuple[str, ...]
    kinds: tuple[str, ...]
    probability: np.ndarray
    start: np.ndarray
    between: np.ndarray
    look: np.ndarray
    p_max: float
    n_sites: int
    allowed: np.ndarray
    joint: np.ndarray | None = None
    factors: np.ndarray | None = None
    structured: "StructuredTruths | None" = None

    @property
    def independent(self) -> bool:
        """True when the truths' distribution is held as a product over objects."""
        return self.joint is None and self.structured is None

    @property
    def prob(self) -> np.ndarray:
        """``probability`` restricted to the open sites, shape (A, |U|, K') (cached)."""
        cached = self.__dict__.get("_prob")
        if cached is None:
            cached = np.ascontiguousarray(self.probability[:, :, self.allowed])
            self.__dict__["_prob"] = cached
        return cached

    def _held(self) -> np.ndarray:
        """``joint`` or ``factors``, or the root's weights (ones) of a structured problem."""
        if self.structured is not None:
            return np.ones((len(self.objects), len(self.allowed)))
        held = self.factors if self.joint is None else self.joint
        assert held is not None, "a search problem holds a joint, factors or a structured model"
        return held

    def root(self) -> np.ndarray:
        """The root belief in the problem's form: a copy of ``joint`` or of ``factors``."""
        return self._held().copy()

    def truth_count(self) -> int:
        """Truths of nonzero probability (a product of per-object counts for factors; for a
        structured problem the same product over the marginals, an upper bound)."""
        if self.joint is not None:
            return int(np.count_nonzero(self.joint))
        if self.structured is not None:
            return math.prod(int(np.count_nonzero(f)) for f in self.structured.root_marginals)
        return math.prod(int(np.count_nonzero(f)) for f in self._held())

    def _table(self) -> tuple[np.ndarray, np.ndarray]:
        cached = self.__dict__.get("_truths")
        if cached is None:
            n, k = len(self.objects), len(self.allowed)
            if k ** n > MAX_TRUTHS:
                raise ValueError(f"search problem: {n} objects over {k} sites give {k ** n:,} "
                                 f"truths, more than {MAX_TRUTHS:,}")
            table = self.joint if self.joint is not None else _outer(self._held())
            loc = self.allowed[np.array(list(itertools.product(range(k), repeat=n)),
                                        dtype=np.int64).reshape(-1, n)]
            p = table.reshape(-1)
            keep = p > 0
            cached = (loc[keep], p[keep])
            self.__dict__["_truths"] = cached
        return cached

    @property
    def loc(self) -> np.ndarray:
        """Shape (T, |U|): each truth of nonzero probability's site per object (belief indices).

        Raises:
            ValueError: the table would exceed :data:`MAX_TRUTHS` entries.
        """
        return self._table()[0]

    @property
    def p(self) -> np.ndarray:
        """Shape (T,): the probabilities of the truths of :attr:`loc` (sum 1)."""
        return self._table()[1]

    def onehot(self, u: int) -> np.ndarray:
        """E[t, k] = [L_u(t) = k], shape (T, K) (cached)."""
        cache = self.__dict__.setdefault("_onehot", {})
        if u not in cache:
            e = np.zeros((len(self.p), self.n_sites))
            e[np.arange(len(self.p)), self.loc[:, u]] = 1.0
            cache[u] = e
        return cache[u]

    @property
    def seen(self) -> np.ndarray:
        """G[a, t, u] = P(look a shows u | truth t), shape (A, T, |U|)."""
        cached = self.__dict__.get("_seen")
        if cached is None:
            u = np.arange(len(self.objects))
            cached = self.probability[:, u[None, :], self.loc]  # (A, T, n)
            self.__dict__["_seen"] = cached
        return cached


def _outer(factors: np.ndarray) -> np.ndarray:
    """The product table of shape (K,) * n of per-object vectors ``factors`` (n, K)."""
    table = factors[0]
    for row in factors[1:]:
        table = np.multiply.outer(table, row)
    return table


@dataclass
class StructuredTruths:
    """A correlated belief over U held as the engine's subset program (docs/design.md §4.4).

    A belief node is one weight vector per object of U over the open sites, w (|U|, K'): the
    node's belief is the model's P(L) times prod_u w_u(L_u), so a hypothetical outcome
    multiplies w, an outcome's probability is a ratio of the model's sums with and without it,
    and marginals come from the same chain (:meth:`StructuredLocationModel.reweighted`). Objects
    outside U keep weight 1; U's weights are 0 off the open sites (truths there are conditioned
    away).

    Attributes:
        model: the belief's :class:`~fg_tea.beliefs.structured.StructuredLocationModel`.
        rows: U's rows in the model, shape (|U|,).
        allowed: the open sites, shape (K',).
        root_ratio: the root's probability, E[prod_u w_u(L_u)] with w = 1 on the open sites.
        root_marginals: the root's marginals over U, shape (|U|, K').
    """

    model: StructuredLocationModel
    rows: np.ndarray
    allowed: np.ndarray
    root_ratio: float = 1.0
    root_marginals: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    def __post_init__(self) -> None:
        ratio, q = self.evaluate(np.ones((1, len(self.rows), len(self.allowed))), raw=True)
        self.root_ratio = float(ratio[0])
        self.root_marginals = q[0]

    def evaluate(self, weights: np.ndarray, singles: bool = True,
                 raw: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """(probability of each node relative to the root, shape (B,); marginals over U and the
        open sites, shape (B, |U|, K'), or an empty array without `singles`) for weights (B, |U|, K')."""
        count = len(weights)
        full = np.ones((count, self.model.n, self.model.k))
        scattered = np.zeros((count, len(self.rows), self.model.k))
        scattered[:, :, self.allowed] = weights
        full[:, self.rows] = scattered
        ratio, q = self.model.reweighted(full, singles)
        if not raw:
            ratio = ratio / self.root_ratio if self.root_ratio > 0 else ratio
        if q is None:
            return ratio, np.zeros((0,))
        return ratio, q[:, self.rows][:, :, self.allowed]


def marginals(problem: SearchProblem, belief: np.ndarray) -> np.ndarray:
    """Per-object marginals, shape (|U|, K'), of one belief in the problem's form."""
    if problem.structured is not None:
        return problem.structured.evaluate(belief[None])[1][0]
    if problem.joint is None:
        return belief
    n = belief.ndim
    axes = tuple(range(n))
    return np.stack([belief.sum(axis=axes[:u] + axes[u + 1:]) for u in range(n)])


def _expectation_steps(joint: np.ndarray, factors: np.ndarray) -> np.ndarray:
    """E_t[prod_u f_{s,u}(L_u(t))] for a batch of joints and S factor sets each.

    Args:
        joint: shape (L,) + (K',) * n, one joint per node.
        factors: shape (L, S, n, K'), per node and step one vector per object.

    Returns:
        shape (L, S): the joint contracted with each step's vectors, last object first; the
        first product serves every step at once (the joint is not copied per step); nodes go
        :data:`EXPECTATION_CHUNK` at a time (the same numbers, faster: blocks stay in cache).
    """
    count, steps, n, k = factors.shape
    if count > (c := EXPECTATION_CHUNK):
        return np.concatenate([_expectation_steps(joint[i:i + c], factors[i:i + c]) for i in range(0, count, c)])
    x = np.matmul(joint.reshape(count, -1, k), np.swapaxes(factors[:, :, n - 1, :], 1, 2))
    x = np.swapaxes(x, 1, 2)                              # (L, S, K'^(n-1))
    for u in range(n - 2, -1, -1):
        x = np.matmul(x.reshape(count, steps, -1, k), factors[:, :, u, :, None])[..., 0]
    return x.reshape(count, steps)


def size_fault(n_sites: int, n_objects: int, correlated: bool, limit: int | None = None,
               structured: bool = False) -> str | None:
    """Why the lookahead planner cannot hold this search problem, or None.

    A correlated belief is planned on its exact joint over the required objects: a dense table
    of ``n_sites ** n_objects`` truths up to `limit` (default :data:`MAX_TRUTHS`), beyond it the
    engine's subset program when the belief has one (`structured`: relational factors that are
    all site- or room-local, docs/design.md §4.4). A factorised belief is held per object
    (``n_objects x n_sites`` numbers) and has no limit. The first decision of an episode plans
    over every site for every object still to find, the largest problem the planner will be asked.
    """
    limit = MAX_TRUTHS if limit is None else limit
    if correlated and not structured and n_sites ** n_objects > limit:
        return (f"{n_objects} objects over {n_sites} sites give {n_sites ** n_objects:,} joint "
                f"truths, more than the limit of {limit:,}, and the belief's relations are not "
                "all site- or room-local (a correlated belief is planned on its exact joint; a "
                "factorised one has no limit)")
    return None


def truth_table(belief, objects: Sequence[str], allowed: Sequence[int]) -> np.ndarray:
    """P(L_U) over the `allowed` sites, normalised: the dense joint of shape (K',) * |U| for a
    correlated belief, the per-object marginals of shape (|U|, K') for a factorised one.

    Raises:
        ValueError: a correlated belief's K'^|U| exceeds :data:`MAX_TRUTHS`, or the belief puts no mass on
            `allowed`.
    """
    idx = [belief.objects.index(o) for o in objects]
    n, k = len(idx), len(allowed)
    if belief.correlated and n == 1:
        # One object: its joint over U is its marginal, which the engine holds (no K^N sum).
        p_u = belief.location_matrix()[idx[0], list(allowed)]
        total = float(p_u.sum())
        if not total > 0:
            raise ValueError("lookahead: the belief puts no mass on the open sites")
        return p_u / total
    if belief.correlated:
        fault = size_fault(k, n, True)
        if fault is not None:
            raise ValueError(f"lookahead planner: {fault}; use a factorised model or another planner")
        joint = belief.location_joint()
        others = tuple(a for a in range(joint.ndim) if a not in idx)
        p_u = joint.sum(axis=others) if others else joint
        order = sorted(idx)
        p_u = np.transpose(p_u, [order.index(i) for i in idx])
        p_u = p_u[np.ix_(*([list(allowed)] * n))]
        total = float(p_u.sum())
        if not total > 0:
            raise ValueError("lookahead: the belief puts no mass on the open sites")
        return p_u / total
    q = belief.location_matrix()[np.ix_(idx, list(allowed))]
    totals = q.sum(axis=1, keepdims=True)
    if not np.all(totals > 0):
        raise ValueError("lookahead: the belief puts no mass on the open sites")
    return q / totals


def build_problem(belief, objects: Sequence[str], distances: DistanceModel,
                  excluded: frozenset[str], views, look: float) -> SearchProblem:
    """Derive the :class:`SearchProblem` of one decision (see the module docstring).

    Raises:
        ValueError: every viewpoint is excluded, or a correlated belief's joint over the open
            sites has more than :data:`MAX_TRUTHS` truths and no subset program
            (``"lookahead planner: ..."``).
    """
    sites = list(belief.sites)
    k = len(sites)
    idx = [belief.objects.index(o) for o in objects]
    mu = belief.model.miss_likelihood
    names, kinds, probs, looks = [], [], [], []
    if views is None:
        for j, s in enumerate(sites):
            if s in excluded:
                continue
            pr = np.zeros((len(idx), k))
            pr[:, j] = 1.0 - mu
            names.append(s)
            kinds.append("site")
            probs.append(pr)
            looks.append(look)
        p_max = 1.0 - mu
    else:
        for v in views.views:
            if v.name in excluded:
                continue
            names.append(v.name)
            kinds.append(v.kind)
            probs.append(v.probability_over_sites(k)[idx])
            looks.append(look * len(v.sites))
        p_max = float(views.max_probability)
    if not names:
        raise ValueError("planner: every viewpoint is excluded")
    open_sites = [j for j, s in enumerate(sites) if s not in excluded]
    try:
        held = _truths(belief, objects, open_sites)
    except ValueError as exc:
        if "no mass" not in str(exc) or len(open_sites) == k:
            raise
        open_sites = list(range(k))
        held = _truths(belief, objects, open_sites)
    start = np.array([float(distances.from_agent(s)) for s in names])
    between = distance_matrix(distances, names)
    return SearchProblem(tuple(objects), tuple(names), tuple(kinds), np.stack(probs), start,
                         between, np.array(looks), p_max, k, np.asarray(open_sites, dtype=np.int64),
                         *held)


def _truths(belief, objects: Sequence[str], open_sites: Sequence[int]):
    """(joint, factors, structured) of a search problem: for a correlated belief the dense joint
    over U when it has at most :data:`MAX_TRUTHS` truths and the engine can build the whole joint
    it is summed from (at most :data:`~fg_tea.beliefs.engine.DENSE_LIMIT` states), or when U is
    one object (its marginal), else its subset program; the marginals for a factorised one. Both
    correlated forms are exact, so an episode may pass from one to the other as objects are found and sites excluded.

    Raises:
        ValueError: no mass on the open sites; a correlated belief too large for a dense joint
            without a subset program.
    """
    dense = len(objects) == 1 or (len(open_sites) ** len(objects) <= MAX_TRUTHS
                                  and len(belief.sites) ** len(belief.objects) <= DENSE_LIMIT)
    if belief.correlated and not dense:
        model = belief.structured_model()
        if model is not None:
            held = StructuredTruths(model, np.array([belief.objects.index(o) for o in objects]),
                                    np.asarray(open_sites, dtype=np.int64))
            if not held.root_ratio > 0:
                raise ValueError("lookahead: the belief puts no mass on the open sites")
            return None, None, held
    table = truth_table(belief, objects, open_sites)
    return (table, None, None) if belief.correlated else (None, table, None)


# ---------------------------------------------------------------------------- rollouts
def _step_costs(problem: SearchProblem) -> tuple[np.ndarray, np.ndarray]:
    """c(v) from each viewpoint (rows 0..A-1) and from the start (row A, so row -1), shape
    (A+1, A), and its reciprocal (cost floored at 1e-9 m) (cached)."""
    cached = problem.__dict__.get("_costs")
    if cached is None:
        cost = np.vstack([problem.between, problem.start[None, :]]) + problem.look[None, :]
        cached = (cost, 1.0 / np.maximum(cost, 1e-9))
        problem.__dict__["_costs"] = cached
    return cached


def _mppm_choice(problem: SearchProblem, gain: np.ndarray, here: np.ndarray,
                 looked: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One step of the most-probable-per-metre policy for a batch: (best look, its cost).

    Sweeps: only the viewpoints looked from least often (among those that can still find
    something, more than 1e-12 expected new finds) compete, so a cheap re-look never beats a
    first look elsewhere; ties go to the first viewpoint in order.
    """
    cost, inverse = _step_costs(problem)
    seen_count = np.where(gain > 1e-12, looked, np.inf)
    fresh = seen_count <= seen_count.min(axis=1, keepdims=True)
    best = np.argmax(np.where(fresh, gain * inverse[here], -np.inf), axis=1)
    return best, cost[here, best]


def rollout_values(problem: SearchProblem, pos: np.ndarray, beliefs: np.ndarray, unfound: np.ndarray,
                   looked: np.ndarray | None = None, stop: float = STOP_PROBABILITY,
                   max_looks: int | None = None,
                   first: np.ndarray | None = None,
                   q: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Expected cost of the most-probable-per-metre rollout from a batch of belief nodes.

    Along the rollout's fixed sequence of looks a_1, a_2, ..., the chance that u is still unseen
    given that it stands at site k is rem_u(k) = prod_s (1 - p_{u,k}(a_s)): it depends on the
    truth only through u's own site. So the expected number of new finds of a look a is
    sum_u sum_k q_u(k) rem_u(k) p_{u,k}(a) (marginals only), and the chance the search is not over
    is 1 - E_t[prod_u (1 - rem_u(L_u(t)))] (eq. 47): a product of per-object sums for a product
    belief, the joint contracted with one vector per object otherwise. The whole batch steps
    together; a node whose search is over (or nearly) stops adding cost.

    Args:
        problem: the search problem.
        pos: shape (L,), each node's current viewpoint (-1: the agent's start position).
        beliefs: each node's posterior in the problem's form, stacked: shape (L, |U|, K')
            (factors; structured weights) or (L,) + (K',) * |U| (joint).
        unfound: shape (L, |U|) booleans, the objects still to find at each node.
        looked: shape (L, A), looks from each viewpoint so far (default 0); the rollout sweeps:
            only the viewpoints looked from least often compete.
        stop: the rollout ends once P(search not over) falls to this or below.
        max_looks: the give-up bound (default 2 x the number of viewpoints).
        first: if given, shape (L,) ints, filled with each node's first rollout look (-1: none).
        q: the nodes' marginals, shape (L, |U|, K'), if already known (else computed).

    Returns:
        (values, looks): values of shape (L,), metres-equivalent; looks, the rollout steps taken
        summed over nodes (for the log).
    """
    prob = problem.prob                                    # (A, n, K')
    a_count, n, k = prob.shape
    count = len(beliefs)
    independent = problem.independent
    max_looks = 2 * a_count if max_looks is None else max_looks
    if q is not None:
        pass
    elif independent:
        q = beliefs
    elif problem.structured is not None:
        q = problem.structured.evaluate(beliefs)[1]
    else:
        axes = tuple(range(1, n + 1))
        q = np.stack([beliefs.sum(axis=axes[:u] + axes[u + 1:]) for u in range(n)], axis=1)
    # One product gives both E[new finds] of every look (A columns) and, for a product belief,
    # P(u unseen) of every object (n columns of ones over its own sites). Per-object arrays are
    # held flat, (L, n K').
    flat = problem.__dict__.get("_rollout_flat")
    if flat is None:
        flat = (np.hstack([prob.reshape(a_count, n * k).T, np.kron(np.eye(n), np.ones((k, 1)))]),
                (1.0 - prob).reshape(a_count, n * k))
        problem.__dict__["_rollout_flat"] = flat
    flat, miss = flat
    cost_table, inverse = _step_costs(problem)
    q = q.reshape(count, n * k)
    # Flat views and preallocated rows keep each step to a few numpy calls (the loop runs up to
    # 2A steps per decision; the arithmetic is the same, element for element). The start
    # position -1 is the costs' last row, A.
    cost_flat = cost_table.reshape(-1)
    # P(u unseen | L_u = k) before each step, (L, n K'): every step's is kept for a correlated
    # belief (its P(not over) comes after the loop); two buffers in turn serve a product belief.
    rem_steps = np.empty((2 if independent else max_looks + 1, count, n * k))
    rem = rem_steps[0]
    rem[:] = np.repeat(unfound.astype(float), k, axis=1)
    cur = np.asarray(pos, dtype=np.int64).copy()
    cur[cur < 0] = a_count
    looked = np.zeros((count, a_count)) if looked is None else np.array(looked, dtype=float, order="C")
    looked_flat = looked.reshape(-1)
    row_start = np.arange(count) * a_count
    if first is not None:
        first[:] = -1
    # The policy's looks depend only on the marginals, so a correlated belief's P(not over) is
    # computed after the loop for every step at once (n batched products instead of n per step);
    # the loop ends once sum_u P(u unseen) (>= P(not over)) is at most `stop` for every node.
    history, costs, firsts, bounds = [], [], None, []
    weighted = np.empty(q.shape)
    for step in range(max_looks + 1):
        both = np.multiply(q, rem, out=weighted) @ flat    # (L, A + n)
        unseen = both[:, a_count:]                         # P(u unseen), (L, n)
        if independent:                                    # P(not over) = 1 - prod_u P(u seen)
            cont = 1.0 - np.multiply.reduce(1.0 - unseen, axis=1)
            going = cont > stop
        else:
            history.append(rem)
            going = unseen.sum(axis=1) > stop
            bounds.append(going)
        if step == max_looks or not going.any():
            break
        if independent:
            history.append(cont)
        gain = both[:, :a_count]
        # The most-probable-per-metre step (as _mppm_choice), inlined: sweeps, then gain/cost.
        seen_count = np.where(gain > 1e-12, looked, np.inf)
        score = np.where(seen_count <= seen_count.min(axis=1, keepdims=True),
                         gain * inverse[cur], -np.inf)
        best = score.argmax(axis=1)
        if step == 0:
            firsts = best
        costs.append(cost_flat[cur * a_count + best])
        looked_flat[row_start + best] += 1.0
        rem = np.multiply(rem, miss[best], out=rem_steps[(step + 1) % len(rem_steps)])
        cur = best
    taken = len(costs)
    if not taken:
        return np.zeros(count), 0
    if independent:
        cont = np.stack(history[:taken], axis=1)           # (L, S)
    elif problem.structured is not None:                   # E[prod_u done_u] = Z(w done) / Z(w)
        # Only where the union bound sum_u P(u unseen) is above `stop`: elsewhere P(not over)
        # is at most `stop` too, so the step is inactive either way (left at 0).
        need = np.stack(bounds[:taken], axis=1)            # (L, S)
        at_leaf, at_step = np.nonzero(need)
        done = 1.0 - np.stack(history[:taken], axis=1).reshape(count, taken, n, k)[at_leaf, at_step]
        here = problem.structured.evaluate(beliefs, singles=False)[0]
        ahead = problem.structured.evaluate(beliefs[at_leaf] * done, singles=False)[0]
        cont = np.zeros((count, taken))
        cont[at_leaf, at_step] = 1.0 - ahead / np.where(here > 0, here, 1.0)[at_leaf]
    else:
        done = 1.0 - np.stack(history[:taken], axis=1).reshape(count, taken, n, k)
        cont = 1.0 - _expectation_steps(beliefs, done)    # (L, S)
    active = np.logical_and.accumulate(cont > stop, axis=1)
    value = (np.stack(costs, axis=1) * cont * active).sum(axis=1)
    if first is not None:
        assert firsts is not None  # set by the first step taken
        first[active[:, 0]] = firsts[active[:, 0]]
    steps = int(active.sum())
    return value, steps


__all__ = ["LOOK_COST", "MAX_TRUTHS", "STOP_PROBABILITY", "SearchProblem", "StructuredTruths",
           "build_problem", "marginals", "rollout_values", "size_fault", "truth_table"]
