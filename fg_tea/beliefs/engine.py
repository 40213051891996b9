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
from contextlib import contextmanager
from typing import Any, Iterator, Sequence

import numpy as np

from fg_tea.beliefs.factors import Factor, location_var, state_prior
from fg_tea.beliefs.graph import (DENSE_LIMIT, BeliefGraph, build_graph, check_exact_method,
                                  pair_weight_matrices)
from fg_tea.beliefs.eliminated import EliminatedLocationModel, eliminated_model, elimination_plan, plan_for
from fg_tea.beliefs.occlusion import CompanyEvidence
from fg_tea.beliefs.solvers import GtsamSolver, NumpySolver
from fg_tea.beliefs.structured import (
    MAX_OBJECTS,
    NumericalGuardError,
    PairWeights,
    StructuredLocationModel,
)
from fg_tea.beliefs.compiled_location import compiled_joint, compiled_marginals, compiled_pairwise
from fg_tea.beliefs.coupling import CoupledBlocks, holding_coupling
from fg_tea.beliefs.location_evidence import LocationEvidence
from fg_tea.beliefs.state_block import StateBlock, UnknownVariableError  # noqa: F401 - re-exported
from fg_tea.beliefs.updates import LookUpdate, StateUpdate  # noqa: F401 - re-exported
from fg_tea.common.errors import ContradictionError
from fg_tea.common.stats import entropy
from fg_tea.model.spec import Model
from fg_tea.world.scenario import MAX_STATES, Scenario  # noqa: F401 - MAX_STATES re-exported

GTSAM_MAP_LIMIT = 1 << 16   # joint states above which MAP uses the structured max-product chain
DENSE_PREFERRED = 50_000    # joint states up to which "auto" prefers the dense joint table


class BeliefEngine(LocationEvidence, StateBlock, CoupledBlocks):
    """Exact beliefs over object locations and task states for one scenario and model.

    Args:
        scenario: the house (only its priors are read, never its truth), or a prebuilt graph.
        model: the agent's generative model.
        backend: ``"numpy"`` (fast exact path), ``"gtsam"`` (every location and state query,
            hypothetical ones included, re-solved through gtsam's discrete elimination) or
            ``"compiled"`` (the location block answered by a compiled program,
            :mod:`fg_tea.beliefs.compiled_location`; the rest as numpy).
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

        if backend not in ("numpy", "gtsam", "compiled"):
            raise ValueError(f"unknown belief backend {backend!r}; use 'numpy', 'gtsam' or 'compiled'")
        if location_solver not in ("auto", "dense", "structured", "elimination"):
            raise ValueError(f"unknown location solver {location_solver!r}; "
                             "use 'auto', 'dense', 'structured' or 'elimination'")
        graph = scenario if isinstance(scenario, BeliefGraph) else build_graph(scenario, model)
        graph = holding_coupling(graph)  # g over several coupled objects' locations, if any
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
        self._start_coupling()  # task states coupled with a location, if the model has any

    # ------------------------------------------------------------------ bookkeeping
    @contextmanager
    def _trial(self) -> Iterator[None]:
        """Evidence tried on the belief: if anything in the block raises (a contradiction, an
        interrupt), the belief is restored exactly as it was, and the exception goes on."""
        saved = (self._unary.copy(), list(self._loc_factors), list(self._state_factors),
                 dict(self._slice), dict(self._cache), self._company, dict(self._prior_tables),
                 self.graph, self._rel_joint, self._elim_plan)  # a coupling's g replaces the graph
        try:
            yield
        except BaseException:
            (self._unary, self._loc_factors, self._state_factors, self._slice, self._cache, self._company,
             self._prior_tables, self.graph, self._rel_joint, self._elim_plan) = saved
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
        other._prior_tables = dict(self._prior_tables)
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
        elimination (:mod:`fg_tea.beliefs.eliminated`), gtsam or compiled."""
        if self.backend == "gtsam":
            return self.backend
        if self.backend == "compiled":
            # The compiled block's subset program where the numpy path's would be (design §4.8):
            # the planners' joint gains read that program, so one is built, not two.
            subset = self._structurable and self._numpy_method() == "structured"
            return "structured" if subset else "compiled"
        return self._numpy_method()

    def _numpy_method(self) -> str:
        """The numpy backend's method (``location_solver``, else the cheapest by size)."""
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
        ``structured``, ``elimination``, ``gtsam`` or ``compiled``)."""
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

    def _replan(self) -> None:
        """The elimination plan of a new graph (a coupling's g replaced it; the scopes are the same)."""
        if self._elim_plan is not None:
            self._elim_plan = plan_for(self.graph, self._pair_weights, budget=self._elim_plan.budget)

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
            elif method == "compiled":
                cached = compiled_marginals(self)
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
            if self._method() == "compiled":  # the compiled block's own table (design §4.8)
                cached = self._cache["joint"] = compiled_joint(self)
                return cached
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
            elif method == "compiled":
                cached = compiled_pairwise(self)
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
        factors = self._state_factors + self._coupled_state_factors()  # a coupling's message, if any
        states = ref.marginals(factors, list(self._slice.values()), self._cards)
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
