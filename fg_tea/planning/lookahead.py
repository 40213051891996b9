"""Lookahead search on the exact belief: which look minimises the expected travel to find everything?

This module answers the planning question of docs/design.md §6 by looking ahead rather than by a
one-step score. It is the expectimin tree of docs/design.md §6.6:

- **Belief.** The hidden truth is the sites L_U = (L_u)_{u in U} of the required objects U =
  `objects`, distributed as the current belief P(L_U) over the open sites (truths that put an
  object on an excluded site are conditioned away, as in the Bayes-optimal planner, unless that
  leaves nothing), held exactly as a :class:`~fg_tea.planning.problem.SearchProblem`: a
  correlated belief as its dense joint over U (up to
  :data:`~fg_tea.planning.problem.MAX_TRUTHS` truths) or beyond that as the engine's subset
  program times one weight vector per object (docs/design.md §4.4; a correlated belief without
  one is refused before the episode starts); a factorised belief as its |U| per-object
  marginals, whose product *is* the joint, with no limit. Every hypothetical outcome is
  conditioned exactly (Bayes' rule, eq. 37 for one object), so a chain of hypothetical looks
  needs no inference call.
- **Looks and outcomes.** A look from viewpoint v shows each unfound object u standing at an
  in-view site a with probability p_{u,a}(v) (1 - mu for a threshold close look; the visibility
  curve otherwise), independently given the truth; false positives are not branched on (their
  rate, 1e-4 by default, is below the outcome pruning). An outcome is the set of objects seen;
  an object seen is found. A room glance's outcomes are grouped by who is seen, not where:
  for a factorised belief a found object's site changes nothing left to find, so no value
  changes (a test checks it against branching on every site); for a joint belief the tree plans
  as if a glance told which objects it showed, not at which of its sites (the belief the agent
  acts on still learns the site).
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
  At the root the score is the EFE planner's own (exact joint information for joint beliefs;
  candidates that provably cannot make the `width` best keep a bound, docs/design.md §6.2); in
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
from fg_tea.planning.problem import (
    LOOK_COST,
    SearchProblem,
    _mppm_choice,
    build_problem,
    marginals,
    rollout_values,
    size_fault,
)

ROLLOUTS = ("mppm", "none")
OUTCOME_FLOOR = 1e-9         # outcomes less probable than this are not expanded
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


# ---------------------------------------------------------------------------- the tree
@dataclass
class _Node:
    pos: int
    b: np.ndarray          # posterior over truths in the problem's form (joint, factors, weights)
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
    z: float = 1.0                   # structured: the node's probability relative to the root


def _node_marginals(problem: SearchProblem, node: _Node) -> np.ndarray:
    if node.q is None:
        node.q = marginals(problem, node.b)
    return node.q


def _options(problem: SearchProblem, a: int) -> np.ndarray:
    """Per-object likelihood vectors of look `a`'s outcomes, shape (|U|, 2, K') (cached).

    Row 0 is "not seen", 1 - p_{u,.}(a); row 1 is "seen", p_{u,.}(a). For a room glance "seen"
    means seen at one of its in-view sites, whichever: outcomes are grouped by which objects are
    seen, not where (docs/design.md §6.6). A found object leaves the search, so for a factorised
    belief the group's members have the same future and grouping changes no value; for a joint
    belief the tree plans as if a glance told only which objects it showed.
    """
    cache = problem.__dict__.setdefault("_options", {})
    cached = cache.get(a)
    if cached is None:
        s_all = problem.prob[a]                                    # (n, K')
        cached = np.stack([1.0 - s_all, s_all], axis=1)
        cache[a] = cached
    return cached


def _outcome_codes(count: int) -> np.ndarray:
    """Outcome codes of a look with `count` unfound objects, shape (2^count, count), in the fixed
    expansion order (cached): code[i] = 1 if the i-th unfound object is seen. Outcomes come by
    the number of objects seen, then in combination order."""
    cached = _CODE_CACHE.get(count)
    if cached is None:
        codes = []
        for size in range(count + 1):
            for subset in itertools.combinations(range(count), size):
                code = [0] * count
                for i in subset:
                    code[i] = 1
                codes.append(code)
        cached = np.array(codes, dtype=np.int64).reshape(len(codes), count)
        _CODE_CACHE[count] = cached
    return cached


_CODE_CACHE: dict[int, np.ndarray] = {}


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
        # The root's candidates are the `width` viewpoints of best one-step score, exact and in
        # exact order (the structured joint gain bounds the others, docs/design.md §6.2).
        self.pruner = EFEPlanner(replace(weights, repeat_penalty=0.0), information,
                                 rank=settings.width)

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
        u was not seen, p_{u,.}(a) if it was (for a glance: at any of its in-view sites, see
        :func:`_options`). Conditioning multiplies each object's factor by its vector (factors), or the joint
        by their outer product (joint table); the outcome's probability is the product of the
        per-object masses, or the joint contracted with the vectors.
        """
        us = np.flatnonzero(node.unfound)
        options = _options(problem, a)[us]                         # (n', 2, K')
        codes = _outcome_codes(len(us))                            # (C, n')
        b = node.b
        child_q = child_z = None
        if problem.structured is not None:
            post = np.repeat(b[None], len(codes), axis=0)         # (C, n, K') weights
            for i, u in enumerate(us):
                post[:, u] *= options[i][codes[:, i]]
            ratio, child_q = problem.structured.evaluate(post)
            mass = ratio / node.z
            keep = np.flatnonzero(mass >= OUTCOME_FLOOR)
            mass, post, child_q, child_z = mass[keep], post[keep], child_q[keep], ratio[keep]
        elif problem.independent:
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
        kids = [(float(m) / total, _Node(a, p, f, depth, looked))
                for m, p, f in zip(mass, post, unfound)]
        if child_q is not None and child_z is not None:
            for (_, kid), q, z in zip(kids, child_q, child_z):
                kid.q, kid.z = q, float(z)
        return kids

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
        fault = size_fault(len(belief.sites), len(objects), belief.correlated,
                           structured=belief.correlated and belief.structured_model() is not None)
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
                                           np.stack([n.looked for n in batch]),
                                           q=np.stack([_node_marginals(problem, n) for n in batch]))
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


__all__ = ["LookaheadPlanner", "LookaheadSettings"]
