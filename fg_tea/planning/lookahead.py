"""Lookahead search on the exact belief: which look minimises the expected travel to find everything?

This module answers the planning question of docs/design.md §6 by looking ahead rather than by a
one-step score. It is the expectimin tree of docs/design.md §6.6:

- **Belief.** The hidden truth is the sites L_U = (L_u)_{u in U} of the required objects U =
  `objects`, distributed as the current belief P(L_U) over the open sites (truths that put an
  object on an excluded site are conditioned away, as in the Bayes-optimal planner, unless that
  leaves nothing). It is held exactly in one of two forms. A correlated belief: the dense joint
  of U (from ``belief.location_joint()``), a table of K'^|U| truths, at most
  :data:`MAX_TRUTHS`; a larger one is refused before the episode starts (:func:`size_fault`).
  A factorised belief: the |U| per-object marginals, whose product *is* the joint, so every
  operation below is a product or sum of per-object terms, O(|U| K') however many truths the
  product has, with no limit. Every hypothetical outcome is conditioned exactly (Bayes' rule,
  eq. 37 for one object), so a chain of hypothetical looks needs no inference call.
- **Looks and outcomes.** A look from viewpoint v shows each unfound object u standing at an
  in-view site a with probability p_{u,a}(v) (1 - mu for a threshold close look; the visibility
  curve otherwise), independently given the truth; false positives are not branched on (their
  rate, 1e-4 by default, is below the outcome pruning). An outcome is the set of objects seen
  and where; an object seen is found.
- **Cost.** c(v) = travel from the current viewpoint to v (metres, the caller's distances) +
  ``look`` metres per image the look takes (one for a close look, one per in-view site for a room
  glance). ``look`` defaults to 0.144 m, the distance the agent would move in the 8 frames it holds
  still for an image (``EnvConfig.look_frames`` x ``movement_step``), so time spent looking and
  time spent travelling are priced alike. The Bayes-optimal planner prices a look at 0 m; the
  small positive price here is what stops a free re-look of the current site from being repeated
  for ever. A re-look is otherwise priced like any other look: its chance of finding something is
  the miss model's, and there is no repeat penalty.
- **Value.** V(b) = 0 when every object is found, else
  min_{v in top-k(b)} [ c(v) + sum_outcomes P(outcome | b, v) V(b | v, outcome) ] to `depth` looks;
  at the leaves, V is the expected cost of a rollout of the base policy (below), or 0 without one.
- **Pruning.** At every node only the `width` viewpoints with the best one-step EFE score
  (eq. 39 without the repeat term, since re-looks are priced by the miss model) are expanded.
  At the root the score is the EFE planner's own (exact joint information for joint beliefs); in
  the tree it is eqs. 39-41 on the tree's marginals.
  A look expected to find fewer than :data:`NULL_LOOK` objects cannot change the belief and is
  dropped from the candidates (unless nothing else is left; see ``LookaheadPlanner._useful``).
- **Rollout** (``rollout = "mppm"``, most probable per metre): from the leaf, repeatedly go to the
  viewpoint with the largest expected number of newly found objects per metre of cost, following
  the all-miss branch, until the search would be over with probability 1 - 1e-3
  (:data:`STOP_PROBABILITY`) or 2 x the number of viewpoints looks were made (the give-up bound).
  Its value is the *exact* expected cost of that fixed sequence of looks stopped when every
  object is found, sum_s c_s P(search not over before look s), so it is the value of a real
  policy and an upper bound of the optimal cost-to-go. P(search not over) is a product of
  per-object sums for a factorised belief and the joint contracted with one vector per object
  otherwise. All leaves of one decision are rolled out together, one batched step per look.
- **Budget.** At most ``nodes`` belief nodes per decision; once spent, further nodes are valued
  by their rollout instead of being expanded. Expansion order is fixed (EFE rank, then outcome
  order), so the same budget gives the same choice.

With ``depth = 1`` and no rollout there is nothing to look ahead with: the planner returns the
EFE planner's choice (a test checks it). Planner specs: ``lookahead`` (defaults) or
``lookahead:depth=2,width=3,rollout=mppm,nodes=20,look=0.144`` (the defaults). The node budget
is chosen by a rule across houses (docs/design.md §6.6, ``experiments/lookahead_budget.py``): the
smallest of 10, 20, 40, 60, 120, 240 nodes whose paired mean search travel is not detectably worse
than 240 nodes' (95 % paired bootstrap) on the default apartment and on generated 13- and 27-site
houses, for factorised and joint close-look models.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import Mapping, Sequence

import numpy as np

from fg_tea.common.errors import PlannerRefused
from fg_tea.model.spec import PlanningWeights
from fg_tea.planning.base import (
    Candidate,
    Decision,
    DistanceModel,
    PlannerBase,
    check_inputs,
    parse_settings,
)
from fg_tea.planning.efe import EFEPlanner, entropies

#: Metres-equivalent of one image: 8 frames held still x 0.018 m per frame (EnvConfig defaults).
LOOK_COST = 8 * 0.018
ROLLOUTS = ("mppm", "none")
MAX_TRUTHS = 50_000          # largest truth table the planner holds (K^|U|)
OUTCOME_FLOOR = 1e-9         # outcomes less probable than this are not expanded
EXPECTATION_CHUNK = 8        # nodes per batch of the rollout's joint contraction
STOP_PROBABILITY = 1e-3      # a rollout ends once the search is over with at least 1 - this
NULL_LOOK = 1e-9             # a look expected to find less than this cannot change the belief


@dataclass(frozen=True)
class LookaheadSettings:
    """The knobs of :class:`LookaheadPlanner` (planner spec ``lookahead:key=value,...``).

    Attributes:
        depth: looks whose outcomes are expanded exactly (>= 1).
        width: viewpoints expanded per node, the best by the one-step score (>= 1).
        rollout: ``"mppm"`` (most probable per metre) or ``"none"`` (leaves valued 0).
        nodes: belief nodes per decision (>= 1); beyond it nodes are valued by their rollout.
        look: metres-equivalent cost of one image (>= 0).
        relook: 1 to weigh, at every node, a look from the nearest viewpoint (a re-look of the
            place the agent stands at) beside the best-scored ones; 0 not to (docs/design.md §6.6).
    """

    depth: int = 2
    width: int = 3
    rollout: str = "mppm"
    nodes: int = 20  # the budget rule of docs/design.md §6.6
    look: float = LOOK_COST
    relook: int = 0

    def __post_init__(self) -> None:
        if self.depth < 1 or self.width < 1 or self.nodes < 1:
            raise ValueError("lookahead: depth, width and nodes must be at least 1")
        if self.rollout not in ROLLOUTS:
            raise ValueError(f"lookahead: unknown rollout {self.rollout!r} (use {', '.join(ROLLOUTS)})")
        if self.relook not in (0, 1):
            raise ValueError(f"lookahead: relook must be 0 or 1, got {self.relook}")
        if not (math.isfinite(self.look) and self.look >= 0):
            raise ValueError(f"lookahead: look cost must be finite and >= 0, got {self.look}")

    @classmethod
    def parse(cls, spec: str) -> "LookaheadSettings":
        """Settings from ``"depth=2,width=4,..."`` (empty: the defaults).

        Raises:
            ValueError: an unknown key, a key given twice, a malformed pair or an out-of-range
                value.
        """
        return cls(**parse_settings("lookahead", spec, {"depth": int, "width": int, "nodes": int,
                                                        "rollout": str, "look": float, "relook": int}))

    def spec(self) -> str:
        return (f"depth={self.depth},width={self.width},rollout={self.rollout},"
                f"nodes={self.nodes},look={self.look:g}" + (",relook=1" if self.relook else ""))


# ---------------------------------------------------------------------------- the search problem
@dataclass
class SearchProblem:
    """The search problem one decision solves, derived from the belief, distances and views.

    The belief over the truths L_U is held in one of two exact forms: ``joint``, the dense table
    of shape (K',) * |U| (correlated beliefs), or ``factors``, the per-object marginals of shape
    (|U|, K') whose outer product is the table (factorised beliefs; O(|U| K') however many
    truths). K' = ``len(allowed)``, the open sites.

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

    @property
    def independent(self) -> bool:
        """True when the truths' distribution is held as a product over objects."""
        return self.joint is None

    @property
    def prob(self) -> np.ndarray:
        """``probability`` restricted to the open sites, shape (A, |U|, K') (cached)."""
        cached = self.__dict__.get("_prob")
        if cached is None:
            cached = np.ascontiguousarray(self.probability[:, :, self.allowed])
            self.__dict__["_prob"] = cached
        return cached

    def _held(self) -> np.ndarray:
        """``joint`` if the problem holds one, else ``factors`` (one of the two is always set)."""
        held = self.factors if self.joint is None else self.joint
        assert held is not None, "a search problem holds a joint or factors"
        return held

    def root(self) -> np.ndarray:
        """The root belief in the problem's form: a copy of ``joint`` or of ``factors``."""
        return self._held().copy()

    def truth_count(self) -> int:
        """Truths of nonzero probability (a product of per-object counts for factors)."""
        if self.joint is not None:
            return int(np.count_nonzero(self.joint))
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


