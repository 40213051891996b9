"""Peer planners: how do pomdp-py's online tree searches (POUCT, POMCP) do on the same search?

This module answers that question inside our own harness (docs/design.md §6.7). The search
problem each decision solves is derived from the scenario and model by
:func:`fg_tea.planning.lookahead.build_problem`, exactly as the lookahead planner sees it:

- **state**: (viewpoint the agent stands at, or -1 at the start; the truth L_U, one row of the
  truth table; which objects have been found; which viewpoints have been looked from);
- **action**: look from viewpoint a (every eligible viewpoint, re-looks included);
- **transition**: the agent moves to a; each unfound object u is found with probability
  p_{u,L_u}(a) (1 - mu for a threshold close look, the visibility curve otherwise): the detector
  model of the belief, drawn in the transition so that the observation is deterministic;
- **observation**: which objects were newly seen, and where;
- **reward** (stated): minus the metres travelled minus the look cost (0.144 m-equivalent per
  image, as the lookahead planner prices it); 0 once every object is found (absorbing);
- **belief**: the exact posterior over truths (a histogram for POUCT; for POMCP, as many particles
  drawn from it as simulations), rebuilt from the belief engine at every decision;
- **rollout**: uniform among viewpoints not yet looked from in the simulation (all, once every
  one has been), the help the peers are given; exploration constant 20 m (:data:`EXPLORATION`,
  the scale of a random rollout's return in the default apartment; not tuned further), discount
  1, depth 2 x the number of viewpoints.

Cost: pomdp-py's POUCT rolls out to the full depth whatever the state (it knows no terminal
state), so a decision costs about N x 2 x |A| calls of the models below; they are kept to a
few attribute reads (states hash once; the rollout's choices are cached per looked-from set).
The start state is drawn by bisection of running sums built once per decision, the same draws
as ``pomdp_py.Histogram`` over the same table (which rebuilds them at every simulation, O(T)
each: 20 s per decision at 27 sites and 3 objects).

Randomness: pomdp-py draws from Python's ``random`` module; each decision seeds it from the
planner's Generator and restores the caller's state afterwards, so a seeded episode is
reproducible. Planner names: ``pouct:N`` and ``pomcp:N`` (N simulations per decision). Needs the
optional extra (``pip install "fg-tea[peers]"``, or ``pip install -e ".[peers]"`` in a checkout).
"""

from __future__ import annotations

import bisect
import itertools
import random
from typing import Mapping, Sequence

import numpy as np

from fg_tea.common.errors import PlannerRefused
from fg_tea.model.spec import Model
from fg_tea.planning.base import (
    Candidate,
    Decision,
    DistanceModel,
    PlannerBase,
    check_inputs,
)
from fg_tea.planning.problem import (
    LOOK_COST,
    MAX_TRUTHS,
    SearchProblem,
    build_problem,
)

EXPLORATION = 20.0  # metres: UCB1 exploration constant (rewards are metres)


def _pomdp_py():
    try:
        import pomdp_py
    except ImportError:
        from fg_tea.common.install import install_command

        raise ValueError("planners pouct:N and pomcp:N need pomdp-py, the optional peers extra: "
                         f"{install_command('peers')}") from None
    return pomdp_py


