"""Task states coupled with objects' locations: "the kettle stands by the sink when it holds
water", "when tea has been made, the mug and the teabag are in the same room" (docs/design.md §4.8).

A model program may state a factor F over task states the task observes or changes (those the
scenario declares) and the locations of one or more objects. The belief is then the joint

    P(L, S) ∝ A(L) · F(C_0, L_O) · B(S)

where A is the location block (priors, relations, look evidence), B the state block (priors,
readings, transitions over time slices), C_0 the *start* slices of the coupled states C and
L_O = (L_o1, ..., L_ok) the coupled objects' locations. The start slices are kept in the state
block (a transition sums out only later slices of a coupled state), so F stays a function of
variables the belief holds. F is the only link between the blocks, so two messages give every
marginal exactly:

- the location block holds g(L_O) = Σ_c B_C(c) F(c, L_O), with B_C the state block's own joint
  over C_0 (recomputed after every reading or transition). For one object g multiplies into its
  prior; for several it is a relational factor over their locations (an ``extra`` factor of the
  engine's graph, :func:`holding_coupling`, replaced by a graph with the new g each time), which
  every location method (dense joint, variable elimination, gtsam) holds exactly;
- the state block's queries add the factor μ(c) = Σ_l q_A(l) F(c, l) over C_0, with q_A ∝ q / g
  the location block's joint of L_O without g, q its joint with g (so after every look). Where
  g(l) = 0, F(c, l) = 0 for every c the state block allows (g sums non-negative terms), so q_A may
  be taken 0 there: μ changes only at c with B_C(c) = 0, whose posterior is 0 either way.

:class:`CoupledBlocks` is the part of :class:`~fg_tea.beliefs.engine.BeliefEngine` that keeps the
two messages; engines without a coupling pay nothing. A factor over task states and the user's own
variables reaches here with those summed out (fg_tea/beliefs/graph.py); a factor over task states
only is held with the first object's location, on which it is constant. All the couplings of one
belief form one F: at most :data:`MAX_COUPLED_STATES` states, and a table over the states and the
coupled locations of at most :data:`MAX_COUPLING_ENTRIES` entries; beyond, the program is refused
in one line when it is compiled (:func:`check_couplings`). With several coupled objects the
location block is correlated (a factorised base gets the dense joint or variable elimination), and
a graph whose elimination would exceed its budget is refused when the engine is built, as for any
factor over several locations (docs/design.md §4.6).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from fg_tea.beliefs.factors import Evidence, Factor, location_var
from fg_tea.common.errors import ContradictionError, InputError

#: Coupled task states one belief may hold (their start slices' joint has 2^n cells).
MAX_COUPLED_STATES = 3
#: Largest table F over the coupled states and locations (2^n K^k entries): the dense limit of
#: fg_tea/beliefs/graph.py, so g and q over the coupled locations fit too.
MAX_COUPLING_ENTRIES = 1 << 22
#: Label prefix of g in the engine's graph when several objects are coupled.
MESSAGE_LABEL = "coupling message"


def coupling_factor(source: str, factor: Any, tracked: set[str], kinds: dict[str, str]) -> Factor:
    """The engine's factor for a program factor over task states the scenario tracks and other
    variables: its variables are the states' names and ``L[obj]`` of each location in its scope,
    in the factor's scope order.

    A factor over task states only is returned as it is (:class:`Coupling` holds it with the
    coupled objects' locations, or the first object's, on which it is constant).

    Raises:
        InputError: the factor also holds a variable of the program's own (graph_from_program sums
            those out first; one line naming the factor).
    """
    states = [v for v in factor.scope if v in tracked]
    where = f"factor {factor.name!r}"
    others = [v for v in factor.scope if v not in tracked and kinds.get(v) != "location"]
    if others:
        raise InputError(source, where, f"couples task state {states[0]!r} with {others[0]!r}, a variable "
                         "the belief does not hold; a task state may share a factor with objects' "
                         "locations and other task states (docs/design.md §4.8)")
    locations = {v for v in factor.scope if kinds.get(v) == "location"}
    variables = tuple(location_var(v) if v in locations else v for v in factor.scope)
    return Factor(variables, np.asarray(factor.table, dtype=float), factor.name)


def check_couplings(source: str, couplings: Sequence[Factor]) -> None:
    """Refuse couplings the engine cannot hold exactly: too many states, or a table over the
    coupled states and locations above :data:`MAX_COUPLING_ENTRIES` (one line naming why)."""
    objects = {v for f in couplings for v in f.variables if v.startswith("L[")}
    states = {v for f in couplings for v in f.variables if not v.startswith("L[")}
    last = f"factor {couplings[-1].label!r}"
    if len(states) > MAX_COUPLED_STATES:
        raise InputError(source, last, f"couples {len(states)} task states with locations; at most "
                         f"{MAX_COUPLED_STATES} (their start slices' joint, docs/design.md §4.8)")
    sites = next((f.table.shape[f.variables.index(v)] for f in couplings for v in f.variables
                  if v.startswith("L[")), 1)
    entries = 2 ** len(states) * sites ** len(objects)
    if entries > MAX_COUPLING_ENTRIES:
        raise InputError(source, last, f"couples {len(states)} task states with {len(objects)} objects' "
                         f"locations ({', '.join(sorted(objects))}): one table of {entries:,} entries, "
                         f"above the limit of {MAX_COUPLING_ENTRIES:,} (docs/design.md §4.8)")


class Coupling:
    """F(C_0, L_O) of one belief, as one array: the states' axes first (sorted), then the coupled
    objects' locations (in the belief's object order)."""

    def __init__(self, factors: Sequence[Factor], objects: Sequence[str], sites: int) -> None:
        order = list(objects)
        located = sorted({v for f in factors for v in f.variables if v.startswith("L[")},
                         key=lambda v: order.index(v[2:-1]))
        # States only: held with the first object's location, on which the factor is constant.
        self.locations = tuple(located) or (location_var(order[0]),)
        self.coupled = tuple(v[2:-1] for v in self.locations)
        self.indices = tuple(order.index(o) for o in self.coupled)
        self.object, self.index = self.coupled[0], self.indices[0]
        self.states = tuple(sorted({v for f in factors for v in f.variables if not v.startswith("L[")}))
        axes = {v: i for i, v in enumerate(self.states + self.locations)}
        table = np.ones((2,) * len(self.states) + (sites,) * len(self.locations))
        for f in factors:
            at = [axes[v] for v in f.variables]
            aligned = np.transpose(f.table, np.argsort(at))  # axes in the order of the table's
            shape = [1] * table.ndim
            for i, n in zip(sorted(at), aligned.shape):
                shape[i] = n
            table = table * aligned.reshape(shape)
        self.table = table
        self.labels = tuple(f.label for f in factors)

    @property
    def several(self) -> bool:
        """True when F holds several objects' locations (g is then a relational factor)."""
        return len(self.locations) > 1

    @property
    def message_label(self) -> str:
        return f"{MESSAGE_LABEL} {', '.join(self.labels)}"

    def g(self, b: np.ndarray) -> np.ndarray:
        """g(L_O) = Σ_c b(c) F(c, L_O) for the states' joint b (axes in :attr:`states` order)."""
        n = len(self.states)
        return np.tensordot(b, self.table, axes=(list(range(n)), list(range(n))))

    def mu(self, q: np.ndarray, g: np.ndarray) -> np.ndarray:
        """μ(c) = Σ_l q_A(l) F(c, l), with q_A ∝ q / g (0 where g is 0, where q is 0 too) and q the
        location block's joint of L_O (axes in :attr:`locations` order)."""
        q_a = np.divide(q, g, out=np.zeros_like(q), where=g > 0)
        total = q_a.sum()
        if not total > 0:
            raise ContradictionError(f"the coupling {', '.join(self.labels)} leaves no location possible")
        m, n = len(self.locations), len(self.states)
        return np.tensordot(self.table, q_a / total, axes=(list(range(n, n + m)), list(range(m))))

    def start_joint(self, state_priors: Sequence[Factor]) -> np.ndarray:
        """B_C before any reading: the product of the coupled states' priors."""
        tables = {f.variables[0]: f.table / f.table.sum() for f in state_priors}
        b = np.ones(())
        for s in self.states:
            b = np.multiply.outer(b, tables[s])
        return b


