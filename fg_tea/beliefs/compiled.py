"""A program compiled to exact inference: the cheapest exact method per query (docs/design.md §4.8).

``compile_program(program)`` splits the program's factor graph into connected components (the
variables of different components are independent) and gives each one method, chosen once:

- ``closed form`` — a variable alone: the normalised product of its unary factors;
- ``dense joint`` — a component of at most ``dense_states`` joint states, or one whose
  elimination would build a table as large as its joint anyway: its whole table, computed once,
  from which every marginal, joint, hypothetical posterior and K-best list is read;
- ``elimination`` — otherwise, variable elimination in log space with a min-fill order
  (:mod:`fg_tea.beliefs.elimination`), once per query.

A component whose exact inference would build a table above ``budget`` entries is refused when
compiled, in one line naming its variables, the elimination width and the table size; a query
whose own order would exceed it (a joint of far-apart variables) is refused the same way.
Nothing is approximated. Evidence (:meth:`CompiledModel.observe`) and transitions
(:meth:`CompiledModel.transition`) give a new compiled model; gtsam's ``DiscreteFactorGraph``
stays the engine of record and cross-checks this one (:mod:`fg_tea.beliefs.compiled_gtsam`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Mapping, Sequence

import numpy as np

from fg_tea.beliefs.budget import BUDGET, refusal
from fg_tea.beliefs.compiled_hypothetical import Hypothetical, hypothetical_many
from fg_tea.beliefs.elimination import (
    LogFactor,
    expand,
    normalised,
    shifted,
    log_product,
    logsumexp,
    min_fill_order,
    order_cost,
    sum_out,
)
from fg_tea.beliefs.kbest import kbest_dense, kbest_partition, merge_independent
from fg_tea.common.errors import ContradictionError, InputError
from fg_tea.model.program import Program

#: Components with at most this many joint states are answered from their dense joint table.
DENSE_STATES = 1 << 16
METHODS = ("auto", "dense", "elimination")


@dataclass(frozen=True)
class _Var:
    name: str
    values: tuple[Any, ...]
    labels: tuple[str, ...]
    hidden: bool = False  # an earlier copy left by a transition: summed out, never reported

    @property
    def card(self) -> int:
        return len(self.values)


@dataclass(frozen=True)
class _Factor:
    label: str
    scope: tuple[int, ...]
    log_table: np.ndarray
    learnable: bool = False
    origin: str = "table"


@dataclass(frozen=True)
class Component:
    """One connected part of a compiled graph and how it is answered.

    Attributes:
        variables: the names of its (reported) variables, in declaration order.
        method: ``"closed form"``, ``"dense joint"`` or ``"elimination"``.
        states: its number of joint states (hidden copies included).
        order: the elimination order of a full elimination (elimination only).
        width: the induced width of that order (most neighbours of an eliminated variable).
        largest: the largest table the method builds (entries).
    """

    variables: tuple[str, ...]
    method: str
    states: int
    order: tuple[str, ...] = ()
    width: int = 0
    largest: int = 0
    ids: tuple[int, ...] = field(default=(), repr=False)


@dataclass(frozen=True)
class Arrangement:
    """One joint assignment of every reported variable, with its posterior probability."""

    values: dict[str, Any]
    probability: float


class CompiledModel:
    """Exact inference over a program (build it with :func:`compile_program`).

    Queries: :meth:`marginal`, :meth:`marginals`, :meth:`joint` (any set of variables),
    :meth:`hypothetical` (posteriors under candidate evidence on one variable), :meth:`kbest`
    (the K most probable arrangements). Updates return a new model: :meth:`observe`,
    :meth:`condition`, :meth:`transition`. :meth:`plan` says how each query is answered.
    """

    def __init__(self, variables: Sequence[_Var], factors: Sequence[_Factor], source: str,
                 method: str = "auto", budget: int = BUDGET, dense_states: int = DENSE_STATES,
                 *, components: tuple[Component, ...] | None = None) -> None:
        if method not in METHODS:
            raise InputError(source, "method", f"unknown method {method!r} (known: {', '.join(METHODS)})")
        self.source, self.method, self.budget, self.dense_states = source, method, budget, dense_states
        self._vars = tuple(variables)
        self._factors = tuple(factors)
        self._index = {v.name: i for i, v in enumerate(self._vars) if not v.hidden}
        self._cards = {i: v.card for i, v in enumerate(self._vars)}
        # `components` is passed only by evidence on single variables, which leaves the plan as it is
        self.components = self._components() if components is None else components
        self._component_of = {i: c for c in self.components for i in c.ids}
        # Caches, each keyed by a component's first id: the log table of a dense component and
        # the summed log factors of a closed-form one (both shifted to a maximum of 0), and the
        # components known to have non-zero weight; marginals by variable id.
        self._dense: dict[int, np.ndarray] = {}
        self._unary: dict[int, np.ndarray] = {}
        self._possible: set[int] = set()
        self._marginal_cache: dict[int, np.ndarray] = {}
        self._dense_prob_cache: dict[int, np.ndarray] = {}

    # -- compiling ------------------------------------------------------------------------

    def _components(self) -> tuple[Component, ...]:
        parent = list(range(len(self._vars)))

        def root(i: int) -> int:
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i
        for f in self._factors:
            for v in f.scope[1:]:
                parent[root(v)] = root(f.scope[0])
        groups: dict[int, list[int]] = {}
        for i in range(len(self._vars)):
            groups.setdefault(root(i), []).append(i)
        return tuple(self._plan_component(tuple(ids)) for ids in
                     sorted(groups.values(), key=lambda g: min((i for i in g if not self._vars[i].hidden),
                                                               default=len(self._vars) + g[0])))

    def _plan_component(self, ids: tuple[int, ...]) -> Component:
        names = tuple(self._vars[i].name for i in ids if not self._vars[i].hidden)
        states = math.prod(self._cards[i] for i in ids)
        if len(ids) == 1:
            return Component(names, "closed form", states, largest=states, ids=ids)
        if self.method == "dense" or (self.method == "auto" and states <= self.dense_states):
            if states > self.budget:
                raise self._refusal(ids, len(ids) - 1, states, "the dense joint")
            return Component(names, "dense joint", states, largest=states, ids=ids)
        scopes = self._scopes(ids)
        order = min_fill_order(scopes, list(ids[:-1]), self._cards)
        width, largest = order_cost(scopes, order, ids[-1:], self._cards)
        if self.method == "auto" and largest >= states and states <= self.budget:
            # Elimination would build a table as large as the joint itself: the joint, built
            # once, answers every query at that cost.
            return Component(names, "dense joint", states, largest=states, ids=ids)
        if largest > self.budget:
            raise self._refusal(ids, width, largest, "variable elimination")
        return Component(names, "elimination", states, tuple(self._vars[i].name for i in order),
                         width, largest, ids)

    def _scopes(self, ids: Sequence[int]) -> list[tuple[int, ...]]:
        members = set(ids)
        return [f.scope for f in self._factors if f.scope[0] in members]

    def _refusal(self, ids: Sequence[int], width: int, size: int, how: str) -> InputError:
        return refusal(self.source, [self._vars[i].name for i in ids], width, size, how, self.budget)

    # -- names ---------------------------------------------------------------------------

    @property
    def variables(self) -> tuple[str, ...]:
        """The reported variables, in declaration order."""
        return tuple(self._index)

    def component(self, name: str) -> Component:
        """The component that holds variable `name` (its method answers every query on it)."""
        return self._component_of[self._id(name)]

    def values(self, name: str) -> tuple[Any, ...]:
        """The values of variable `name`, in index order."""
        return self._vars[self._id(name)].values

    def _id(self, name: str) -> int:
        if name in self._index:
            return self._index[name]
        if name.startswith("L[") and name.endswith("]") and name[2:-1] in self._index:
            return self._index[name[2:-1]]
        raise InputError(self.source, f"variable {name!r}",
                         f"unknown variable (known: {', '.join(self._index) or 'none'})")

    # -- queries -------------------------------------------------------------------------

    def marginal(self, name: str) -> np.ndarray:
        """P(name): a normalised vector over its values."""
        return self._marginal_id(self._id(name)).copy()

    def marginals(self, names: Sequence[str] | None = None) -> dict[str, np.ndarray]:
        """The marginal of each of `names` (default: every variable)."""
        return {n: self.marginal(n) for n in (self.variables if names is None else names)}

    def joint(self, names: Sequence[str]) -> np.ndarray:
        """P(names...): a normalised table with one axis per name, in the given order.

        Raises:
            InputError: an unknown or repeated name, or a query over the budget.
            ContradictionError: the evidence has probability zero.
        """
        if isinstance(names, str):
            raise InputError(self.source, "joint", "takes a list of variable names")
        ids = [self._id(n) for n in names]
        if len(set(ids)) != len(ids):
            raise InputError(self.source, "joint", "names a variable twice")
        return self._joint_ids(ids)

    def _check_possible(self) -> None:
        """Raise ContradictionError when some component has total weight zero (then the whole
        program, evidence included, has probability zero and no query has an answer)."""
        for comp in self.components:
            if not self._weighs(comp):
                raise ContradictionError(f"{self.source}: the evidence has probability zero under the program "
                                         f"({', '.join(comp.variables)})")

    def _weighs(self, comp: Component) -> bool:
        """Whether `comp` has non-zero total weight (remembered once known)."""
        if comp.ids[0] not in self._possible:
            try:
                if comp.method == "closed form":
                    weighs = bool(np.isfinite(np.max(self._unary_log(comp))))
                elif comp.method == "dense joint":
                    weighs = self._dense_prob(comp) is not None  # normalising it raises if zero
                else:
                    weighs = bool(np.isfinite(self._log_partition(comp)))
            except ContradictionError:  # a dense table of zero weight says so
                return False
            if not weighs:
                return False
            self._possible.add(comp.ids[0])
        return True

    def _joint_ids(self, ids: Sequence[int]) -> np.ndarray:
        self._check_possible()
        by_component: dict[int, list[int]] = {}
        for i in ids:
            by_component.setdefault(id(self._component_of[i]), []).append(i)
        comp = self._component_of[ids[0]]
        if len(by_component) == 1 and comp.method == "dense joint":  # sums of its cached joint
            full, axes = self._dense_prob(comp)
            drop = tuple(a for a, i in enumerate(axes) if i not in ids)
            kept = [i for i in axes if i in ids]
            return np.array(np.transpose(full.sum(axis=drop) if drop else full, [kept.index(i) for i in ids]))
        log = np.zeros([self._cards[i] for i in ids])
        for group in by_component.values():
            part = self._component_log(self._component_of[group[0]], group)
            log = log + _expand(group, part, ids)
        return normalised(log, self.source)

    def _component_log(self, comp: Component, keep: Sequence[int]) -> np.ndarray:
        """An unnormalised log table over `keep` (all in `comp`), axes in `keep` order."""
        if comp.method == "closed form":
            return self._unary_log(comp)
        if comp.method == "dense joint":
            full = self._dense_log(comp)
            drop = tuple(a for a, i in enumerate(comp.ids) if i not in keep)
            reduced = logsumexp(full, drop) if drop else full
            kept = [i for i in comp.ids if i in keep]
            return np.transpose(reduced, [kept.index(i) for i in keep])
        factors = self._log_factors(comp)
        eliminate = [i for i in comp.ids if i not in keep]
        scopes = [s for s, _ in factors]
        order = min_fill_order(scopes, eliminate, self._cards)
        width, largest = order_cost(scopes, order, keep, self._cards)
        if largest > self.budget:
            raise self._refusal(comp.ids, width, largest, f"elimination keeping {len(keep)} variables")
        return log_product(sum_out(factors, order, self._cards), list(keep), self._cards)

    def _log_factors(self, comp: Component) -> list[LogFactor]:
        members = set(comp.ids)
        return [(f.scope, f.log_table) for f in self._factors if f.scope[0] in members]

    def _unary_log(self, comp: Component) -> np.ndarray:
        """The summed log factors of a closed-form component's one variable, maximum 0 (or all
        -inf: probability zero)."""
        key = comp.ids[0]
        if key not in self._unary:
            self._unary[key] = shifted(log_product(self._log_factors(comp), [key], self._cards))
        return self._unary[key]

    def _dense_log(self, comp: Component) -> np.ndarray:
        key = comp.ids[0]
        if key not in self._dense:
            table = log_product(self._log_factors(comp), list(comp.ids), self._cards)
            top = np.max(table)
            if not np.isfinite(top):
                raise ContradictionError(f"{self.source}: the evidence has probability zero under the program")
            self._dense[key] = table - top
        return self._dense[key]

    def hypothetical(self, name: str, likelihoods: Any) -> Hypothetical:
        """Posterior marginals of every variable under each candidate likelihood on `name`.

        Exact: P(Y | l_c) = sum_x P(x, Y) l_c(x) / sum_x P(x) l_c(x), from the pairwise joints
        (a dense component answers all candidates and variables with one contraction).

        Args:
            name: the observed variable.
            likelihoods: (C, values) or (values,) non-negative likelihood vectors, one per
                candidate observation.

        Returns:
            A :class:`Hypothetical`; the belief itself is unchanged.
        """
        return self.hypothetical_many({name: likelihoods})[name]

    def hypothetical_many(self, likelihoods: Mapping[str, Any],
                          report: Sequence[str] | None = None) -> dict[str, Hypothetical]:
        """:meth:`hypothetical` for several observed variables at once (name -> (C, values)
        likelihoods), reporting the posteriors of `report` only (default: every variable): what
        a planner asks before a decision (:func:`fg_tea.beliefs.compiled_hypothetical.hypothetical_many`)."""
        return hypothetical_many(self, likelihoods, report)

    def _marginal_id(self, i: int) -> np.ndarray:
        """The cached marginal of variable id `i` (not a copy: callers must not write to it)."""
        if i not in self._marginal_cache:
            self._marginal_cache[i] = self._joint_ids([i])
        return self._marginal_cache[i]

    def _dense_prob(self, comp: Component) -> tuple[np.ndarray, list[int]]:
        """A dense component's normalised joint over its reported variables, and their ids."""
        key = comp.ids[0]
        if key not in self._dense_prob_cache:
            full = normalised(self._dense_log(comp), self.source)
            hidden = tuple(a for a, i in enumerate(comp.ids) if self._vars[i].hidden)
            self._dense_prob_cache[key] = full.sum(axis=hidden) if hidden else full
        return self._dense_prob_cache[key], [i for i in comp.ids if not self._vars[i].hidden]

    def kbest(self, k: int) -> list[Arrangement]:
        """The `k` most probable joint arrangements of all variables, best first, exactly.

        Ties are ordered by the variables' value indices in declaration order on the dense and
        closed-form routes, and deterministically on the elimination route. Fewer than `k`
        come back when fewer arrangements are possible.
        """
        if not isinstance(k, int) or k < 1:
            raise InputError(self.source, "kbest", f"k must be a positive integer, got {k!r}")
        self._check_possible()
        lists, order = [], []
        for comp in self.components:
            shown = [i for i in comp.ids if not self._vars[i].hidden]
            if not shown:
                continue
            lists.append(self._component_kbest(comp, shown, k))
            order += shown
        best = merge_independent(lists, k)
        position = {v: a for a, v in enumerate(order)}
        ids = list(self._index.values())
        rows = [(s, tuple(x[position[i]] for i in ids)) for s, x in best]
        rows.sort(key=lambda r: (-r[0], r[1]))
        return [Arrangement({self._vars[i].name: self._vars[i].values[j] for i, j in zip(ids, x)}, math.exp(s))
                for s, x in rows]

    def _component_kbest(self, comp: Component, shown: list[int], k: int) -> list[tuple[float, tuple[int, ...]]]:
        """Normalised log-probability and value indices (in `shown` order) of the k best."""
        log_z = self._log_partition(comp)
        if not np.isfinite(log_z):
            raise ContradictionError(f"{self.source}: the evidence has probability zero under the program")
        if comp.method != "elimination":
            return [(s - log_z, x) for s, x in kbest_dense(self._component_log(comp, shown), k)]
        factors = self._log_factors(comp)
        hidden = [i for i in comp.ids if self._vars[i].hidden]
        if hidden:  # sum the hidden copies out first, then maximise over the rest (exact)
            factors = sum_out(factors, min_fill_order([s for s, _ in factors], hidden, self._cards), self._cards)
            factors = [f for f in factors if f[0]]
        return [(s - log_z, x) for s, x in kbest_partition(factors, shown, self._cards, k)]

    def _log_partition(self, comp: Component) -> float:
        """log of the component's total weight (its normalising constant)."""
        if comp.method == "dense joint":
            return float(logsumexp(self._dense_log(comp), None))
        if comp.method == "closed form":
            return float(logsumexp(self._unary_log(comp), None))
        factors = self._log_factors(comp)
        rest = sum_out(factors, min_fill_order([s for s, _ in factors], list(comp.ids), self._cards), self._cards)
        return float(sum(float(t) for _, t in rest))

    def map(self) -> Arrangement:
        """The most probable joint arrangement (``kbest(1)[0]``)."""
        return self.kbest(1)[0]

    # -- updates -------------------------------------------------------------------------

    def observe(self, name: str, likelihood: Any, label: str | None = None) -> "CompiledModel":
        """A new model with a likelihood vector on `name` multiplied in (evidence: a detection,
        a miss, a reading), held in log space so long runs of evidence never underflow."""
        return self._with_evidence((self._evidence(name, likelihood, label),))

    def observe_many(self, evidence: Mapping[str, Any]) -> "CompiledModel":
        """A new model with several likelihood vectors (variable name -> likelihood) multiplied in
        at once: the model :meth:`observe` gives one by one, compiled once instead of once each."""
        return self._with_evidence(tuple(self._evidence(name, likelihood, None)
                                         for name, likelihood in evidence.items()))

    def _with_evidence(self, added: tuple[_Factor, ...]) -> "CompiledModel":
        """The model with single-variable factors `added`: the plan is unchanged, so it is kept;
        an untouched component keeps its caches, and a touched closed-form or dense component
        has the evidence added to its cached log table (exact: the same sum, in another order)."""
        new = CompiledModel(self._vars, self._factors + added, self.source, self.method, self.budget,
                            self.dense_states, components=self.components)
        touched: dict[int, list[_Factor]] = {}
        for f in added:
            touched.setdefault(self._component_of[f.scope[0]].ids[0], []).append(f)
        for comp in self.components:
            key = comp.ids[0]
            mine = touched.get(key)
            if mine is None:
                if key in self._possible or (comp.method != "elimination" and self._weighs(comp)):
                    new._possible.add(key)  # (_weighs fills this model's caches, which carry over)
                if key in self._dense_prob_cache:
                    new._dense_prob_cache[key] = self._dense_prob_cache[key]
                for cache, old in ((new._unary, self._unary), (new._dense, self._dense)):
                    if key in old:
                        cache[key] = old[key]
                new._marginal_cache.update({i: self._marginal_cache[i] for i in comp.ids
                                            if i in self._marginal_cache})
            elif key in self._unary:
                new._unary[key] = shifted(self._unary[key] + sum(f.log_table for f in mine))
            elif key in self._dense:
                # kept unshifted (a sum of logs cannot overflow); a table of zero weight is
                # refused by whatever query normalises it
                new._dense[key] = self._dense[key] + sum(_expand(f.scope, f.log_table, comp.ids) for f in mine)
        return new

    def observe_logs(self, evidence: Mapping[str, Any]) -> "CompiledModel":
        """:meth:`observe_many` with natural-log likelihoods (name -> log vector, -inf for zero):
        evidence whose product underflows a float (a thousand misses) stays exact."""
        added = []
        for name, log in evidence.items():
            i = self._id(name)
            table = np.asarray(log, dtype=float)
            if table.shape != (self._cards[i],) or np.isnan(table).any() or np.isposinf(table).any():
                raise InputError(self.source, f"evidence on {name!r}",
                                 f"a log-likelihood must be {self._cards[i]} numbers below +inf")
            added.append(_Factor(f"evidence {name}", (i,), table))
        return self._with_evidence(tuple(added))

    def _evidence(self, name: str, likelihood: Any, label: str | None) -> _Factor:
        """The log-space factor of a likelihood vector on `name`, checked."""
        i = self._id(name)
        lik = np.asarray(likelihood, dtype=float)
        if lik.shape != (self._cards[i],) or not np.all(np.isfinite(lik)) or np.any(lik < 0):
            raise InputError(self.source, f"evidence on {name!r}",
                             f"a likelihood must be {self._cards[i]} finite non-negative numbers")
        if not np.any(lik > 0):
            raise ContradictionError(f"{self.source}: evidence on {name!r} is zero for every value")
        with np.errstate(divide="ignore"):
            return _Factor(label or f"evidence {name}", (i,), np.log(lik))

    def condition(self, name: str, value: Any) -> "CompiledModel":
        """A new model in which `name` is known to take `value` (one of its values or labels)."""
        var = self._vars[self._id(name)]
        matches = [j for j, (v, lab) in enumerate(zip(var.values, var.labels)) if v == value or lab == value]
        if not matches:
            raise InputError(self.source, f"evidence on {name!r}",
                             f"unknown value {value!r} (known: {', '.join(var.labels)})")
        lik = np.zeros(var.card)
        lik[matches[0]] = 1.0
        return self.observe(name, lik, f"condition {name}={var.labels[matches[0]]}")

    def transition(self, name: str, table: Any, parents: Sequence[str] = (),
                   label: str | None = None) -> "CompiledModel":
        """A new model after `name` moves by P(new | old, parents...): the old value becomes a
        hidden variable (summed out, never reported) and the new one takes the name.

        Args:
            name: the variable that changes.
            table: shape (values of name, values of each parent..., values of name): the
                weight of each new value given the old value and the parents' current values.
            parents: other variables the change depends on (their current values).
        """
        i = self._id(name)
        pids = [self._id(p) for p in parents]
        if i in pids:
            raise InputError(self.source, f"transition of {name!r}", "names the variable as its own parent")
        arr = np.asarray(table, dtype=float)
        shape = (self._cards[i], *[self._cards[p] for p in pids], self._cards[i])
        if arr.shape != shape or not np.all(np.isfinite(arr)) or np.any(arr < 0) or not np.any(arr > 0):
            raise InputError(self.source, f"transition of {name!r}",
                             f"needs a finite non-negative table of shape {shape}, not all zero")
        old = len(self._vars)
        steps = sum(1 for v in self._vars if v.hidden and v.name.startswith(name + "@"))
        variables = self._vars + (replace(self._vars[i], name=f"{name}@{steps}", hidden=True),)
        moved = tuple(replace(f, scope=tuple(old if s == i else s for s in f.scope)) for f in self._factors)
        with np.errstate(divide="ignore"):
            step = _Factor(label or f"transition {name}", (old, *pids, i), np.log(arr))
        return self._rebuild(variables, moved + (step,))

    def _rebuild(self, variables: Sequence[_Var], factors: Sequence[_Factor]) -> "CompiledModel":
        return CompiledModel(variables, factors, self.source, self.method, self.budget, self.dense_states)

    # -- inspection ----------------------------------------------------------------------

    def factor_tables(self) -> list[tuple[str, tuple[str, ...], np.ndarray]]:
        """Every factor as (label, scope names — hidden copies included —, table scaled to a
        maximum of 1): the graph a cross-check (gtsam) rebuilds."""
        return [(f.label, tuple(self._vars[i].name for i in f.scope), np.exp(f.log_table - np.max(f.log_table)))
                for f in self._factors]

    def cards(self) -> dict[str, int]:
        """Values per variable, hidden copies included."""
        return {v.name: v.card for v in self._vars}

    def plan(self) -> str:
        """The compiled plan as text: variables, factors, the method of each component (every
        query on its variables uses it), the elimination width and the largest table."""
        from fg_tea.beliefs.compiled_plan import plan_lines

        return "\n".join(plan_lines(self, self._vars, self._factors)) + "\n"


