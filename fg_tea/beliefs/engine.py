"""The belief engine: what is probably where, and which hidden states probably hold?

Only this module writes beliefs. It keeps two independent blocks of one factor graph:

- the **location block**: one variable ``L[o]`` per object over the K sites (the site where o
  stood when the episode began). Factors: the prior [eq. 2], every detection [4] and miss [5, 6],
  and, in joint models, relational factors (capacity, co-location, exclusivity). Factorised
  models have no relational factors, so each marginal is a closed form (docs/design.md §4.2).
- the **state block**: Bernoulli task states (``kettle.contains_water``...). Factors: priors,
  noisy readings [23, 24] and action transitions P(z'|z,a) [27] (or the direct form [25, 26]).
  A transition creates a new time slice of the states it touches and sums the old slice out at
  once, so the graph stays one factor over the current slice.

Exact answers come from a solver (:mod:`fg_tea.beliefs.solvers`): ``backend="gtsam"`` runs every
query through gtsam's discrete elimination (the engine of record); ``backend="numpy"`` (default)
answers the same queries from closed forms (factorised models), the dense K^N joint table (small
joint models), the subset dynamic program of :mod:`fg_tea.beliefs.structured` (joint models
whose relational factors are site- or room-local, at any size up to its object limit) or variable
elimination (:mod:`fg_tea.beliefs.eliminated`: extra factors of any scope, joints too big to hold),
and :meth:`BeliefEngine.check_against_gtsam` measures their agreement. Hypothetical evidence (what
the planner asks dozens of times per decision) is answered in one vectorised step from single
and pairwise marginals, without mutating the belief.
"""

from __future__ import annotations

import copy
import math
from contextlib import contextmanager
from typing import Any, Iterable, Iterator, Mapping, Sequence

import numpy as np

from fg_tea.beliefs.factors import (
    Evidence,
    Factor,
    collapse_factor,
    collapse_target,
    detection_factor,
    log_ratio_gap,
    effect_factor,
    location_var,
    merge_evidence,
    miss_factor,
    state_observation,
    state_prior,
    view_miss_factor,
)
from fg_tea.beliefs.graph import (DENSE_LIMIT, BeliefGraph, build_graph, check_exact_method,
                                  pair_weight_matrices)
from fg_tea.beliefs.eliminated import EliminatedLocationModel, eliminated_model, elimination_plan
from fg_tea.beliefs.occlusion import CompanyEvidence, alone_miss
from fg_tea.beliefs.solvers import GtsamSolver, NumpySolver
from fg_tea.beliefs.structured import (
    MAX_OBJECTS,
    NumericalGuardError,
    PairWeights,
    StructuredLocationModel,
)
from fg_tea.beliefs.updates import LookUpdate, StateUpdate  # noqa: F401 - re-exported
from fg_tea.common.errors import ContradictionError
from fg_tea.common.stats import entropy
from fg_tea.model.spec import Effect, Model, Sensor
from fg_tea.world.scenario import MAX_STATES, Scenario  # noqa: F401 - MAX_STATES re-exported

GTSAM_MAP_LIMIT = 1 << 16   # joint states above which MAP uses the structured max-product chain
DENSE_PREFERRED = 50_000    # joint states up to which "auto" prefers the dense joint table
#: Several objects seen in one look (eq. 4 for each, docs/design.md §3.2): the collapses are
#: repeated in sweeps (iterative proportional fitting) until every seen object's marginal is its
#: eq. 4 target to this relative tolerance (:func:`log_ratio_gap`), or a sweep no longer shrinks
#: the gap. The fixed point, the joint closest in KL with all those marginals, is order-free.
JOINT_COLLAPSE_TOLERANCE = 1e-13
#: Sweeps allowed before the fit stops; IPF converges geometrically, and the bundled houses need
#: fewer than 20 (one sweep when the objects are independent).
JOINT_COLLAPSE_SWEEPS = 500


