"""The belief engine: what is probably where, and which hidden states probably hold?

Only this module writes beliefs. It keeps two independent blocks of one factor graph:

- the **location block**: one variable ``L[o]`` per object over the K sites (the site where o
  stood when the episode began). Factors: the prior [eq. 2], every detection [4] and miss [5, 6],
  and, in joint models, relational factors (capacity, co-location). Factorised models have no
  relational factors, so each marginal is the blueprint's closed form.
- the **state block**: Bernoulli task states (``kettle.contains_water``...). Factors: priors,
  noisy readings [23, 24] and action transitions P(z'|z,a) [27] (or the direct form [25, 26]).
  A transition creates a new time slice of the states it touches and sums the old slice out at
  once, so the graph stays one factor over the current slice.

Exact answers come from a solver (:mod:`fg_tea.beliefs.solvers`): ``backend="gtsam"`` runs every
query through gtsam's discrete elimination (the engine of record); ``backend="numpy"`` (default)
answers the same queries from dense tables and closed forms, and :meth:`BeliefEngine.check_against_gtsam`
measures their agreement. Hypothetical evidence (what the planner asks dozens of times per
decision) is answered in one vectorised step from single and pairwise marginals, without
mutating the belief.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Iterable, Mapping, Sequence

import numpy as np

from fg_tea.beliefs.factors import (Factor, collapse_factor, collapse_target, detection_factor,
                                    effect_factor, location_var, miss_factor, state_observation,
                                    state_prior)
from fg_tea.beliefs.graph import BeliefGraph, build_graph
from fg_tea.beliefs.solvers import GtsamSolver, NumpySolver
from fg_tea.errors import ContradictionError
from fg_tea.model import Effect, Model, Sensor
from fg_tea.scenario import Scenario

DENSE_LIMIT = 1 << 22  # largest joint location table (K^N entries) held densely
MAX_STATES = 20        # Bernoulli states held jointly in the state block


def entropy(p: np.ndarray) -> float:
    """Shannon entropy in nats, eq. 7 (and eq. 22 for a Bernoulli [1-p, p])."""
    p = np.asarray(p, dtype=float)
    nz = p[p > 0]
    return float(-(nz * np.log(nz)).sum())


@dataclass(frozen=True)
class SiteUpdate:
    """The effect of one inspection on the location beliefs.

    Attributes:
        site: the inspected site.
        detections: the observation, object -> True (seen) / False (looked, not seen).
        before, after: location marginals of every object before and after.
        detected: objects seen at the site, in object order.
    """

    site: str
    detections: Mapping[str, bool]
    before: Mapping[str, np.ndarray]
    after: Mapping[str, np.ndarray]
    detected: tuple[str, ...] = ()


@dataclass(frozen=True)
class StateUpdate:
    """Belief in each touched state, before and after an observation or transition."""

    kind: str
    before: Mapping[str, float]
    after: Mapping[str, float]
    detail: Mapping[str, object] = field(default_factory=dict)


class BeliefEngine:
    """Exact beliefs over object locations and task states for one scenario and model.

    Args:
        scenario: the house (only its priors are read, never its truth).
        model: the agent's generative model.
        backend: ``"numpy"`` (fast exact path) or ``"gtsam"`` (every query through gtsam).
    """

    def __init__(self, scenario: Scenario | BeliefGraph, model: Model, backend: str = "numpy") -> None:
        import gtsam

        if backend not in ("numpy", "gtsam"):
            raise ValueError(f"unknown belief backend {backend!r}; use 'numpy' or 'gtsam'")
        graph = scenario if isinstance(scenario, BeliefGraph) else build_graph(scenario, model)
        self.model = model
        self.graph = graph
        self.backend = backend
        self.sites = graph.sites
        self.objects = graph.objects
        self._site_index = {s: i for i, s in enumerate(self.sites)}
        self._obj_index = {o: i for i, o in enumerate(self.objects)}
        k = len(self.sites)
        self._cards: dict[str, int] = {location_var(o): k for o in self.objects}
        self._keys: dict[str, int] = {location_var(o): gtsam.symbol("l", i)
                                      for i, o in enumerate(self.objects)}
        self._loc_factors: list[Factor] = list(graph.location_priors)
        self._unary = np.stack([f.table for f in graph.location_priors])
        self._relational = list(graph.relational)
        self._rel_joint: np.ndarray | None = None
        if self._relational:
            if k ** len(self.objects) > DENSE_LIMIT:
                raise ValueError(f"joint model with {len(self.objects)} objects over {k} sites has "
                                 f"{k ** len(self.objects):,} joint states, more than the dense "
                                 f"limit {DENSE_LIMIT:,}")
            self._rel_joint = NumpySolver().contract(
                self._relational, [location_var(o) for o in self.objects], self._cards)
        self._serial = 0
        self._slice: dict[str, str] = {}
        self._state_factors: list[Factor] = []
        for f in graph.state_priors:
            self._add_state(f.variables[0], f.table[1])
        self._cache: dict[str, object] = {}

    # ------------------------------------------------------------------ bookkeeping
    def copy(self) -> "BeliefEngine":
        """An independent copy (hypotheses can be applied to it freely)."""
        other = copy.copy(self)
        other._loc_factors = list(self._loc_factors)
        other._unary = self._unary.copy()
        other._slice = dict(self._slice)
        other._state_factors = list(self._state_factors)
        other._cards = dict(self._cards)
        other._keys = dict(self._keys)
        other._cache = dict(self._cache)
        return other

    def _solver(self, backend: str | None = None):
        return GtsamSolver(self._keys) if (backend or self.backend) == "gtsam" else NumpySolver()

    def _add_state(self, state: str, p_true: float) -> None:
        import gtsam

        name = f"{state}@{self._serial}"
        self._keys[name] = gtsam.symbol("z", self._serial)
        self._cards[name] = 2
        self._serial += 1
        self._slice[state] = name
        self._state_factors.append(state_prior(name, float(p_true)))
        if len(self._slice) > MAX_STATES:
            raise ValueError(f"more than {MAX_STATES} task states in one belief")

    def ensure_state(self, state: str, prior: float = 0.5) -> None:
        """Declare a new Bernoulli state (objects can gain states, e.g. a cupboard's ``open``)."""
        if state not in self._slice:
            self._add_state(state, prior)
            self._cache.pop("states", None)

    # ------------------------------------------------------------------ location queries
    def _location_marginals(self) -> np.ndarray:
        cached = self._cache.get("locations")
        if cached is None:
            if self.backend == "gtsam":
                names = [location_var(o) for o in self.objects]
                marg = self._solver().marginals(self._loc_factors + self._relational, names, self._cards)
                cached = np.stack([marg[n] for n in names])
            elif self._rel_joint is None:
                cached = self._unary / self._unary.sum(axis=1, keepdims=True)
            else:
                joint = self.location_joint()
                n = len(self.objects)
                cached = np.stack([joint.sum(axis=tuple(a for a in range(n) if a != i))
                                   for i in range(n)])
            self._cache["locations"] = cached
        return cached

    def location(self, obj: str) -> np.ndarray:
        """q(L_o = i) for every site i (a fresh array, sums to 1)."""
        return self._location_marginals()[self._obj_index[obj]].copy()

    def locations(self) -> dict[str, np.ndarray]:
        m = self._location_marginals()
        return {o: m[i].copy() for i, o in enumerate(self.objects)}

    def location_matrix(self) -> np.ndarray:
        """Location marginals as an (N objects, K sites) array."""
        return self._location_marginals().copy()

    def location_joint(self) -> np.ndarray:
        """The exact joint P(L_1, ..., L_N) as an array of shape (K,) * N."""
        cached = self._cache.get("joint")
        if cached is None:
            n, k = self._unary.shape
            if k ** n > DENSE_LIMIT:
                raise ValueError(f"the joint over {n} objects x {k} sites is too large to hold densely")
            operands: list = []
            for i in range(n):
                operands += [self._unary[i], [i]]
            if self._rel_joint is not None:
                operands += [self._rel_joint, list(range(n))]
            table = np.einsum(*operands, list(range(n)))
            total = table.sum()
            if not np.isfinite(total) or total <= 0:
                raise ContradictionError("location evidence has probability zero under the model")
            cached = table / total
            self._cache["joint"] = cached
        return cached

    def pairwise(self) -> np.ndarray:
        """P(L_o = a, L_p = b) as an array of shape (N, N, K, K); diagonal blocks are diag(q_o)."""
        cached = self._cache.get("pairwise")
        if cached is None:
            m = self._location_marginals()
            n, k = m.shape
            cached = np.empty((n, n, k, k))
            joint = self.location_joint() if self._rel_joint is not None else None
            for o in range(n):
                cached[o, o] = np.diag(m[o])
                for p in range(o + 1, n):
                    if joint is None:
                        block = np.outer(m[o], m[p])
                    else:
                        block = joint.sum(axis=tuple(a for a in range(n) if a not in (o, p)))
                    cached[o, p], cached[p, o] = block, block.T
            self._cache["pairwise"] = cached
        return cached

    @property
    def correlated(self) -> bool:
        """True when location variables are coupled by relational factors."""
        return bool(self._relational)

    # ------------------------------------------------------------------ state queries
    def _state_marginals(self) -> dict[str, float]:
        cached = self._cache.get("states")
        if cached is None:
            names = list(self._slice.values())
            marg = self._solver().marginals(self._state_factors, names, self._cards)
            cached = {s: float(marg[v][1]) for s, v in self._slice.items()}
            self._cache["states"] = cached
        return cached

    def state(self, name: str) -> float:
        """q(z = true) for a task state such as ``kettle.contains_water``."""
        try:
            return self._state_marginals()[name]
        except KeyError:
            raise KeyError(f"no task state {name!r} in the belief (known: "
                           f"{', '.join(sorted(self._slice))})") from None

    def states(self) -> dict[str, float]:
        return dict(self._state_marginals())

    def has_state(self, name: str) -> bool:
        return name in self._slice

    def state_joint(self, names: Sequence[str]) -> np.ndarray:
        """The joint of a few task states, shape (2,) * len(names), axis order as given."""
        return self._solver().joint(self._state_factors, [self._slice[n] for n in names], self._cards)

    # ------------------------------------------------------------------ generic queries
    def marginal(self, var: str) -> np.ndarray:
        """Marginal of a variable by name: ``L[mug]`` or ``kettle.contains_water``."""
        if var.startswith("L[") and var.endswith("]"):
            return self.location(var[2:-1])
        p = self.state(var)
        return np.array([1.0 - p, p])

    def entropy(self, var: str) -> float:
        """Entropy (nats) of one variable's marginal, eqs. 7 and 22."""
        return entropy(self.marginal(var))

    def joint(self, variables: Sequence[str]) -> np.ndarray:
        """The joint of a few variables of one block (all locations, or all states)."""
        if all(v.startswith("L[") for v in variables):
            names = [location_var(o) for o in self.objects]
            full = self.location_joint()
            axes = [names.index(v) for v in variables]
            other = tuple(a for a in range(len(names)) if a not in axes)
            reduced = full.sum(axis=other)
            order = sorted(axes)
            return np.moveaxis(reduced, [order.index(a) for a in axes], list(range(len(axes))))
        if any(v.startswith("L[") for v in variables):
            raise ValueError("locations and task states are independent blocks; ask each separately")
        return self.state_joint(variables)

    # ------------------------------------------------------------------ location evidence
    def _commit_location(self, factors: Iterable[Factor]) -> None:
        for f in factors:
            o = self._obj_index[f.variables[0][2:-1]]
            row = self._unary[o] * f.table
            total = row.sum()
            if not np.isfinite(total) or total <= 0:
                raise ContradictionError(f"evidence {f.label} has probability zero under the model")
            self._unary[o] = row / total
            self._loc_factors.append(f)
            self._cache.pop("locations", None)
            self._cache.pop("joint", None)
            self._cache.pop("pairwise", None)

    def observe_site(self, site: str, detections: Mapping[str, bool]) -> SiteUpdate:
        """Absorb one inspection of `site`: True = seen there, False = looked and not seen.

        An object absent from `detections` is "no observation" and its evidence is unchanged.
        Misses are applied first (they commute); then detections, in object order.

        Raises:
            ContradictionError: the evidence has probability zero; the belief is left unchanged.
        """
        if site not in self._site_index:
            raise KeyError(f"no site named {site!r}")
        for obj in detections:
            if obj not in self._obj_index:
                raise KeyError(f"no object named {obj!r}")
        j, k = self._site_index[site], len(self.sites)
        before = self.locations()
        saved = (self._unary.copy(), list(self._loc_factors), dict(self._cache))
        try:
            misses = [miss_factor(o, j, k, self.model.miss_likelihood)
                      for o in self.objects if detections.get(o) is False]
            self._commit_location(misses)
            for o in self.objects:
                if detections.get(o) is True:
                    if self.model.positive_update == "blueprint":
                        f = collapse_factor(o, j, self.location(o), self.model.prior_floor)
                    else:
                        f = detection_factor(o, j, k, self.model.miss_likelihood,
                                             self.model.false_positive_rate)
                    self._commit_location([f])
            after = self.locations()
        except ContradictionError:
            self._unary, self._loc_factors, self._cache = saved
            raise
        detected = tuple(o for o in self.objects if detections.get(o) is True)
        return SiteUpdate(site, dict(detections), before, after, detected)

    # ------------------------------------------------------------------ hypothetical evidence
    def hypothetical(self, site: str, detections: Mapping[str, bool]) -> dict[str, np.ndarray]:
        """Location marginals *if* `site` were inspected with this outcome; the belief is untouched."""
        return self.copy().observe_site(site, detections).after

    def hypothetical_all(self) -> tuple[np.ndarray, np.ndarray]:
        """Every single-object hypothesis at every site, in one vectorised step.

        Returns:
            (miss, seen): arrays of shape (N, K, N, K). ``miss[o, j, p]`` is q(L_p) after "o not
            seen at site j"; ``seen[o, j, p]`` is q(L_p) after "o seen at site j". Exact: an
            observation touches one variable, so P(L_p | obs on o) = sum_a P(L_p, L_o = a) l(a) /
            sum_a P(L_o = a) l(a), from the pairwise marginals.
        """
        m = self._location_marginals()
        pw = self.pairwise()
        n, k = m.shape
        mu = self.model.miss_likelihood
        # Miss at j: l(a) = 1 - (1 - mu)[a = j].
        z_miss = 1.0 - (1.0 - mu) * m  # (o, j)
        miss = (m[None, None, :, :] - (1.0 - mu) * np.transpose(pw, (0, 2, 1, 3))) / z_miss[:, :, None, None]
        # Seen at j.
        if self.model.positive_update == "blueprint":
            floor = self.model.prior_floor
            targets = np.stack([collapse_target(j, k, floor) for j in range(k)])  # (j, a)
            cond = pw / m[:, None, :, None]  # P(L_p = b | L_o = a): (o, p, a, b)
            seen = np.einsum("ja,opab->ojpb", targets, cond)
        else:
            lik = np.full((k, k), self.model.false_positive_rate)
            np.fill_diagonal(lik, 1.0 - mu)  # (j, a)
            num = np.einsum("ja,opab->ojpb", lik, pw)
            seen = num / np.einsum("ja,oa->oj", lik, m)[:, :, None, None]
        return miss, seen

    # ------------------------------------------------------------------ state evidence and actions
    def _commit_states(self, factors: list[Factor], kind: str, touched: Sequence[str],
                       detail: Mapping[str, object]) -> StateUpdate:
        before = {s: self.state(s) for s in touched}
        saved = (list(self._state_factors), dict(self._slice), dict(self._cache))
        self._state_factors = factors
        self._cache.pop("states", None)
        try:
            after = {s: self.state(s) for s in touched}
        except ContradictionError:
            self._state_factors, self._slice, self._cache = saved
            raise
        return StateUpdate(kind, before, after, detail)

    def observe_state(self, state: str, value: bool, sensor: Sensor) -> StateUpdate:
        """Absorb a noisy binary reading of `state` (eqs. 23, 24).

        Raises:
            ContradictionError: the reading has probability zero under the belief (unchanged).
        """
        var = self._slice[state] if state in self._slice else None
        if var is None:
            raise KeyError(f"no task state {state!r} in the belief")
        f = state_observation(var, bool(value), sensor.sensitivity, sensor.specificity)
        return self._commit_states(self._state_factors + [f], "observe", [state],
                                   {"state": state, "value": bool(value),
                                    "sensitivity": sensor.sensitivity,
                                    "specificity": sensor.specificity})

    def apply_effects(self, effects: Sequence[Effect], direct: bool | None = None) -> StateUpdate:
        """Advance the task states through one action's effects, P(z'|z,a) (eq. 27).

        `effects` carry concrete state names (role templates already filled in). Each target gets
        a new time slice; all effects read the old slice; then the old slices of the targets are
        summed out, leaving one factor over the current slice.

        Args:
            effects: the action's effects.
            direct: use the blueprint's direct form q'(z) = rho (eqs. 25, 26); default: the model's.
        """
        import gtsam

        direct = (self.model.transition_form == "direct") if direct is None else direct
        targets = [e.state for e in effects]
        if len(set(targets)) != len(targets):
            raise ValueError(f"an action sets one state twice: {targets}")
        for e in effects:
            for s in (e.state, *e.requires):
                if s not in self._slice:
                    raise KeyError(f"effect refers to unknown task state {s!r}")
        new_names, factors = {}, []
        for e in effects:
            name = f"{e.state}@{self._serial}"
            self._keys[name] = gtsam.symbol("z", self._serial)
            self._cards[name] = 2
            self._serial += 1
            new_names[e.state] = name
            factors.append(effect_factor(name, self._slice[e.state],
                                         tuple(self._slice[r] for r in e.requires),
                                         e.value, e.success, direct))
        old = [self._slice[t] for t in targets]
        merged = self._solver().sum_out(self._state_factors + factors, old, self._cards,
                                        "states after " + ", ".join(targets))
        before = {s: self.state(s) for s in targets}
        saved = (list(self._state_factors), dict(self._slice), dict(self._cache))
        self._slice.update(new_names)
        self._state_factors = [merged]
        self._cache.pop("states", None)
        try:
            after = {s: self.state(s) for s in targets}
        except ContradictionError:
            self._state_factors, self._slice, self._cache = saved
            raise
        return StateUpdate("transition", before, after,
                           {"form": "direct" if direct else "full",
                            "effects": [{"state": e.state, "value": e.value, "success": e.success,
                                         "requires": list(e.requires)} for e in effects]})

    # ------------------------------------------------------------------ inspection and checks
    def factor_labels(self) -> list[str]:
        """What the current graph holds, factor by factor (location block, then state block)."""
        return [f.label for f in self._loc_factors + self._relational + self._state_factors]

    def map_estimate(self) -> dict[str, str]:
        """The most probable joint arrangement of objects (gtsam max-product)."""
        assignment = GtsamSolver(self._keys).map_assignment(self._loc_factors + self._relational, self._cards)
        return {o: self.sites[assignment[location_var(o)]] for o in self.objects}

    def check_against_gtsam(self) -> float:
        """Largest absolute difference between this engine's marginals and gtsam's."""
        ref = GtsamSolver(self._keys)
        names = [location_var(o) for o in self.objects]
        loc = ref.marginals(self._loc_factors + self._relational, names, self._cards)
        diff = max(float(np.max(np.abs(loc[location_var(o)] - self.location(o)))) for o in self.objects)
        states = ref.marginals(self._state_factors, list(self._slice.values()), self._cards)
        for s, v in self._slice.items():
            diff = max(diff, abs(float(states[v][1]) - self.state(s)))
        return diff

    def snapshot(self, digits: int | None = None) -> dict:
        """A JSON-serialisable picture of the belief: location marginals and state probabilities."""
        def r(x: float) -> float:
            return round(float(x), digits) if digits is not None else float(x)

        return {
            "sites": list(self.sites),
            "locations": {o: [r(x) for x in q] for o, q in self.locations().items()},
            "states": {s: r(p) for s, p in sorted(self.states().items())},
            "entropy": {o: r(entropy(q)) for o, q in self.locations().items()},
        }