def _expand(group: Sequence[int], table: np.ndarray, target: Sequence[int]) -> np.ndarray:
    return expand(tuple(group), table, list(target))


def compile_program(program: Program, method: str = "auto", budget: int = BUDGET,
                    dense_states: int = DENSE_STATES) -> CompiledModel:
    """Compile a :class:`~fg_tea.model.program.Program` to exact inference.

    Args:
        program: the declared variables and factors.
        method: ``"auto"`` (each component by size), or force ``"dense"`` or ``"elimination"``
            for every component of two or more variables (for tests and comparisons).
        budget: the largest table exact inference may build (entries).
        dense_states: the most joint states a component may have to be answered densely in
            ``auto`` mode.

    Returns:
        A :class:`CompiledModel`.

    Raises:
        InputError: exact inference would exceed `budget` (one line: variables, width, size).
    """
    variables = [_Var(v.name, v.values, v.labels) for v in program.variables]
    index = {v.name: i for i, v in enumerate(program.variables)}
    factors = []
    for f in program.factors:
        with np.errstate(divide="ignore"):
            factors.append(_Factor(f.name, tuple(index[s] for s in f.scope), np.log(f.table),
                                   f.learnable, f.origin))
    return CompiledModel(variables, factors, program.source, method, budget, dense_states)


def compile_factors(variables: Sequence[tuple[str, Sequence[Any]]],
                    factors: Sequence[tuple[str, Sequence[str], np.ndarray]], source: str,
                    **options: Any) -> CompiledModel:
    """Compile named variables (name, values) and factors (label, scope names, non-negative
    table) to exact inference, as :func:`compile_program` does for a program; `options` as there.
    The belief engine's location block uses it (``BeliefEngine(..., backend="compiled")``)."""
    index = {name: i for i, (name, _) in enumerate(variables)}
    var = [_Var(name, tuple(values), tuple(str(v) for v in values)) for name, values in variables]
    built = []
    for label, scope, table in factors:
        with np.errstate(divide="ignore"):
            built.append(_Factor(label, tuple(index[v] for v in scope), np.log(np.asarray(table, dtype=float))))
    return CompiledModel(var, built, source, **options)


def plan_text(program: Program, **options: Any) -> str:
    """The compiled plan of `program` as text (what ``fg-tea validate my_model.py`` prints):
    its variables, its factors, the exact method each query uses, the elimination width and the
    largest table. `options` go to :func:`compile_program`.

    Raises:
        InputError: the program is refused (over budget); the message is one line.
    """
    return compile_program(program, **options).plan()