def _classes():
    """The pomdp-py model classes (defined on first use, so the import stays optional)."""
    pomdp_py = _pomdp_py()

    class SearchState(pomdp_py.State):
        def __init__(self, pos: int, t: int, found: int, looked: int, new: tuple = ()):
            self.pos, self.t, self.found, self.looked, self.new = pos, t, found, looked, new
            # pomdp-py hashes states, actions and observations at every tree and dict lookup:
            # hash once, not per lookup (the value is the same tuple hash as before)
            self._hash = hash((pos, t, found, looked, new))

        def __hash__(self):
            return self._hash

        def __eq__(self, other):
            return (isinstance(other, SearchState) and self.pos == other.pos and self.t == other.t
                    and self.found == other.found and self.looked == other.looked
                    and self.new == other.new)

    class Look(pomdp_py.Action):
        def __init__(self, a: int):
            self.a = a

        def __hash__(self):
            return hash(self.a)

        def __eq__(self, other):
            return isinstance(other, Look) and self.a == other.a

    class Seen(pomdp_py.Observation):
        def __init__(self, new: tuple):
            self.new = new
            self._hash = hash(new)

        def __hash__(self):
            return self._hash

        def __eq__(self, other):
            return isinstance(other, Seen) and self.new == other.new

    class Transition(pomdp_py.TransitionModel):
        def __init__(self, problem: SearchProblem, full: int):
            self.problem, self.full = problem, full
            self.seen = problem.seen  # (A, T, n)

        def sample(self, state, action):
            if state.found == self.full:  # absorbing (pomdp-py rolls out to max_depth regardless)
                return state if not state.new else SearchState(state.pos, state.t, state.found,
                                                               state.looked)
            a = action.a
            found, new = state.found, []
            probs = self.seen[a, state.t]
            for u in range(len(probs)):
                if not found >> u & 1 and probs[u] > 0 and random.random() < probs[u]:
                    found |= 1 << u
                    new.append((u, int(self.problem.loc[state.t, u])))
            return SearchState(a, state.t, found, state.looked | (1 << a), tuple(new))

    class Observe(pomdp_py.ObservationModel):
        def sample(self, next_state, action):
            return Seen(next_state.new)

        def probability(self, observation, next_state, action):
            return 1.0 if observation.new == next_state.new else 0.0

    class Reward(pomdp_py.RewardModel):
        def __init__(self, problem: SearchProblem, full: int):
            self.problem, self.full = problem, full

        def sample(self, state, action, next_state):
            if state.found == self.full:
                return 0.0
            p = self.problem
            move = p.start[action.a] if state.pos < 0 else p.between[state.pos, action.a]
            return -float(move + p.look[action.a])

    class Policy(pomdp_py.RolloutPolicy):
        def __init__(self, actions: list):
            self.actions = actions
            self.all = (1 << len(actions)) - 1
            self._fresh: dict[int, list] = {}  # looked-from mask -> the rollout's choices

        def sample(self, state):
            return self.rollout(state)

        def get_all_actions(self, state=None, history=None):
            return self.actions

        def rollout(self, state, history=None):
            fresh = self._fresh.get(state.looked)
            if fresh is None:
                fresh = [x for x in self.actions if not state.looked >> x.a & 1] or self.actions
                self._fresh[state.looked] = fresh
            return random.choice(fresh)

    class TruthBelief(pomdp_py.GenerativeDistribution):
        """The exact belief over start states, drawn from in O(log T) per simulation.

        The same draws as ``pomdp_py.Histogram`` over the same states in the same order (its
        ``random`` is ``random.choices(states, weights)``: a bisection of the running sums,
        rebuilt from the dict at every call, O(T) per simulation); here the running sums are
        built once per decision.
        """

        def __init__(self, states: list, weights: Sequence[float]):
            self.states = states
            self.cum = list(itertools.accumulate(float(w) for w in weights))
            self.total = self.cum[-1] + 0.0
            self.hi = len(states) - 1

        def random(self, rnd=random):
            return self.states[bisect.bisect(self.cum, rnd.random() * self.total, 0, self.hi)]

        def mpe(self):
            weights = np.diff(np.concatenate([[0.0], self.cum]))
            return self.states[int(np.argmax(weights))]

        def __getitem__(self, state):
            if state in self.states:
                i = self.states.index(state)
                return self.cum[i] - (self.cum[i - 1] if i else 0.0)
            return 0.0

        def get_histogram(self):
            return {s: self[s] for s in self.states}

    return SearchState, Look, Transition, Observe, Reward, Policy, TruthBelief