class UnknownVariableError(KeyError):
    """A belief query named an object, state or variable the belief does not hold.

    A ``KeyError`` (as before), whose message names the valid names in full.
    """

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class BeliefEngine:
    """Exact beliefs over object locations and task states for one scenario and model.

    Args:
        scenario: the house (only its priors are read, never its truth), or a prebuilt graph.
        model: the agent's generative model.
        backend: ``"numpy"`` (fast exact path) or ``"gtsam"`` (every location and state query,
            hypothetical ones included, re-solved through gtsam's discrete elimination).
        location_solver: how the numpy backend solves a joint location block: ``"auto"`` (the
            cheapest exact method), ``"dense"`` (the K^N joint table), ``"structured"`` (the
            subset dynamic program of :mod:`fg_tea.beliefs.structured`) or ``"elimination"``
            (variable elimination, :mod:`fg_tea.beliefs.eliminated`; auto's choice for extra
            factors over a joint above 250,000 states).

    Raises:
        ValueError: unknown backend or solver, or a joint model that no exact method can hold
            (relational factors that are not site/room-local over more than
            :data:`DENSE_LIMIT` joint states), or one whose elimination exceeds its budget
            (:class:`~fg_tea.beliefs.eliminated.EliminationRefused`, one line).
    """

    def __init__(self, scenario: Scenario | BeliefGraph, model: Model, backend: str = "numpy",
                 location_solver: str = "auto") -> None:
        import gtsam

        if backend not in ("numpy", "gtsam"):
            raise ValueError(f"unknown belief backend {backend!r}; use 'numpy' or 'gtsam'")
        if location_solver not in ("auto", "dense", "structured", "elimination"):
            raise ValueError(f"unknown location solver {location_solver!r}; "
                             "use 'auto', 'dense', 'structured' or 'elimination'")
        graph = scenario if isinstance(scenario, BeliefGraph) else build_graph(scenario, model)
        self.model = model
        self.graph = graph
        self.backend = backend
        self.sites = graph.sites
        self.objects = graph.objects
        self._site_index = {s: i for i, s in enumerate(self.sites)}
        self._obj_index = {o: i for i, o in enumerate(self.objects)}
        n, k = len(self.objects), len(self.sites)
        self._cards: dict[str, int] = {location_var(o): k for o in self.objects}
        self._keys: dict[str, int] = {location_var(o): gtsam.symbol("l", i)
                                      for i, o in enumerate(self.objects)}
        self._loc_factors: list[Factor] = list(graph.location_priors)
        self._unary = np.stack([f.table / f.table.sum() for f in graph.location_priors])
        self._correlated = graph.correlated
        self._pair_weights = pair_weight_matrices(graph)
        self._structurable = (self._correlated and not graph.extra and n <= MAX_OBJECTS
                              and bool(np.all(self._pair_weights.same_room > 0)))
        self._dense_ok = graph.joint_size <= DENSE_LIMIT
        self._elim_plan = elimination_plan(graph, self._pair_weights, location_solver)
        if self._elim_plan is None:
            check_exact_method(graph, self._structurable, location_solver)
        self.location_solver = location_solver
        self._rel_joint: np.ndarray | None = None
        self._company: CompanyEvidence | None = None  # coupled looks under occlusion (eq. 59)
        self._serial = 0
        self._slice: dict[str, str] = {}
        self._state_factors: list[Factor] = []
        for f in graph.state_priors:
            self._add_state(f.variables[0], f.table[1])
        self._cache: dict[str, Any] = {}

    # ------------------------------------------------------------------ bookkeeping
    @contextmanager
    def _trial(self) -> Iterator[None]:
        """Evidence tried on the belief: if anything in the block raises (a contradiction, an
        interrupt), the belief is restored exactly as it was, and the exception goes on."""
        saved = (self._unary.copy(), list(self._loc_factors), list(self._state_factors),
                 dict(self._slice), dict(self._cache), self._company)
        try:
            yield
        except BaseException:
            (self._unary, self._loc_factors, self._state_factors, self._slice,
             self._cache, self._company) = saved
            raise

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

        if len(self._slice) >= MAX_STATES:
            raise ValueError(f"more than {MAX_STATES} task states in one belief")
        if not 0.0 <= float(p_true) <= 1.0:
            raise ValueError(f"prior {p_true} of {state!r} is outside [0, 1]")
        name = f"{state}@{self._serial}"
        self._keys[name] = gtsam.symbol("z", self._serial)
        self._cards[name] = 2
        self._serial += 1
        self._slice[state] = name
        self._state_factors = self._state_factors + [state_prior(name, float(p_true))]

    def ensure_state(self, state: str, prior: float = 0.5) -> None:
        """Declare a new Bernoulli state (objects can gain states, e.g. a cupboard's ``open``).

        Args:
            state: ``object.state`` name; nothing happens if it already exists.
            prior: q(state = true) before any evidence, in [0, 1].
        """
        if state not in self._slice:
            self._add_state(state, prior)
            self._cache.pop("states", None)

    # ------------------------------------------------------------------ location solvers
    def _method(self) -> str:
        """Which exact method answers location queries: independent, dense, structured,
        elimination (:mod:`fg_tea.beliefs.eliminated`) or gtsam."""
        if self.backend == "gtsam":
            return "gtsam"
        if not self._correlated:
            return "independent"
        if self._elim_plan is not None:
            return "elimination"
        if self.location_solver != "auto":
            return self.location_solver
        if not self._dense_ok:
            return "structured"
        if not self._structurable:
            return "dense"
        # Measured (experiments/bench_inference.py): below ~5e4 joint states the dense table is
        # cheaper than the subset program's per-site overhead; above, dense pairwise marginals
        # (~N^2 K^N) lose quickly to the program's ~(K + rooms^2) 3^N.
        return "dense" if self.graph.joint_size <= DENSE_PREFERRED else "structured"

    @property
    def location_method(self) -> str:
        """The exact method answering location queries (``independent``, ``dense``,
        ``structured``, ``elimination`` or ``gtsam``)."""
        return self._method()

    def _relational_joint(self) -> np.ndarray:
        if self._rel_joint is None:
            self._rel_joint = NumpySolver().contract(
                list(self.graph.relational), [location_var(o) for o in self.objects], self._cards)
        return self._rel_joint

    def _structured(self) -> StructuredLocationModel:
        cached = self._cache.get("structured")
        if cached is None:
            g = self.graph
            cached = StructuredLocationModel(self._unary, g.rooms, g.capacities,
                                             g.capacity_penalty if g.capacity_active else None,
                                             self._pair_weights,
                                             previous=self._cache.get("structured_previous"),
                                             site_weights=None if self._company is None
                                             else self._company.weights)
            self._cache["structured"] = cached
        return cached

    def _eliminated(self) -> EliminatedLocationModel:
        if "eliminated" not in self._cache:
            assert self._elim_plan is not None
            self._cache["eliminated"] = eliminated_model(self._elim_plan, self.graph, self._pair_weights,
                                                         self._unary, self._company)
        return self._cache["eliminated"]

    def eliminated_model(self) -> EliminatedLocationModel | None:
        """The elimination method's queries (:mod:`fg_tea.beliefs.eliminated`), or None under another."""
        return self._eliminated() if self._method() == "elimination" else None

    def structured_model(self) -> StructuredLocationModel | None:
        """The subset dynamic program of the current location belief (docs/design.md §4.4).

        Factorised beliefs get one without relational factors (exact for them too). Returns None
        when the relational factors are not site/room-local or there are more than
        :data:`~fg_tea.beliefs.structured.MAX_OBJECTS` objects. The object is cached until the
        next location evidence; treat it as read only.
        """
        if self._correlated:
            return self._structured() if self._structurable else None
        if len(self.objects) > MAX_OBJECTS:
            return None
        cached = self._cache.get("structured")
        if cached is None:
            cached = StructuredLocationModel(self._unary, self.graph.rooms, self.graph.capacities,
                                             None, None,
                                             previous=self._cache.get("structured_previous"))
            self._cache["structured"] = cached
        return cached

    @property
    def pair_weights(self) -> PairWeights:
        """Same-site and same-room weights between objects (eq. 35), belief order; 1 = none."""
        return self._pair_weights

    def _location_factors(self) -> list[Factor]:
        company = [] if self._company is None else [Factor(
            tuple(location_var(o) for o in self.objects), self._company.dense(), "company")]
        return self._loc_factors + list(self.graph.relational) + company

    def _gtsam_marginals(self, factors: Sequence[Factor]) -> np.ndarray:
        names = [location_var(o) for o in self.objects]
        marg = GtsamSolver(self._keys).marginals(factors, names, self._cards)
        return np.stack([marg[v] for v in names])

    # ------------------------------------------------------------------ location queries
    def _location_marginals(self) -> np.ndarray:
        cached = self._cache.get("locations")
        if cached is None:
            method = self._method()
            if method == "gtsam":
                cached = self._gtsam_marginals(self._location_factors())
            elif method == "independent":
                cached = self._unary / self._unary.sum(axis=1, keepdims=True)
            elif method == "structured":
                try:
                    cached = self._structured().singles()
                except NumericalGuardError:
                    if not self._dense_ok:
                        raise
                    cached = self._dense_marginals()
            elif method == "elimination":
                cached = self._eliminated().singles()
            else:
                cached = self._dense_marginals()
            self._cache["locations"] = cached
        return cached

    def _dense_marginals(self) -> np.ndarray:
        joint = self._dense_joint()
        n = len(self.objects)
        return np.stack([joint.sum(axis=tuple(a for a in range(n) if a != i)) for i in range(n)])

    # ------------------------------------------------------------------ names
    @property
    def state_names(self) -> tuple[str, ...]:
        """The task states the belief holds (``kettle.contains_water``...), sorted."""
        return tuple(sorted(self._slice))

    @property
    def variables(self) -> tuple[str, ...]:
        """Every variable name: ``L[o]`` for each object (in :attr:`objects` order), then states."""
        return tuple(location_var(o) for o in self.objects) + self.state_names

    def _names_hint(self) -> str:
        return (f"objects: {', '.join(self.objects)}; states: {', '.join(self.state_names) or 'none'}"
                f"; or L[object]")

    def variable(self, name: str) -> str:
        """The variable a query name stands for: an object (``mug`` -> ``L[mug]``), ``L[mug]``,
        or a task state (``kettle.contains_water``).

        Raises:
            UnknownVariableError: (a ``KeyError``) naming the valid objects and states.
        """
        if not isinstance(name, str):
            raise UnknownVariableError(f"expected a variable name (a string), got "
                                       f"{type(name).__name__}; {self._names_hint()}")
        if name in self._obj_index:
            return location_var(name)
        if name in self._slice:
            return name
        if name.startswith("L[") and name.endswith("]") and name[2:-1] in self._obj_index:
            return name
        raise UnknownVariableError(f"no object, task state or variable {name!r} in the belief "
                                   f"({self._names_hint()})")

    def _object(self, obj: str) -> int:
        try:
            return self._obj_index[obj]
        except (KeyError, TypeError):
            if isinstance(obj, str) and obj.startswith("L[") and obj[2:-1] in self._obj_index:
                return self._obj_index[obj[2:-1]]
            raise UnknownVariableError(f"no object {obj!r} in the belief (objects: "
                                       f"{', '.join(self.objects)})") from None

    def location(self, obj: str) -> np.ndarray:
        """q(L_o = i) for every site i, in :attr:`sites` order (a fresh array, sums to 1).

        Args:
            obj: an object name (``mug``; ``L[mug]`` is accepted too).

        Raises:
            UnknownVariableError: (a ``KeyError``) not an object of the belief.
        """
        return self._location_marginals()[self._object(obj)].copy()

    def location_map(self, obj: str) -> dict[str, float]:
        """q(L_o = site) as a mapping site name -> probability, in :attr:`sites` order.

        The labelled form of :meth:`location` (same numbers).
        """
        return {s: float(p) for s, p in zip(self.sites, self.location(obj))}

    def location_maps(self) -> dict[str, dict[str, float]]:
        """Every object's :meth:`location_map`, object -> (site -> probability)."""
        m = self._location_marginals()
        return {o: {s: float(p) for s, p in zip(self.sites, m[i])} for i, o in enumerate(self.objects)}

    def locations(self) -> dict[str, np.ndarray]:
        """Every object's location marginal, object -> (K,) array."""
        m = self._location_marginals()
        return {o: m[i].copy() for i, o in enumerate(self.objects)}

    def location_matrix(self) -> np.ndarray:
        """Location marginals as an (N objects, K sites) array."""
        return self._location_marginals().copy()

    def location_joint(self) -> np.ndarray:
        """The exact joint P(L_1, ..., L_N) as an array of shape (K,) * N.

        Raises:
            ValueError: K^N exceeds :data:`DENSE_LIMIT` (single and pairwise marginals —
                :meth:`location_matrix`, :meth:`pairwise` — remain exact and available).
        """
        return self._dense_joint()

    def _dense_joint(self) -> np.ndarray:
        cached = self._cache.get("joint")
        if cached is None:
            n, k = self._unary.shape
            if k ** n > DENSE_LIMIT:
                raise ValueError(f"the joint over {n} objects x {k} sites has {k ** n:,} states, "
                                 f"more than the dense limit {DENSE_LIMIT:,}; single and pairwise "
                                 "marginals (location_matrix(), pairwise()) are still exact")
            operands: list = []
            for i in range(n):
                operands += [self._unary[i], [i]]
            if self._correlated:
                operands += [self._relational_joint(), list(range(n))]
            if self._company is not None:
                operands += [self._company.dense(), list(range(n))]
            table = np.einsum(*operands, list(range(n)))
            total = table.sum()
            if not np.isfinite(total) or total <= 0:
                raise ContradictionError("location evidence has probability zero under the model")
            cached = table / total
            self._cache["joint"] = cached
        return cached

    def pairwise(self) -> np.ndarray:
        """P(L_o = a, L_p = b) as an array of shape (N, N, K, K); diagonal blocks are diag(q_o)."""
        return self._pairwise().copy()

    def _pairwise(self) -> np.ndarray:
        cached = self._cache.get("pairwise")
        if cached is None:
            method = self._method()
            m = self._location_marginals()
            n, k = m.shape
            if method == "elimination":
                cached = self._eliminated().pairwise()
            elif method == "structured":
                try:
                    cached = self._structured().pairwise()
                except NumericalGuardError:
                    if not self._dense_ok:
                        raise
                    method = "dense"
            if cached is None:
                cached = np.empty((n, n, k, k))
                joint = self._dense_joint() if method == "dense" else None
                factors = self._location_factors() if method == "gtsam" else None
                for o in range(n):
                    cached[o, o] = np.diag(m[o])
                    for p in range(o + 1, n):
                        if method == "independent":
                            block = np.outer(m[o], m[p])
                        elif method == "gtsam":
                            assert factors is not None
                            block = GtsamSolver(self._keys).joint(
                                factors, [location_var(self.objects[o]),
                                          location_var(self.objects[p])], self._cards)
                        else:
                            assert joint is not None
                            block = joint.sum(axis=tuple(a for a in range(n) if a not in (o, p)))
                        cached[o, p], cached[p, o] = block, block.T
            self._cache["pairwise"] = cached
        return cached

    @property
    def correlated(self) -> bool:
        """True when location variables are coupled by relational factors."""
        return self._correlated

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
        except (KeyError, TypeError):
            raise UnknownVariableError(f"no task state {name!r} in the belief (states: "
                                       f"{', '.join(self.state_names) or 'none'})") from None

    def states(self) -> dict[str, float]:
        """q(z = true) of every task state, name -> probability."""
        return dict(self._state_marginals())

    def has_state(self, name: str) -> bool:
        """True when the belief holds task state `name`."""
        return name in self._slice

    def state_joint(self, names: Sequence[str]) -> np.ndarray:
        """The joint of a few task states, shape (2,) * len(names), axis order as given."""
        for name in names:
            if name not in self._slice:
                raise UnknownVariableError(f"no task state {name!r} in the belief (states: "
                                           f"{', '.join(self.state_names) or 'none'})")
        return self._solver().joint(self._state_factors, [self._slice[n] for n in names], self._cards)

    # ------------------------------------------------------------------ generic queries
    def marginal(self, var: str) -> np.ndarray:
        """Marginal of a variable by name: an object (``mug`` or ``L[mug]``; shape (K,), sites
        in :attr:`sites` order) or a task state (``kettle.contains_water``; [q(false), q(true)]).

        Raises:
            UnknownVariableError: (a ``KeyError``) naming the valid objects and states.
        """
        var = self.variable(var)
        if var.startswith("L[") and var.endswith("]"):
            return self.location(var[2:-1])
        p = self.state(var)
        return np.array([1.0 - p, p])

    def entropy(self, var: str) -> float:
        """Entropy (nats) of one variable's marginal, eqs. 7 and 22; names as in :meth:`marginal`."""
        return entropy(self.marginal(var))

    def joint(self, variables: Sequence[str]) -> np.ndarray:
        """The joint of a few variables of one block (all locations, or all states).

        Variables are named as in :meth:`marginal` (``["mug", "kettle"]`` or
        ``["L[mug]", "L[kettle]"]``); axes follow the order given, each location axis in
        :attr:`sites` order. One or two location variables are answered from the single and
        pairwise marginals (so they work for joint models too large to hold densely); more need
        :meth:`location_joint`.

        Raises:
            UnknownVariableError: (a ``KeyError``) an unknown name, naming the valid ones.
            ValueError: a repeated variable, or locations mixed with task states.
        """
        if isinstance(variables, str):
            raise TypeError("joint() takes a list of variable names, e.g. ['mug', 'kettle']")
        variables = [self.variable(v) for v in variables]
        if all(v.startswith("L[") for v in variables):
            names = [location_var(o) for o in self.objects]
            for v in variables:
                if v not in names:
                    raise KeyError(f"no location variable {v!r}")
            axes = [names.index(v) for v in variables]
            if len(set(axes)) != len(axes):
                raise ValueError(f"repeated variable in {list(variables)}")
            if len(axes) == 1:
                return self._location_marginals()[axes[0]].copy()
            if len(axes) == 2:
                return self._pairwise()[axes[0], axes[1]].copy()
            if self._method() == "elimination":
                return self._eliminated().joint(axes).copy()
            full = self.location_joint()
            other = tuple(a for a in range(len(names)) if a not in axes)
            reduced = full.sum(axis=other)
            order = sorted(axes)
            return np.moveaxis(reduced, [order.index(a) for a in axes], list(range(len(axes))))
        if any(v.startswith("L[") for v in variables):
            raise ValueError("locations and task states are independent blocks; ask each separately")
        return self.state_joint(variables)

    # ------------------------------------------------------------------ location evidence
    def _commit_location(self, factors: Iterable[Factor]) -> None:
        """Multiply unary location evidence into the graph, in log space.

        Every object holds at most one :class:`~fg_tea.beliefs.factors.Evidence` factor: each new
        miss, detection or collapse is merged into it as a sum of logs, so the graph does not
        grow with the number of inspections and a thousand misses at one site stay exact (their
        product, mu^1000, is far below the smallest float). ``_unary[o]`` is the normalised
        prior x evidence, computed from the logs.
        """
        for f in factors:
            var = f.variables[0]
            o = self._obj_index[var[2:-1]]
            pos = next((i for i, g in enumerate(self._loc_factors)
                        if isinstance(g, Evidence) and g.variables == (var,)), None)
            merged = merge_evidence(None if pos is None else _as_evidence(self._loc_factors[pos]), f)
            log_row = self._log_prior(o) + merged.log_table
            top = float(np.max(log_row))
            if not np.isfinite(top):
                raise ContradictionError(f"evidence {f.label} has probability zero under the model")
            row = np.exp(log_row - top)
            self._unary[o] = row / row.sum()
            if pos is None:
                self._loc_factors.append(merged)
            else:
                self._loc_factors[pos] = merged
            previous = self._cache.pop("structured", None)
            if previous is not None:     # rooms the evidence left unchanged are reused from it
                self._cache["structured_previous"] = previous
            for key in ("locations", "joint", "pairwise", "eliminated"):
                self._cache.pop(key, None)

    def _log_prior(self, o: int) -> np.ndarray:
        """log q0(L_o) (eq. 2), normalised; -inf where the prior is zero."""
        table = self.graph.location_priors[o].table
        with np.errstate(divide="ignore"):
            return np.log(table / table.sum())

    def _location_evidence(self, obj: str) -> Evidence | None:
        var = location_var(obj)
        return next((g for g in self._loc_factors
                     if isinstance(g, Evidence) and g.variables == (var,)), None)

    def unseen_probability(self, obj: str, excluded: Iterable[str] = ()) -> tuple[float | None, int]:
        """How much chance is left of finding `obj` by looking, and how many looks missed it.

        R_o = sum over sites j not in `excluded` of q0(L_o = j) x P(every look so far missed o |
        L_o = j): the probability, under o's prior (eq. 2) and the detection model (eqs. 5-6),
        that o stands at a reachable site and is still unseen (the search give-up rule of
        :class:`fg_tea.model.spec.PlanningWeights`). Computed from the merged log evidence, so it is
        exact however many looks there were.

        Returns:
            (R_o, looks): R_o is None once o has been seen (a detection or collapse is not a
            likelihood over where o stood, so the rule no longer applies); looks counts the
            misses absorbed for o (failed picks at a believed site included).
        """
        o = self._obj_index[obj]
        ev = self._location_evidence(obj)
        if ev is None:
            log_l, looks, seen = np.zeros(len(self.sites)), 0, False
        else:
            log_l = np.asarray(ev.log_table, dtype=float)
            seen = ev.kind_count("collapse") + ev.kind_count("detect") > 0
            looks = ev.count - ev.kind_count("collapse") - ev.kind_count("detect")
        if self._company is not None:  # coupled misses count with their p̄ (eq. 60)
            log_l = log_l + self._company.log_miss[o]
        if seen:
            return None, looks
        skip = {self._site_index[s] for s in excluded if s in self._site_index}
        keep = [j for j in range(len(self.sites)) if j not in skip]
        if not keep:
            return 0.0, looks
        terms = self._log_prior(o)[keep] + log_l[keep]
        top = float(np.max(terms))
        if not np.isfinite(top):
            return 0.0, looks
        return float(np.exp(top) * np.exp(terms - top).sum()), looks

    def _log_location(self, obj: str) -> np.ndarray:
        """log q(L_o), exact even where q underflows (log prior + log evidence + log message).

        Without relational factors q(L_o) is the normalised prior x evidence. With them,
        q(L_o = a) is proportional to that times c(a), the marginal L_o would have with a uniform
        prior and no evidence of its own (the message of the relational factors); c is bounded
        away from zero because relational factors are positive, so only the unary part needs logs.
        """
        o = self._obj_index[obj]
        ev = self._location_evidence(obj)
        log_u = self._log_prior(o) + (0.0 if ev is None else ev.log_table)
        if self._correlated:
            var, k = location_var(obj), len(self.sites)
            other = self.copy()
            other._unary[o] = np.full(k, 1.0 / k)
            other._loc_factors = [g for g in self._loc_factors if g.variables != (var,)]
            other._loc_factors.append(Factor((var,), np.full(k, 1.0 / k), f"uniform {var}"))
            other._cache = {}
            with np.errstate(divide="ignore"):
                log_u = log_u + np.log(other.location(obj))
        top = float(np.max(log_u))
        return log_u - (top + float(np.log(np.exp(log_u - top).sum())))

    def _detection_factor(self, obj: str, j: int, miss: float | None = None) -> Factor:
        """The factor of "obj seen at site j": eq. 4's collapse, or the detection likelihood
        (miss likelihood `miss`, default the model's mu)."""
        if self.model.positive_update == "collapse":
            current = self.location(obj)
            # Any entry below the smallest normal float (q at j after many misses there, or q
            # elsewhere after many misses elsewhere) is taken from the exact log belief, so the
            # ratio t / q keeps eq. 4's floor at every site.
            exact = None if current.min() >= np.finfo(float).tiny else self._log_location(obj)
            return collapse_factor(obj, j, current, self.model.prior_floor, log_current=exact)
        return detection_factor(obj, j, len(self.sites),
                                self.model.miss_likelihood if miss is None else miss,
                                self.model.false_positive_rate)

    def _apply_detections(self, seen: Sequence[tuple[str, int, float | None]]) -> int:
        """Absorb the detections of one look: (object, site index, miss likelihood or None).

        With the likelihood update (eq. 31) the factors are multiplied in, which commutes. With
        eq. 4's collapse, one object's collapse moves the others it is correlated with (joint
        models), so the collapses are repeated in sweeps until every seen object's marginal is
        its eq. 4 target (:data:`JOINT_COLLAPSE_TOLERANCE`): iterative proportional fitting,
        whose fixed point, the joint closest in KL to the belief before the look among those with
        every target marginal, is independent of the order of the objects (docs/design.md §3.2).

        Returns:
            The number of sweeps (1 when nothing is correlated).
        """
        if not seen:
            return 0
        if self.model.positive_update != "collapse" or len(seen) == 1:
            for o, j, miss in seen:
                self._commit_location([self._detection_factor(o, j, miss)])
            return 1
        previous = math.inf
        for sweep in range(1, JOINT_COLLAPSE_SWEEPS + 1):
            reached = {}
            for o, j, miss in seen:
                self._commit_location([self._detection_factor(o, j, miss)])
                reached[o] = self.location(o)
            gap = max(log_ratio_gap(self.location(o), q) for o, q in reached.items())
            if gap <= JOINT_COLLAPSE_TOLERANCE or (gap < 1e-10 and gap >= previous):
                break
            previous = gap
        return sweep

    def observe_site(self, site: str, detections: Mapping[str, bool]) -> LookUpdate:
        """Absorb one inspection of `site`: True = seen there, False = looked and not seen.

        An object absent from `detections` is "no observation" and its evidence is unchanged.
        Misses [5, 6] are applied first (they commute); then detections [4], together
        (:meth:`_apply_detections`: each seen object ends at eq. 4's value, in any object order).

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
        with self._trial():
            misses = [miss_factor(o, j, k, self.model.miss_likelihood)
                      for o in self.objects if detections.get(o) is False]
            self._commit_location(misses)
            self._apply_detections([(o, j, None) for o in self.objects
                                    if detections.get(o) is True])
            after = self.locations()
        detected = tuple(o for o in self.objects if detections.get(o) is True)
        return LookUpdate(site, dict(detections), before, after, detected, tuple(self.sites))

    def observe_viewpoint(self, view, found: Mapping[str, str | None]) -> LookUpdate:
        """Absorb one look from a viewpoint (docs/design.md eq. 30 over every site in view).

        Args:
            view: the :class:`~fg_tea.beliefs.detection.View` looked from (its sites in view and
                p_{o,j}).
            found: object -> the in-view site it was seen at, or None for "looked, not seen
                anywhere in view". Objects absent are "no observation".

        Misses multiply L_o by l(a) = 1 - p_{o,a} on the sites in view (they commute); then
        detections apply eq. 4 at the site seen (or, with ``positive_update = "likelihood"``,
        l(a) = p_{o,j} at that site and the false-positive rate elsewhere), together and in any
        object order (:meth:`_apply_detections`).

        Raises:
            ContradictionError: the evidence has probability zero; the belief is left unchanged.
        """
        k = len(self.sites)
        if getattr(view, "objects", ()) and tuple(view.objects) != self.objects:
            raise ValueError(f"view {view.name!r} has rows for {view.objects}, not {self.objects}")
        in_view = {self.sites[j] for j in view.sites}
        for obj, site in found.items():
            if obj not in self._obj_index:
                raise KeyError(f"no object named {obj!r}")
            if site is not None and site not in in_view:
                raise KeyError(f"site {site!r} is not in view of {view.name!r}")
        label = str(view.sites[0]) if view.kind == "site" else view.name
        before = self.locations()
        coupled = getattr(view, "conditional", None) is not None and self._correlated
        with self._trial():
            if coupled:  # eq. 59 kept exactly: site-local factors over who stands there
                company = self._company or CompanyEvidence.empty(len(self.objects), k)
                self._company = company.absorb(view.conditional, view.sites, {
                    self._obj_index[o]: None if s is None else self._site_index[s]
                    for o, s in found.items()}, view.probability)
                for key in ("locations", "joint", "pairwise", "structured", "eliminated"):
                    self._cache.pop(key, None)
            miss = alone_miss(view.conditional) if coupled else view.miss
            self._commit_location([view_miss_factor(o, view.sites, miss[self._obj_index[o]], k, label)
                                   for o in self.objects if o in found and found[o] is None])
            seen = []
            for o in self.objects:
                site = found.get(o)
                if site is not None:
                    j = self._site_index[site]
                    seen.append((o, j, 0.0 if coupled else
                                 float(view.miss[self._obj_index[o], view.sites.index(j)])))
            self._apply_detections(seen)
            after = self.locations()
        detected = tuple(o for o in self.objects if found.get(o) is not None)
        return LookUpdate(view.name, {o: found[o] is not None for o in found}, before, after,
                          detected, tuple(self.sites))

    def observe_view(self, view, found: Mapping[str, str | None]) -> LookUpdate:
        """Deprecated name of :meth:`observe_viewpoint` (a viewpoint is called a viewpoint)."""
        import warnings

        warnings.warn("BeliefEngine.observe_view is deprecated; use observe_viewpoint",
                      DeprecationWarning, stacklevel=2)
        return self.observe_viewpoint(view, found)

    # ------------------------------------------------------------------ hypothetical evidence
    def hypothetical(self, site: str, detections: Mapping[str, bool]) -> dict[str, np.ndarray]:
        """Location marginals *if* `site` were inspected with this outcome; the belief is untouched."""
        return dict(self.copy().observe_site(site, detections).after)

    def hypothetical_all(self) -> tuple[np.ndarray, np.ndarray]:
        """Every single-object hypothesis at every site, without touching the belief.

        Returns:
            (miss, seen): arrays of shape (N, K, N, K). ``miss[o, j, p]`` is q(L_p) after "o not
            seen at site j" [5, 6]; ``seen[o, j, p]`` is q(L_p) after "o seen at site j" [4].
            A hypothesis with probability zero under the belief leaves the marginals as they are.

        The numpy backend answers all 2·N·K hypotheses in one vectorised step: an observation
        touches one variable, so P(L_p | obs on o) = sum_a P(L_p, L_o = a) l(a) / sum_a P(L_o = a)
        l(a), from the pairwise marginals. The gtsam backend re-solves the graph per hypothesis
        (the reference the fast path is tested against).
        """
        if self.backend == "gtsam":
            return self._hypothetical_all_resolved()
        m = self._location_marginals()
        pw = self._pairwise()
        n, k = m.shape
        mu = self.model.miss_likelihood
        # Miss at j: l(a) = 1 - (1 - mu)[a = j]; P(L_p = b, miss) >= mu q(L_p = b), so the
        # subtraction below loses at most a factor 1/mu of relative precision.
        z_miss = 1.0 - (1.0 - mu) * m                                      # (o, j)
        num = m[None, None, :, :] - (1.0 - mu) * np.transpose(pw, (0, 2, 1, 3))
        miss = np.maximum(num, 0.0) / z_miss[:, :, None, None]
        if self.model.positive_update == "collapse":
            # Jeffrey's rule: q'(L_p) = sum_a t_j(a) P(L_p | L_o = a), t_j restricted to the
            # support of q(L_o) (eq. 4 where the belief allows it).
            floor = self.model.prior_floor
            targets = np.stack([collapse_target(j, k, floor) for j in range(k)])   # (j, a)
            support = m > 0                                                         # (o, a)
            t = targets[None, :, :] * support[:, None, :]                           # (o, j, a)
            t_norm = t.sum(axis=2, keepdims=True)
            t = np.divide(t, t_norm, out=np.zeros_like(t), where=t_norm > 0)
            safe = np.where(support, m, 1.0)
            cond = np.where(support[:, None, :, None], pw / safe[:, None, :, None], 0.0)
            seen = np.einsum("oja,opab->ojpb", t, cond)
            possible = support                                                      # (o, j)
        else:
            lik = np.full((k, k), self.model.false_positive_rate)
            np.fill_diagonal(lik, 1.0 - mu)                                         # (j, a)
            num = np.einsum("ja,opab->ojpb", lik, pw)
            den = np.einsum("ja,oa->oj", lik, m)
            possible = den > 0
            seen = num / np.where(possible, den, 1.0)[:, :, None, None]
        seen = np.where(possible[:, :, None, None], seen, m[None, None, :, :])
        return miss, seen

    def _hypothetical_all_resolved(self) -> tuple[np.ndarray, np.ndarray]:
        """hypothetical_all by re-running the backend's inference once per hypothesis."""
        n, k = len(self.objects), len(self.sites)
        base = self._location_marginals()
        miss = np.empty((n, k, n, k))
        seen = np.empty((n, k, n, k))
        factors = self._location_factors()
        for o, obj in enumerate(self.objects):
            for j in range(k):
                for out, make in ((miss, lambda: miss_factor(obj, j, k, self.model.miss_likelihood)),
                                  (seen, lambda: self._detection_factor(obj, j))):
                    try:
                        out[o, j] = self._gtsam_marginals(factors + [make()])
                    except ContradictionError:
                        out[o, j] = base
        return miss, seen

    # ------------------------------------------------------------------ state evidence and actions
    def _commit_states(self, factors: list[Factor], kind: str, touched: Sequence[str],
                       detail: Mapping[str, object]) -> StateUpdate:
        before = {s: self.state(s) for s in touched}
        with self._trial():
            self._state_factors = factors
            self._cache.pop("states", None)
            after = {s: self.state(s) for s in touched}
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
        # Repeated readings of one slice merge into one evidence factor, summed in log space:
        # the graph stays bounded (dense contraction has an operand limit) and exact (the
        # product of thousands of readings underflows).
        factors = list(self._state_factors)
        pos = next((i for i, g in enumerate(factors)
                    if isinstance(g, Evidence) and g.variables == (var,)), None)
        if pos is None:
            factors.append(merge_evidence(None, f))
        else:
            factors[pos] = merge_evidence(_as_evidence(factors[pos]), f)
        return self._commit_states(factors, "observe", [state],
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
            direct: use the direct form q'(z) = rho (docs/design.md eqs. (25), (26)); default: the model's.
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
        with self._trial():
            self._slice.update(new_names)
            self._state_factors = [merged]
            self._cache.pop("states", None)
            after = {s: self.state(s) for s in targets}
        return StateUpdate("transition", before, after,
                           {"form": "direct" if direct else "full",
                            "effects": [{"state": e.state, "value": e.value, "success": e.success,
                                         "requires": list(e.requires)} for e in effects]})

    # ------------------------------------------------------------------ inspection and checks
    def factor_labels(self) -> list[str]:
        """What the current graph holds, factor by factor (location block, then state block)."""
        return ([f.label for f in self._loc_factors] + list(self.graph.relational_labels)
                + [f.label for f in self._state_factors])

    def map_estimate(self) -> dict[str, str]:
        """The most probable joint arrangement of objects.

        gtsam max-product over the factor graph; joint models whose dense relational tables
        would exceed :data:`GTSAM_MAP_LIMIT` joint states use the structured max-product chain,
        and the elimination method max-product elimination.
        """
        elimination = self._method() == "elimination"
        if elimination or (self._correlated and self._structurable and self.graph.joint_size > GTSAM_MAP_LIMIT):
            sites = (self._eliminated() if elimination else self._structured()).map_assignment()
            return {o: self.sites[int(sites[i])] for i, o in enumerate(self.objects)}
        assignment = GtsamSolver(self._keys).map_assignment(self._location_factors(), self._cards)
        return {o: self.sites[assignment[location_var(o)]] for o in self.objects}

    def check_against_gtsam(self) -> float:
        """Largest absolute difference between this engine's marginals and gtsam's.

        Raises:
            ValueError: the relational factors are too large for gtsam's dense tables.
        """
        ref = GtsamSolver(self._keys)
        names = [location_var(o) for o in self.objects]
        loc = ref.marginals(self._location_factors(), names, self._cards)
        diff = max(float(np.max(np.abs(loc[location_var(o)] - self.location(o)))) for o in self.objects)
        states = ref.marginals(self._state_factors, list(self._slice.values()), self._cards)
        for s, v in self._slice.items():
            diff = max(diff, abs(float(states[v][1]) - self.state(s)))
        return diff

    def snapshot(self, digits: int | None = None) -> dict:
        """A JSON-serialisable picture of the belief: location marginals and state probabilities.

        Args:
            digits: round every number to this many decimals (None = full precision; Python's
                float repr round-trips exactly through JSON).
        """
        def r(x: float) -> float:
            return round(float(x), digits) if digits is not None else float(x)

        locations = self.locations()
        return {
            "model": self.model.name,
            "structure": self.graph.structure,
            "sites": list(self.sites),
            "locations": {o: [r(x) for x in q] for o, q in locations.items()},
            "states": {s: r(p) for s, p in sorted(self.states().items())},
            "entropy": {o: r(entropy(q)) for o, q in locations.items()},
        }


def _as_evidence(factor: Factor) -> Evidence:
    """`factor`, known to be the merged :class:`Evidence` of its variable, typed as such."""
    assert isinstance(factor, Evidence)
    return factor