def holding_coupling(graph: Any) -> Any:
    """The engine's graph for `graph`: unchanged unless its couplings hold several objects'
    locations; then with g at the start (the states' priors) as one more ``extra`` factor, so the
    engine builds its location method for a factor of that scope (docs/design.md §4.6)."""
    if not graph.couplings:
        return graph
    c = Coupling(graph.couplings, graph.objects, len(graph.sites))
    return with_message(graph, c, c.g(c.start_joint(graph.state_priors))) if c.several else graph


def with_message(graph: Any, c: Coupling, g: np.ndarray) -> Any:
    """`graph` with g as the extra factor labelled :attr:`Coupling.message_label` (replaced)."""
    extra = tuple(f for f in graph.extra if f.label != c.message_label)
    return dataclasses.replace(graph, extra=extra + (Factor(c.locations, g, c.message_label),))


class CoupledBlocks:
    """The messages between the state block and the location block (module docstring); a part of
    the belief engine."""

    # The engine's state these use (BeliefEngine.__init__ sets it).
    graph: Any  # the engine's BeliefGraph (fg_tea.beliefs.graph, which builds couplings from here)
    objects: tuple[str, ...]
    _coupling: Coupling | None
    _start: dict[str, str]
    _prior_tables: dict[int, np.ndarray]
    _unary: np.ndarray
    _loc_factors: list[Factor]
    _state_factors: list[Factor]
    _cards: dict[str, int]
    _cache: dict[str, Any]
    _slice: dict[str, str]
    _rel_joint: np.ndarray | None
    _elim_plan: Any

    if TYPE_CHECKING:
        def _solver(self, backend: str | None = None) -> Any: ...

        def location(self, obj: str) -> np.ndarray: ...

        def joint(self, variables: Sequence[str]) -> np.ndarray: ...

        def _replan(self) -> None: ...

    def _start_coupling(self) -> None:
        """Hold the graph's couplings, if any: remember the coupled states' start slices and fold
        g into the location block (called once, after the states are added)."""
        couplings = self.graph.couplings
        self._coupling = None
        self._prior_tables = {}
        if not couplings:
            return
        self._coupling = Coupling(couplings, self.objects, len(self.graph.sites))
        self._start = {s: self._slice[s] for s in self._coupling.states}
        if self._coupling.several and self._elim_plan is not None and len(self._coupling.indices) > 2:
            plan = self._elim_plan  # refuse now a joint of the coupled objects above the budget
            plan.order(plan.component_of(self._coupling.index), self._coupling.indices)
        self._after_state_change()

    def _states_joint(self) -> np.ndarray:
        """B_C: the state block's own joint over the coupled states' start slices."""
        c = self._coupling
        assert c is not None
        b = self._solver().joint(self._state_factors, [self._start[s] for s in c.states], self._cards)
        return np.asarray(b, dtype=float) / float(np.sum(b))

    def _after_state_change(self) -> None:
        """Fold the new g into the location block (after a reading or a transition)."""
        c = self._coupling
        if c is None:
            return
        if c.several:
            self._replace_message(c)
            return
        base = self.graph.location_priors[c.index].table
        prior = base * c.g(self._states_joint())
        if not prior.sum() > 0:
            raise ContradictionError(f"the coupling {', '.join(c.labels)} leaves no site possible")
        prior = prior / prior.sum()
        self._prior_tables[c.index] = prior
        var = location_var(c.object)
        at = next(i for i, f in enumerate(self._loc_factors) if f.variables == (var,)
                  and not isinstance(f, Evidence))
        self._loc_factors[at] = Factor((var,), prior, self._loc_factors[at].label)
        evidence = next((f for f in self._loc_factors if isinstance(f, Evidence) and f.variables == (var,)), None)
        with np.errstate(divide="ignore"):
            log_row = np.log(prior) + (evidence.log_table if evidence is not None else 0.0)
        top = float(np.max(log_row))
        if not np.isfinite(top):
            raise ContradictionError(f"the coupling {', '.join(c.labels)} contradicts the looks so far")
        row = np.exp(log_row - top)
        self._unary[c.index] = row / row.sum()
        self._forget_locations()

    def _replace_message(self, c: Coupling) -> None:
        """Several objects: the engine's graph with the new g as its factor over their locations
        (the engine's ``_trial`` restores the graph if this or a later query raises)."""
        g = c.g(self._states_joint())
        if not np.any(g > 0):
            raise ContradictionError(f"the coupling {', '.join(c.labels)} leaves no arrangement possible")
        self.graph = with_message(self.graph, c, g / float(np.max(g)))
        self._rel_joint = None
        self._replan()
        self._forget_locations()
        self.joint(list(c.coupled))  # the looks so far and the new g: raises if they contradict

    def _forget_locations(self) -> None:
        for key in ("structured", "structured_previous", "locations", "joint", "pairwise", "eliminated",
                    "compiled", "states"):
            self._cache.pop(key, None)

    def _message(self, c: Coupling) -> np.ndarray:
        """The g the location block holds now."""
        if c.several:
            return next(f.table for f in self.graph.extra if f.label == c.message_label)
        return c.g(self._states_joint())

    def _coupled_state_factors(self) -> list[Factor]:
        """μ over the coupled states' start slices, for the state block's queries ([] uncoupled)."""
        c = self._coupling
        if c is None:
            return []
        q = self.joint(list(c.coupled)) if c.several else self.location(c.object)
        mu = c.mu(q, self._message(c))
        return [Factor(tuple(self._start[s] for s in c.states), mu, "coupling " + ", ".join(c.labels))]


__all__ = ["MAX_COUPLED_STATES", "MAX_COUPLING_ENTRIES", "Coupling", "CoupledBlocks", "check_couplings",
           "coupling_factor", "holding_coupling", "with_message"]