class PeerPlanner(PlannerBase):
    """POUCT or POMCP from pomdp-py on the derived search problem (module docstring).

    Args:
        kind: ``"pouct"`` or ``"pomcp"``.
        simulations: simulations per decision (>= 1).
        rng: the Generator each decision's seed is drawn from (default: seed 0).
        look: metres-equivalent cost of one image.
    """

    def __init__(self, kind: str, simulations: int, rng: np.random.Generator | None = None,
                 look: float = LOOK_COST) -> None:
        if kind not in ("pouct", "pomcp"):
            raise ValueError(f"unknown peer planner {kind!r}")
        if simulations < 1:
            raise ValueError("peer planner: simulations must be at least 1")
        self.kind, self.simulations, self.look = kind, int(simulations), float(look)
        self.name = f"{kind}:{self.simulations}"
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self._classes = _classes()

    def size_fault(self, n_sites: int, n_objects: int) -> str | None:
        """Why this planner cannot hold the search problem, or None.

        The peers' belief is the table of truths itself (a histogram over it, or particles drawn
        from it), for a factorised belief too, so the limit of :data:`MAX_TRUTHS` truths applies to
        every model. The first decision, over every site for every object, is the largest.
        """
        if n_sites ** n_objects > MAX_TRUTHS:
            return (f"{self.kind} planner: {n_objects} objects over {n_sites} sites give "
                    f"{n_sites ** n_objects:,} truths, more than the limit of {MAX_TRUTHS:,} (its "
                    "belief is the exact table of truths, factorised or not); use another planner")
        return None

    def check(self, belief, objects: Sequence[str]) -> None:
        """Refuse, before an episode starts, a search problem whose truth table is too large.

        Raises:
            PlannerRefused: kind ``"size"`` (``"pouct planner: ..."`` or ``"pomcp planner: ..."``).
        """
        fault = self.size_fault(len(belief.sites), len(objects))
        if fault is not None:
            raise PlannerRefused(fault, "size", self.kind)

    def choose(self, belief, objects: Sequence[str], relevance: Mapping[str, float],
               distances: DistanceModel, inspected: Mapping[str, int],
               excluded_sites: frozenset[str] = frozenset(), views=None) -> Decision:
        pomdp_py = _pomdp_py()
        SearchState, Look, Transition, Observe, Reward, Policy, TruthBelief = self._classes
        check_inputs(belief, objects, relevance, excluded_sites, views)
        self.check(belief, objects)
        problem = build_problem(belief, objects, distances, excluded_sites, views, self.look)
        n, a_count = len(objects), len(problem.names)
        full = (1 << n) - 1
        looked = sum(1 << a for a, name in enumerate(problem.names) if inspected.get(name, 0) > 0)
        seed = int(self.rng.integers(2 ** 31))
        saved = random.getstate()
        random.seed(seed)
        try:
            actions = [Look(a) for a in range(a_count)]
            policy = Policy(actions)
            if self.kind == "pouct":
                init = TruthBelief([SearchState(-1, t, 0, looked) for t in range(len(problem.p))],
                                   problem.p)
            else:
                draws = np.random.default_rng(seed).choice(len(problem.p), size=self.simulations,
                                                           p=problem.p)
                init = pomdp_py.Particles([SearchState(-1, int(t), 0, looked) for t in draws])
            agent = pomdp_py.Agent(init, policy, Transition(problem, full), Observe(),
                                   Reward(problem, full))
            cls = pomdp_py.POUCT if self.kind == "pouct" else pomdp_py.POMCP
            planner = cls(max_depth=2 * a_count, planning_time=-1.0, num_sims=self.simulations,
                          discount_factor=1.0, exploration_const=EXPLORATION,
                          num_visits_init=0, value_init=0, rollout_policy=policy)
            action = planner.plan(agent)
            stats = {}
            for x in actions:
                node = agent.tree[x] if x in agent.tree.children else None
                if node is not None and node.num_visits > 0:
                    stats[x.a] = (-float(node.value), int(node.num_visits))
        finally:
            random.setstate(saved)
        q = belief.location_matrix()[[belief.objects.index(o) for o in objects]]
        candidates = []
        for a, (value, visits) in sorted(stats.items()):
            i = int(np.argmax((q * problem.probability[a]).sum(axis=1)))
            candidates.append(Candidate(objects[i], problem.names[a],
                                        float(problem.start[a]), float((q[i] * problem.probability[a][i]).sum()),
                                        0.0, int(inspected.get(problem.names[a], 0)),
                                        float(relevance[objects[i]]), float(visits), value,
                                        problem.kinds[a]))
        chosen = next((c for c in candidates if c.viewpoint == problem.names[action.a]), None)
        if chosen is None:  # the chosen action was never simulated (tiny budgets)
            i = 0
            chosen = Candidate(objects[i], problem.names[action.a], float(problem.start[action.a]),
                               0.0, 0.0, 0, float(relevance[objects[i]]), 0.0, 0.0,
                               problem.kinds[action.a])
            candidates.append(chosen)
        values = sorted(c.total for c in candidates)
        info = {"simulations": self.simulations, "seed": seed, "truths": int(len(problem.p)),
                "best_value": values[0], "second_value": values[1] if len(values) > 1 else values[0],
                "exploration": EXPLORATION, "look_cost": self.look}
        return Decision(chosen.object, chosen.viewpoint, chosen.total, tuple(candidates), self.name, info)


def make_peer(kind: str, spec: str, model: Model, rng: np.random.Generator | None) -> PeerPlanner:
    """``pouct:N`` / ``pomcp:N`` -> a :class:`PeerPlanner` (raises ValueError on a bad N)."""
    if not (spec.isdigit() and int(spec) >= 1):
        raise ValueError(f"planner {kind}:{spec}: the setting is the number of simulations per "
                         "decision, a positive integer")
    return PeerPlanner(kind, int(spec), rng)


__all__ = ["PeerPlanner", "make_peer", "EXPLORATION"]
