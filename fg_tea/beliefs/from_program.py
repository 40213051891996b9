"""The belief engine's graph from a model program (docs/design.md §4.8).

:func:`graph_from_program` turns a :class:`~fg_tea.model.program.Program` into the
:class:`~fg_tea.beliefs.graph.BeliefGraph` the engine (:mod:`fg_tea.beliefs.engine`) answers
queries on, exactly — no factor is approximated:

- factors over one location multiply into that object's location prior;
- a bundled model's relational factors that are still as ``program_from_model`` made them
  (``ProgramFactor.form``) stay structured: pairwise same-site / same-room weights and the
  capacity penalty, which the subset dynamic program takes without any K^N table;
- any other factor over locations is an ``extra`` dense factor of its scope;
- factors touching variables the task never reads — the user's own variables and states the
  scenario does not declare — are summed out exactly, one connected group at a time, into one
  factor over the locations they touch;
- a factor over one task state (a state the scenario declares, which the task observes or
  changes) multiplies into its Bernoulli prior; a factor coupling a task state with a location
  or another state is refused in one line: the engine keeps task states independent (the next
  step, docs/design.md §4.8).

Objects and task states the program does not declare keep the base model's priors (eq. 2 and
eq. 21). Every refusal is an :class:`~fg_tea.common.errors.InputError` naming the program's
source and the factor.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from fg_tea.beliefs.factors import Factor, location_var, state_prior
from fg_tea.beliefs.graph import DENSE_LIMIT, BeliefGraph, PairRelation
from fg_tea.common.errors import InputError
from fg_tea.model.program import Program, ProgramFactor

#: Most variables summed out in one connected group (einsum's axis letters).
SUM_OUT_LIMIT = 48


def graph_from_program(program: Program, scenario: Any, model: Any) -> BeliefGraph:
    """The engine's initial graph for `program` over the house of `scenario`.

    Args:
        program: the model program (locations over the scenario's sites).
        scenario: the loaded scenario the episode runs in.
        model: the base model: its structure names the graph, and its priors stand in for
            objects and task states the program does not declare.

    Returns:
        A :class:`BeliefGraph` with the program's factors, exactly.

    Raises:
        InputError: the program's sites are not the scenario's, a factor couples a task state
            with another variable, a group to sum out is too large, or a prior is all zero.
    """
    source = program.source
    sites = tuple(scenario.site_names)
    if tuple(s.name for s in program.sites) != sites:
        raise InputError(source, "sites", f"the program's sites are not scenario {scenario.name!r}'s "
                         "(build it with fg.Program.from_scenario(scenario) or fg.program_from_model)")
    objects = tuple(scenario.object_names)
    tracked = [f"{o.name}.{s}" for o in scenario.objects for s in o.state_priors]
    kinds = {v.name: v.kind for v in program.variables}
    for v in program.variables:
        if v.kind == "location" and v.name not in objects:
            raise InputError(source, f"location {v.name!r}", f"unknown object in scenario {scenario.name!r}")
    unary: dict[str, list[np.ndarray]] = {}
    pairs: list[PairRelation] = []
    penalty: float | None = None
    extra: list[Factor] = []
    hidden: list[ProgramFactor] = []
    for f in program.factors:
        touched = [s for s in f.scope if s in tracked]
        if touched:
            if len(f.scope) > 1:
                other = next(s for s in f.scope if s != touched[0])
                raise InputError(source, f"factor {f.name!r}",
                                 f"couples task state {touched[0]!r} with {other!r}; the belief engine keeps "
                                 "task states independent of locations and of each other, so this is not run "
                                 "yet (docs/design.md §4.8)")
            unary.setdefault(f.scope[0], []).append(f.table)
        elif any(kinds[s] != "location" for s in f.scope):
            hidden.append(f)
        elif f.form is not None and f.form[0] == "capacity":
            penalty = f.form[1] if penalty is None else penalty * f.form[1]
        elif f.form is not None and f.form[0] == "pair":
            _, a, b, same_site, same_room = f.form
            pairs.append(PairRelation(a, b, same_site, same_room, f.name))
        elif len(f.scope) == 1:
            unary.setdefault(f.scope[0], []).append(f.table)
        else:
            extra.append(Factor(tuple(location_var(s) for s in f.scope), f.table, f.name))
    for name, scope, table in _summed_out(program, hidden, kinds):
        if len(scope) == 1:
            unary.setdefault(scope[0], []).append(table)
        elif scope:
            extra.append(Factor(tuple(location_var(s) for s in scope), table, name))
    base = _BasePriors(scenario, model)
    priors = tuple(Factor((location_var(o),), _product(source, f"location {o!r}", unary[o]) if o in unary
                          else base.location(o), f"prior {location_var(o)}") for o in objects)
    states = []
    for name in tracked:
        if name in unary:
            table = _product(source, f"state {name!r}", unary[name])
            states.append(state_prior(name, float(table[1])))
        elif name in kinds:
            states.append(state_prior(name, 0.5))  # declared, no factor: uniform
        else:
            states.append(state_prior(name, base.state(name)))
    return BeliefGraph(sites=sites, objects=objects, rooms=tuple(s.room for s in scenario.sites),
                       capacities=tuple(s.capacity for s in scenario.sites), location_priors=priors,
                       state_priors=tuple(states), structure=getattr(model, "structure", "joint"),
                       pairs=tuple(pairs), capacity_penalty=penalty, extra=tuple(extra))


class _BasePriors:
    """The base model's priors for what the program leaves undeclared (built only if needed)."""

    def __init__(self, scenario: Any, model: Any) -> None:
        self.scenario, self.model, self._program = scenario, model, None

    def _factor(self, name: str) -> np.ndarray:
        if self._program is None:
            from fg_tea.model.program_bundled import program_from_model

            self._program = program_from_model(self.scenario, self.model)
        return self._program.factor_named(f"prior {name}").table

    def location(self, obj: str) -> np.ndarray:
        return self._factor(obj)

    def state(self, name: str) -> float:
        return float(self._factor(name)[1])


def _product(source: str, what: str, tables: Sequence[np.ndarray]) -> np.ndarray:
    """The normalised product of one variable's tables (a table already normalised to 1e-12 is kept
    as it is, so a bundled model's priors reach the engine bit for bit)."""
    table = np.array(tables[0], dtype=float)
    for t in tables[1:]:
        table = table * t
    total = float(table.sum())
    if not total > 0:
        raise InputError(source, what, "its factors multiply to zero everywhere (the program is impossible)")
    return table if abs(total - 1.0) <= 1e-12 else table / total


def _summed_out(program: Program, hidden: Sequence[ProgramFactor],
                kinds: dict[str, str]) -> list[tuple[str, tuple[str, ...], np.ndarray]]:
    """Each connected group of factors over variables the task never reads, with those variables
    summed out exactly: (label, location scope, table)."""
    parent: dict[str, str] = {}

    def root(v: str) -> str:
        while parent.setdefault(v, v) != v:
            v = parent[v]
        return v

    for f in hidden:
        own = [s for s in f.scope if kinds[s] != "location"]
        for s in own[1:]:
            parent[root(s)] = root(own[0])
    groups: dict[str, list[ProgramFactor]] = {}
    for f in hidden:
        groups.setdefault(root(next(s for s in f.scope if kinds[s] != "location")), []).append(f)
    out = []
    for members in groups.values():
        names = list(dict.fromkeys(s for f in members for s in f.scope))
        keep = tuple(s for s in names if kinds[s] == "location")
        label = " * ".join(f.name for f in members) + " (summed out: " + \
            ", ".join(s for s in names if kinds[s] != "location") + ")"
        if len(names) > SUM_OUT_LIMIT:
            raise InputError(program.source, f"factor {members[0].name!r}",
                             f"its group of {len(names)} variables is too large to sum out (limit {SUM_OUT_LIMIT})")
        size = len(program.sites) ** len(keep)
        if size > DENSE_LIMIT:
            raise InputError(program.source, f"factor {members[0].name!r}",
                             f"summing out {label} leaves a table of {size:,} entries (limit {DENSE_LIMIT:,})")
        axis = {s: i for i, s in enumerate(names)}
        operands: list[Any] = []
        for f in members:
            operands += [f.table, [axis[s] for s in f.scope]]
        table = np.einsum(*operands, [axis[s] for s in keep], optimize="greedy")
        table = np.asarray(table, dtype=float)
        if not np.any(table > 0):
            raise InputError(program.source, f"factor {members[0].name!r}",
                             f"summing out {label} gives zero everywhere (the program is impossible)")
        out.append((label, keep, table / table.max()))
    return out


__all__ = ["graph_from_program"]
