"""Task states coupled with an object's location: "the kettle stands by the sink when it holds
water" (docs/design.md §4.8).

A model program may state a factor F over task states the task observes or changes (those the
scenario declares) and one object's location. The belief is then the joint

    P(L, S) ∝ A(L) · F(C_0, L_o) · B(S)

where A is the location block (priors, relations, look evidence), B the state block (priors,
readings, transitions over time slices), C_0 the *start* slices of the coupled states C and o the
coupled object. The start slices are kept in the state block (a transition sums out only later
slices of a coupled state), so F stays a function of variables the belief holds. F is the only
link between the blocks, so two messages give every marginal exactly:

- the location block holds o's prior times g(L_o) = Σ_c B_C(c) F(c, L_o), with B_C the state
  block's own joint over C_0 (recomputed after every reading or transition);
- the state block's queries add the factor μ(c) = Σ_l q_A(l) F(c, l) over C_0, with q_A ∝ q / g
  the location block's marginal of o without g (so after every look).

:class:`CoupledBlocks` is the part of :class:`~fg_tea.beliefs.engine.BeliefEngine` that keeps the
two messages; engines without a coupling pay nothing. A factor over task states and the user's own
variables reaches here with those summed out (fg_tea/beliefs/graph.py); a factor over task states
only is held with the first object's location, on which it is constant. One object and at most
:data:`MAX_COUPLED_STATES` states per belief; several objects' locations are refused in one line when
the program is compiled (:func:`coupling_factor`, :func:`check_couplings`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from fg_tea.beliefs.factors import Evidence, Factor, location_var
from fg_tea.common.errors import ContradictionError, InputError

#: Coupled task states one belief may hold (their start slices' joint has 2^n cells).
MAX_COUPLED_STATES = 3


def coupling_factor(source: str, factor: Any, tracked: set[str], kinds: dict[str, str]) -> Factor:
    """The engine's factor for a program factor over task states the scenario tracks and other
    variables: its variables are the states' names and ``L[obj]``, in the factor's scope order.

    A factor over task states only is returned as it is (:class:`Coupling` holds it with the
    coupled object's location, or the first object's, on which it is constant).

    Raises:
        InputError: the factor also holds a variable of the program's own (graph_from_program sums
            those out first) or the locations of several objects (one line naming the factor).
    """
    states = [v for v in factor.scope if v in tracked]
    where = f"factor {factor.name!r}"
    others = [v for v in factor.scope if v not in tracked and kinds.get(v) != "location"]
    if others:
        raise InputError(source, where, f"couples task state {states[0]!r} with {others[0]!r}, a variable "
                         "the belief does not hold; a task state may share a factor with one object's "
                         "location (docs/design.md §4.8)")
    locations = [v for v in factor.scope if kinds.get(v) == "location"]
    if len(locations) > 1:
        raise InputError(source, where, f"couples task states with {len(locations)} objects' locations; "
                         "a task state may share a factor with one object's location (docs/design.md §4.8)")
    variables = tuple(location_var(v) if v in locations else v for v in factor.scope)
    return Factor(variables, np.asarray(factor.table, dtype=float), factor.name)


def check_couplings(source: str, couplings: Sequence[Factor]) -> None:
    """Refuse couplings the engine cannot hold exactly: several objects, or too many states."""
    objects = {v for f in couplings for v in f.variables if v.startswith("L[")}
    states = {v for f in couplings for v in f.variables if not v.startswith("L[")}
    if len(objects) > 1:
        raise InputError(source, f"factor {couplings[-1].label!r}", f"couples task states with "
                         f"{len(objects)} objects' locations ({', '.join(sorted(objects))}); one belief "
                         "couples its task states with one object's location (docs/design.md §4.8)")
    if len(states) > MAX_COUPLED_STATES:
        raise InputError(source, f"factor {couplings[-1].label!r}", f"couples {len(states)} task states "
                         f"with a location; at most {MAX_COUPLED_STATES} (docs/design.md §4.8)")


class Coupling:
    """F(C_0, L_o) of one belief, as one array with the states' axes first (sorted) and o's last."""

    def __init__(self, factors: Sequence[Factor], objects: Sequence[str], sites: int) -> None:
        # States only: held with the first object's location, on which the factor is constant.
        var = next((v for f in factors for v in f.variables if v.startswith("L[")), location_var(objects[0]))
        self.object = var[2:-1]
        self.index = list(objects).index(self.object)
        self.states = tuple(sorted({v for f in factors for v in f.variables if v != var}))
        axes = {v: i for i, v in enumerate(self.states + (var,))}
        table = np.ones((2,) * len(self.states) + (sites,))
        for f in factors:
            order = [axes[v] for v in f.variables]
            aligned = np.transpose(f.table, np.argsort(order))  # axes in the order of the table's
            shape = [1] * table.ndim
            for at, n in zip(sorted(order), aligned.shape):
                shape[at] = n
            table = table * aligned.reshape(shape)
        self.table = table
        self.labels = tuple(f.label for f in factors)

    def g(self, b: np.ndarray) -> np.ndarray:
        """g(L_o) = Σ_c b(c) F(c, L_o) for the states' joint b (axes in :attr:`states` order)."""
        n = len(self.states)
        return np.tensordot(b, self.table, axes=(list(range(n)), list(range(n))))

    def mu(self, q: np.ndarray, g: np.ndarray) -> np.ndarray:
        """μ(c) = Σ_l q_A(l) F(c, l), with q_A ∝ q / g (0 where g is 0, where q is 0 too)."""
        q_a = np.divide(q, g, out=np.zeros_like(q), where=g > 0)
        total = q_a.sum()
        if not total > 0:
            raise ContradictionError(f"the coupling {', '.join(self.labels)} leaves no location possible")
        return np.tensordot(self.table, q_a / total, axes=([-1], [0]))


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

    if TYPE_CHECKING:
        def _solver(self, backend: str | None = None) -> Any: ...

        def location(self, obj: str) -> np.ndarray: ...

    def _start_coupling(self) -> None:
        """Hold the graph's couplings, if any: remember the coupled states' start slices and fold
        g into the coupled object's prior (called once, after the states are added)."""
        couplings = self.graph.couplings
        self._coupling = None
        self._prior_tables = {}
        if not couplings:
            return
        self._coupling = Coupling(couplings, self.objects, len(self.graph.sites))
        self._start = {s: self._slice[s] for s in self._coupling.states}
        self._after_state_change()

    def _states_joint(self) -> np.ndarray:
        """B_C: the state block's own joint over the coupled states' start slices."""
        c = self._coupling
        assert c is not None
        b = self._solver().joint(self._state_factors, [self._start[s] for s in c.states], self._cards)
        return np.asarray(b, dtype=float) / float(np.sum(b))

    def _after_state_change(self) -> None:
        """Fold the new g into the coupled object's prior (after a reading or a transition)."""
        c = self._coupling
        if c is None:
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
        for key in ("structured", "structured_previous", "locations", "joint", "pairwise", "eliminated",
                    "states"):
            self._cache.pop(key, None)

    def _coupled_state_factors(self) -> list[Factor]:
        """μ over the coupled states' start slices, for the state block's queries ([] uncoupled)."""
        c = self._coupling
        if c is None:
            return []
        mu = c.mu(self.location(c.object), c.g(self._states_joint()))
        return [Factor(tuple(self._start[s] for s in c.states), mu, "coupling " + ", ".join(c.labels))]


__all__ = ["MAX_COUPLED_STATES", "Coupling", "CoupledBlocks", "check_couplings", "coupling_factor"]