def marginals(problem: SearchProblem, belief: np.ndarray) -> np.ndarray:
    """Per-object marginals, shape (|U|, K'), of one belief in the problem's form."""
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


def size_fault(n_sites: int, n_objects: int, correlated: bool, limit: int | None = None) -> str | None:
    """Why the lookahead planner cannot hold this search problem, or None.

    A correlated belief is planned on its exact joint over the required objects, a table of
    ``n_sites ** n_objects`` truths; a factorised belief is held per object (``n_objects x
    n_sites`` numbers) and has no limit. The first decision of an episode plans over every site
    for every object still to find, the largest problem the planner will be asked. `limit`
    defaults to :data:`MAX_TRUTHS`.
    """
    limit = MAX_TRUTHS if limit is None else limit
    if correlated and n_sites ** n_objects > limit:
        return (f"{n_objects} objects over {n_sites} sites give {n_sites ** n_objects:,} joint "
                f"truths, more than the limit of {limit:,} (a correlated belief is planned on its "
                "exact joint; a factorised one has no limit)")
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
            sites has more than :data:`MAX_TRUTHS` truths (``"lookahead planner: ..."``).
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
        table = truth_table(belief, objects, open_sites)
    except ValueError as exc:
        if "no mass" not in str(exc) or len(open_sites) == k:
            raise
        open_sites = list(range(k))
        table = truth_table(belief, objects, open_sites)
    start = np.array([float(distances.from_agent(s)) for s in names])
    between = np.array([[float(distances.between(a, b)) if a != b else 0.0 for b in names]
                        for a in names])
    joint, factors = (table, None) if belief.correlated else (None, table)
    return SearchProblem(tuple(objects), tuple(names), tuple(kinds), np.stack(probs), start,
                         between, np.array(looks), p_max, k, np.asarray(open_sites, dtype=np.int64),
                         joint, factors)


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
                   first: np.ndarray | None = None) -> tuple[np.ndarray, int]:
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
            (factors) or (L,) + (K',) * |U| (joint).
        unfound: shape (L, |U|) booleans, the objects still to find at each node.
        looked: shape (L, A), looks from each viewpoint so far (default 0); the rollout sweeps:
            only the viewpoints looked from least often compete.
        stop: the rollout ends once P(search not over) falls to this or below.
        max_looks: the give-up bound (default 2 x the number of viewpoints).
        first: if given, shape (L,) ints, filled with each node's first rollout look (-1: none).

    Returns:
        (values, looks): values of shape (L,), metres-equivalent; looks, the rollout steps taken
        summed over nodes (for the log).
    """
    prob = problem.prob                                    # (A, n, K')
    a_count, n, k = prob.shape
    count = len(beliefs)
    independent = problem.independent
    max_looks = 2 * a_count if max_looks is None else max_looks
    if independent:
        q = beliefs
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
    rem = np.repeat(unfound.astype(float), k, axis=1)      # P(u unseen | L_u = k), (L, n K')
    value = np.zeros(count)
    cur = np.asarray(pos, dtype=np.int64).copy()
    looked = np.zeros((count, a_count)) if looked is None else looked.astype(float)
    rows = np.arange(count)
    if first is not None:
        first[:] = -1
    # The policy's looks depend only on the marginals, so a correlated belief's P(not over) is
    # computed after the loop for every step at once (n batched products instead of n per step);
    # the loop ends once sum_u P(u unseen) (>= P(not over)) is at most `stop` for every node.
    history, costs, firsts = [], [], None
    for step in range(max_looks + 1):
        both = (q * rem) @ flat                            # (L, A + n)
        unseen = both[:, a_count:]                         # P(u unseen), (L, n)
        if independent:                                    # P(not over) = 1 - prod_u P(u seen)
            cont = 1.0 - np.multiply.reduce(1.0 - unseen, axis=1)
            going = cont > stop
        else:
            history.append(rem.copy())
            going = unseen.sum(axis=1) > stop
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
        costs.append(cost_table[cur, best])
        looked[rows, best] += 1.0
        rem *= miss[best]
        cur = best
    taken = len(costs)
    if not taken:
        return np.zeros(count), 0
    if independent:
        cont = np.stack(history[:taken], axis=1)           # (L, S)
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


# ---------------------------------------------------------------------------- the tree
@dataclass
class _Node:
    pos: int
    b: np.ndarray          # posterior over truths in the problem's form (joint table or factors)
    unfound: np.ndarray    # (n,) bool
    depth: int             # looks still to expand
    looked: np.ndarray     # (A,) looks from each viewpoint so far (history + path; rollout sweeps)
    value: float = 0.0
    # per action: (action, cost, [(prob, node)]); None until expanded
    children: list[tuple[int, float, list[tuple[float, "_Node"]]]] | None = None
    leaf: bool = False
    base: int = -1                   # the rollout policy's first look from here (-1: none)
    rollout: float = math.inf        # the rollout's value from here (fortification)
    q: np.ndarray | None = None      # (n, K') marginals (cached)


def _node_marginals(problem: SearchProblem, node: _Node) -> np.ndarray:
    if node.q is None:
        node.q = marginals(problem, node.b)
    return node.q


def _options(problem: SearchProblem, a: int) -> np.ndarray:
    """Per-object likelihood vectors of look `a`'s outcomes, shape (|U|, M, K') (cached).

    Row 0 is "not seen", 1 - p_{u,.}(a). A close look has one "seen" row, p_{u,.}(a); a glance
    one per in-view site k, p_{u,k}(a) at k and 0 elsewhere (the site it was seen at), in site
    order. Objects with fewer rows are padded with zero rows: their outcomes have probability 0
    and are dropped, so the order of the others is unchanged.
    """
    cache = problem.__dict__.setdefault("_options", {})
    cached = cache.get(a)
    if cached is None:
        s_all = problem.prob[a]                                    # (n, K')
        n, k = s_all.shape
        if problem.kinds[a] == "site":
            cached = np.stack([1.0 - s_all, s_all], axis=1)
        else:
            width = 1 + max(int(np.count_nonzero(s > 0)) for s in s_all)
            cached = np.zeros((n, width, k))
            cached[:, 0] = 1.0 - s_all
            for u, s in enumerate(s_all):
                ks = np.flatnonzero(s > 0)
                cached[u, np.arange(1, 1 + len(ks)), ks] = s[ks]
        cache[a] = cached
    return cached


def _outcome_codes(options: Sequence[int]) -> np.ndarray:
    """Outcome codes of a look, shape (C, len(options)), in the fixed expansion order (cached).

    ``options[i]`` is 1 + the seen options of the i-th unfound object; a code names one option
    per object (0 = not seen). Outcomes come by the set of objects seen (by size, then in
    combination order), then by the seen options of those objects in lexicographic order (for
    a glance, the sites they stood at).
    """
    key = tuple(options)
    cached = _CODE_CACHE.get(key)
    if cached is None:
        codes = []
        m = len(options)
        for size in range(m + 1):
            for subset in itertools.combinations(range(m), size):
                for choice in itertools.product(*[range(1, options[i]) for i in subset]):
                    code = [0] * m
                    for i, c in zip(subset, choice):
                        code[i] = c
                    codes.append(code)
        cached = np.array(codes, dtype=np.int64).reshape(len(codes), m)
        _CODE_CACHE[key] = cached
    return cached


_CODE_CACHE: dict[tuple[int, ...], np.ndarray] = {}


class LookaheadPlanner(PlannerBase):
    """Depth-limited expectimin over look outcomes on the exact belief (module docstring).

    Args:
        weights: the EFE weights (candidate pruning and the depth-1 fallback).
        settings: depth, width, rollout, node budget and look cost.
        information: the EFE information mode (``"auto"``, ``"factorised"``, ``"joint"``).
    """

    name = "lookahead"

    def __init__(self, weights: PlanningWeights, settings: LookaheadSettings = LookaheadSettings(),
                 information: str = "auto") -> None:
        self.weights = weights
        self.settings = settings
        self.efe = EFEPlanner(weights, information)
        # The root's candidates are ranked by their one-step scores, so every one is exact.
        self.pruner = EFEPlanner(replace(weights, repeat_penalty=0.0), information, prune=False)

    # ------------------------------------------------------------------ one-step scores in the tree
    def _tree_scores(self, problem: SearchProblem, node: _Node, relevance: np.ndarray) -> np.ndarray:
        """Eqs. 39-41 (no repeat term) per viewpoint, min over unfound objects, shape (A,)."""
        w = self.weights
        us = np.flatnonzero(node.unfound)
        q = _node_marginals(problem, node)[us]                   # (n', K')
        prob = problem.prob[:, us, :]                            # (A, n', K')
        find = (q[None] * prob).sum(axis=2) / problem.p_max      # (A, n')
        post = q[None] * (1.0 - prob)
        post = post / np.maximum(post.sum(axis=2, keepdims=True), 1e-300)
        gain = entropies(q)[None, :] - (1.0 - find) * entropies(post)
        d = problem.start if node.pos < 0 else problem.between[node.pos]
        g = (w.distance_weight * d[:, None] - w.probability_weight * find
             - w.information_weight * gain - w.relevance_weight * relevance[us][None, :])
        return g.min(axis=1)

    def _outcomes(self, problem: SearchProblem, node: _Node, a: int) -> list[tuple[float, _Node]]:
        """The children of looking from viewpoint `a`: (probability, node), in a fixed order.

        Given the truth, each unfound object is seen or not independently, so an outcome's
        likelihood is a product of one vector per object over its own site: 1 - p_{u,.}(a) if
        u was not seen, p_{u,.}(a) if it was (for a glance, restricted to the site it was seen
        at). Conditioning multiplies each object's factor by its vector (factors), or the joint
        by their outer product (joint table); the outcome's probability is the product of the
        per-object masses, or the joint contracted with the vectors.
        """
        us = np.flatnonzero(node.unfound)
        options = _options(problem, a)[us]                         # (n', M, K')
        m_count = options.shape[1]
        codes = _outcome_codes((m_count,) * len(us))               # (C, n')
        b = node.b
        if problem.independent:
            masses = np.einsum("imk,ik->im", options, b[us])       # (n', M)
            mass = np.prod(masses[np.arange(len(us)), codes], axis=1)
            keep = np.flatnonzero(mass >= OUTCOME_FLOOR)
            mass = mass[keep]
            per_option = options * (b[us][:, None, :] / np.where(masses > 0, masses, 1.0)[:, :, None])
            post = np.repeat(b[None], len(keep), axis=0)
            post[:, us] = per_option[np.arange(len(us)), codes[keep]]
        else:
            n = b.ndim
            lik = b[None]
            for i, u in enumerate(us):
                shape = [len(codes)] + [1] * n
                shape[u + 1] = b.shape[u]
                lik = lik * options[i][codes[:, i]].reshape(shape)
            mass = lik.reshape(len(codes), -1).sum(axis=1)
            keep = np.flatnonzero(mass >= OUTCOME_FLOOR)
            mass = mass[keep]
            post = lik[keep] / mass.reshape([-1] + [1] * n)
        unfound = np.repeat(node.unfound[None], len(keep), axis=0)
        unfound[:, us] = codes[keep] == 0
        looked = node.looked.copy()
        looked[a] += 1
        depth = node.depth - 1
        total = float(mass.sum())
        return [(float(m) / total, _Node(a, p, f, depth, looked))
                for m, p, f in zip(mass, post, unfound)]

    def _expand(self, problem: SearchProblem, node: _Node, relevance: np.ndarray,
                budget: list[int], leaves: list[_Node], fortify: list[_Node],
                root_actions: Sequence[int] | None = None) -> None:
        """Build the tree below `node` depth first, collecting the leaves to roll out."""
        if not node.unfound.any():
            node.value, node.leaf = 0.0, False
            node.children = []
            return
        if node.depth <= 0 or budget[0] <= 0:
            node.leaf = True
            leaves.append(node)
            return
        if root_actions is None:
            scores = self._tree_scores(problem, node, relevance)
            actions = [int(a) for a in np.argsort(scores, kind="stable")[:self.settings.width]]
            base = self._base_action(problem, node)
            if base >= 0 and base not in actions:
                actions.append(base)
            node.base = base
            if self.settings.relook and node.pos >= 0 and node.pos not in actions:
                actions.append(node.pos)
        else:
            actions = list(root_actions)
        actions = self._useful(problem, node, actions) if root_actions is None else actions
        if node.base >= 0:
            fortify.append(node)
        node.children = []
        for a in actions:
            cost = (problem.start[a] if node.pos < 0 else problem.between[node.pos, a]) + problem.look[a]
            kids = self._outcomes(problem, node, a)
            budget[0] -= len(kids)
            node.children.append((a, float(cost), kids))
        for _, _, kids in node.children:
            for _, child in kids:
                self._expand(problem, child, relevance, budget, leaves, fortify)

    @staticmethod
    def _useful(problem: SearchProblem, node: _Node, actions: Sequence[int]) -> list[int]:
        """The looks of `actions` that can change the belief (all of them if none can).

        A look expected to find fewer than :data:`NULL_LOOK` objects (in practice a re-look of a
        site already missed several times) leaves every outcome but "nothing seen" below the
        outcome floor, so its child is the same belief one look poorer: it costs and changes
        nothing, and is never the best plan. Kept as a candidate it can still win on a
        depth-limited tree, whose child (valued to a smaller depth, over its own candidates) may
        look cheaper than the node's other looks, and then it is chosen for ever.
        """
        q = _node_marginals(problem, node) * node.unfound[:, None]
        finds = np.einsum("nk,ank->a", q, problem.prob[list(actions)])
        keep = [a for a, f in zip(actions, finds) if f >= NULL_LOOK]
        return keep or list(actions)

    def _base_action(self, problem: SearchProblem, node: _Node) -> int:
        """The rollout policy's first look from `node` (-1 without a rollout or if none helps).

        The first step of :func:`rollout_values` from a node with something unfound (so the
        search is not over with probability 1), on the node's marginals.
        """
        if self.settings.rollout == "none" or not node.unfound.any():
            return -1
        q = _node_marginals(problem, node) * node.unfound[:, None]
        gain = np.einsum("nk,ank->a", q, problem.prob)[None, :]
        best, _ = _mppm_choice(problem, gain, np.array([node.pos]),
                               node.looked[None, :].astype(float))
        return int(best[0])

    @staticmethod
    def _backup(node: _Node) -> float:
        if node.leaf:
            return node.value
        if not node.children:
            return 0.0
        node.value = min(LookaheadPlanner._q(node, a, cost, kids) for a, cost, kids in node.children)
        return node.value

    @staticmethod
    def _q(node: _Node, a: int, cost: float, kids) -> float:
        """Q(node, a); for the rollout policy's own first look, no worse than the rollout itself
        (a fortified rollout: following the base policy from here is a plan whose value is known)."""
        q = cost + sum(p * LookaheadPlanner._backup(c) for p, c in kids)
        return min(q, node.rollout) if a == node.base else q

    def check(self, belief, objects: Sequence[str]) -> None:
        """Refuse, before an episode starts, a correlated belief whose joint is too large to hold.

        Raises:
            PlannerRefused: kind ``"belief"``, with :func:`size_fault`'s reason.
        """
        fault = size_fault(len(belief.sites), len(objects), belief.correlated)
        if fault is not None:
            raise PlannerRefused(f"lookahead planner: {fault}; use a factorised model or another "
                                 "planner", "belief", self.name)

    # ------------------------------------------------------------------ the decision
    def choose(self, belief, objects: Sequence[str], relevance: Mapping[str, float],
               distances: DistanceModel, inspected: Mapping[str, int],
               excluded_sites: frozenset[str] = frozenset(), views=None) -> Decision:
        """The first look of the best plan found within the budget (see the module docstring).

        Candidates are the `width` viewpoints kept at the root, each labelled with the object
        its one-step score serves best: ``base`` is that EFE score (no repeat term), ``total``
        the lookahead value (expected metres-equivalent until every object is found).
        """
        st = self.settings
        check_inputs(belief, objects, relevance, excluded_sites, views)
        if st.depth == 1 and st.rollout == "none":
            d = self.efe.choose(belief, objects, relevance, distances, inspected, excluded_sites, views)
            return Decision(d.object, d.viewpoint, d.total, d.candidates, self.name,
                            {**d.info, "lookahead": st.spec(), "nodes": 0, "leaves": 0})
        ranked = self.pruner.choose(belief, objects, relevance, distances, inspected,
                                    excluded_sites, views)
        best_by_view: dict[str, Candidate] = {}
        for c in ranked.candidates:
            if c.viewpoint not in best_by_view or c.total < best_by_view[c.viewpoint].total:
                best_by_view[c.viewpoint] = c
        problem = build_problem(belief, objects, distances, excluded_sites, views, st.look)
        index = {name: a for a, name in enumerate(problem.names)}
        order = sorted(best_by_view.values(), key=lambda c: (c.total, index[c.viewpoint]))
        root_actions = [index[c.viewpoint] for c in order[:st.width]]
        r = np.array([float(relevance[o]) for o in objects])
        history = np.array([float(inspected.get(name, 0)) for name in problem.names])
        root = _Node(-1, problem.root(), np.ones(len(objects), dtype=bool), st.depth, history)
        budget = [st.nodes]
        leaves: list[_Node] = []
        base = self._base_action(problem, root)
        root.base = base
        if base >= 0 and base not in root_actions:
            root_actions.append(base)
            kept = order[:st.width] + [best_by_view[problem.names[base]]]
        else:
            kept = order[:st.width]
        here = int(np.argmin(problem.start))
        if st.relook and here not in root_actions:  # the nearest look: a re-look where the agent stands
            root_actions.append(here)
            kept = kept + [best_by_view[problem.names[here]]]
        useful = set(self._useful(problem, root, root_actions))
        kept = [c for a, c in zip(root_actions, kept) if a in useful]
        root_actions = [a for a in root_actions if a in useful]
        fortify: list[_Node] = []
        self._expand(problem, root, r, budget, leaves, fortify, root_actions)
        steps = 0
        batch = leaves + fortify
        if batch and st.rollout == "mppm":
            values, steps = rollout_values(problem, np.array([n.pos for n in batch]),
                                           np.stack([n.b for n in batch]),
                                           np.stack([n.unfound for n in batch]),
                                           np.stack([n.looked for n in batch]))
            for n, v in zip(leaves, values):
                n.value = float(v)
            for n, v in zip(fortify, values[len(leaves):]):
                n.rollout = float(v)
        assert root.children is not None   # depth and nodes >= 1: the root is always expanded
        q_values = np.array([self._q(root, a, cost, kids) for a, cost, kids in root.children])
        best = int(np.argmin(q_values))  # first minimum: EFE rank
        candidates = []
        for c, q in zip(kept, q_values):
            candidates.append(Candidate(c.object, c.viewpoint, c.distance, c.probability,
                                        c.information_gain, c.repeat, c.relevance, c.total,
                                        float(q), c.kind))
        sorted_q = np.sort(q_values)
        info: dict[str, float | str] = {"lookahead": st.spec(), "nodes": int(st.nodes - budget[0]),
                "leaves": len(leaves), "rollout_looks": int(steps), "truths": problem.truth_count(),
                "viewpoints": len(problem.names), "best_value": float(sorted_q[0]),
                "second_value": float(sorted_q[1]) if len(sorted_q) > 1 else float(sorted_q[0]),
                "look_cost": st.look}
        chosen = candidates[best]
        return Decision(chosen.object, chosen.viewpoint, chosen.total, tuple(candidates), self.name, info)


__all__ = ["LookaheadPlanner", "LookaheadSettings", "SearchProblem", "build_problem",
           "rollout_values", "truth_table", "size_fault", "LOOK_COST", "MAX_TRUTHS"]
