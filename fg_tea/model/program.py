"""Models as programs: discrete variables and the factors over them, declared in Python.

A :class:`Program` is the model a user would write on a whiteboard (docs/design.md §4.8)::

    m = fg.Program.from_scenario(scenario)
    m.location("mug")                                   # where the mug is: one of the sites
    m.state("mug.dirty")                                # a hidden Bernoulli state
    m.variable("weather", ["dry", "wet"])               # a variable of your own

    @m.factor("mug", "mug.dirty")                       # a function of the values -> weight
    def dirty_mug_by_sink(mug, dirty):
        return 5.0 if dirty and mug.furniture == "sink" else 1.0

    m.table(["weather"], [0.7, 0.3], name="weather prior", learnable=True)
    m.learnable_transition("boil")                      # learn how often boiling really heats
    belief = fg.compile_program(m)                              # exact inference (fg_tea.beliefs.compiled)

Every factor is stored as a table over its scope's assignments; a function is evaluated once per
assignment when it is declared. A location's values are :class:`SiteValue` objects carrying the
site's name, room, furniture, capacity and position, so "same room" or "within 1.5 m of the sink"
is one line. Every fault — a function that raises or returns NaN, a negative or all-zero table, an
unknown variable or site — is an :class:`~fg_tea.common.errors.InputError` naming the program's
source, the factor and the fault, in one line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np

from fg_tea.common.errors import InputError

#: Most assignments a function factor is evaluated over (it is called once per assignment).
FUNCTION_LIMIT = 2_000_000
#: Most entries a table (given, or from a vectorised function) may have.
TABLE_LIMIT = 50_000_000
#: The values of a hidden state variable, in index order.
STATE_VALUES = (False, True)
KINDS = ("location", "state", "variable")


@dataclass(frozen=True)
class SiteValue:
    """One value of a location variable: a site of the house, as a factor function sees it.

    Attributes:
        name: the site's name (``"kitchen_counter"``).
        room: the room it is in.
        furniture: the furniture it is the top of (None if it has none).
        capacity: how many objects it holds (None = unlimited).
        position: (x, y, z) of its surface in metres.
        index: its position in the scenario's site order (the axis index of tables).
    """

    name: str
    room: str
    furniture: str | None
    capacity: int | None
    position: tuple[float, float, float]
    index: int

    def distance(self, other: "SiteValue | Sequence[float]") -> float:
        """Horizontal (x, y) distance in metres to another site or to an (x, y[, z]) point."""
        x, y = (other.position[:2] if isinstance(other, SiteValue) else tuple(other)[:2])
        return math.hypot(self.position[0] - x, self.position[1] - y)

    def __str__(self) -> str:
        return self.name


@dataclass(frozen=True)
class Variable:
    """A discrete variable of a program.

    Attributes:
        name: its name in scopes and queries (``"mug"``, ``"mug.dirty"``, ``"weather"``).
        kind: ``"location"`` (values are sites), ``"state"`` (False, True) or ``"variable"``.
        values: its values in index order.
    """

    name: str
    kind: str
    values: tuple[Any, ...]

    @property
    def card(self) -> int:
        """How many values it has."""
        return len(self.values)

    @property
    def key(self) -> str:
        """The belief engine's name for it: ``L[mug]`` for a location, else its name."""
        return f"L[{self.name}]" if self.kind == "location" else self.name

    @property
    def labels(self) -> tuple[str, ...]:
        """Its values as text (site names, ``false``/``true``, or ``str(value)``)."""
        if self.kind == "state":
            return ("false", "true")
        return tuple(str(v) for v in self.values)


class ProgramFactor:
    """A named non-negative table over some of a program's variables.

    Attributes:
        name: unique within its program (what :meth:`Program.remove` and ``replace`` take).
        scope: variable names, one per axis of `table`.
        table: float64 array, finite, non-negative, not all zero (a structured factor builds it
            on first use).
        learnable: marked for learning (docs/design.md §12); inference treats it like any table.
        origin: ``"table"`` or ``"function"`` (how it was declared), for the compiled plan.
        form: None, or the structured form a bundled model's factor was made from and still has
            (``("pair", a, b, same_site, same_room)`` or ``("capacity", penalty)``); the belief
            engine keeps such factors structured (:func:`fg_tea.beliefs.graph.graph_from_program`).
    """

    __slots__ = ("name", "scope", "_table", "_build", "learnable", "origin", "form")

    def __init__(self, name: str, scope: tuple[str, ...], table: np.ndarray | None = None,
                 learnable: bool = False, origin: str = "table", form: tuple[Any, ...] | None = None,
                 build: Callable[[], np.ndarray] | None = None) -> None:
        if (table is None) == (build is None):
            raise ValueError("a program factor needs a table or a way to build one, not both")
        self.name, self.scope, self._table, self._build = name, tuple(scope), table, build
        self.learnable, self.origin, self.form = bool(learnable), origin, form

    @property
    def table(self) -> np.ndarray:
        """The factor's table over its scope (built, once, when first asked for)."""
        if self._table is None:
            assert self._build is not None
            self._table = self._build()
        return self._table

    def __repr__(self) -> str:
        return f"ProgramFactor({self.name!r}, scope={self.scope!r}, origin={self.origin!r})"


class Program:
    """A factor-graph model written in Python: variables, and factors over any subset of them.

    Build one with :meth:`from_scenario` (locations range over the house's sites), with
    ``fg.program_from_model(scenario, model)`` (a bundled model's factors, to edit), or directly
    with ``Program(sites=scenario.sites)``. Then declare variables with :meth:`location`,
    :meth:`state` and :meth:`variable`, and factors with :meth:`factor` (a function) or
    :meth:`table`; :meth:`remove` and :meth:`replace` edit it; :meth:`learnable_transition` marks a
    transition of the model for learning. ``fg.compile_program(program)`` turns it
    into an exact belief (marginals, joints, hypothetical posteriors, K best arrangements) and
    ``fg.compile_program(program).plan()`` prints how each query will be answered.

    Args:
        sites: the house's sites (scenario :class:`~fg_tea.world.scenario.Site` objects or
            :class:`SiteValue`); location variables range over them, in this order.
        objects: the objects a location may be declared for (None = any name).
        source: where the program comes from (a file name), the first field of its errors.
    """

    def __init__(self, sites: Iterable[Any] = (), objects: Iterable[str] | None = None,
                 source: str = "<program>") -> None:
        self.source = source
        self.sites: tuple[SiteValue, ...] = tuple(_site_value(s, i) for i, s in enumerate(sites))
        names = [s.name for s in self.sites]
        if len(set(names)) != len(names):
            raise InputError(source, "sites", "two sites share a name")
        self.objects = None if objects is None else tuple(objects)
        self._variables: dict[str, Variable] = {}
        self._factors: dict[str, ProgramFactor] = {}
        self._learnable_transitions: list[str] = []
        #: The model whose other settings (planning, detection, sensors, transitions) go with
        #: these starting factors: set by ``program_from_model``; None = the default model's.
        self.model: Any = None

    @classmethod
    def from_scenario(cls, scenario: Any, source: str | None = None) -> "Program":
        """An empty program over a scenario's house: its sites, and its objects' names.

        Args:
            scenario: a loaded :class:`~fg_tea.world.scenario.Scenario` (``fg.load_scenario``).
            source: the name errors give (default: the scenario's file or name).

        Returns:
            A program with no variables yet; declare them with :meth:`location` and friends.
        """
        return cls(scenario.sites, scenario.object_names,
                   source or scenario.source or f"<program on {scenario.name}>")

    # -- variables -------------------------------------------------------------------------

    def location(self, obj: str) -> Variable:
        """Declare where object `obj` is: a variable over the sites (values are :class:`SiteValue`).

        Args:
            obj: the object's name; the variable is named the same (its engine key is ``L[obj]``).

        Returns:
            The new :class:`Variable`.
        """
        if not self.sites:
            raise InputError(self.source, f"location {obj!r}", "the program has no sites")
        if self.objects is not None and obj not in self.objects:
            raise InputError(self.source, f"location {obj!r}",
                             f"unknown object (known: {', '.join(self.objects)})")
        return self._declare(Variable(obj, "location", self.sites))

    def state(self, name: str) -> Variable:
        """Declare a hidden Bernoulli state such as ``"mug.dirty"``; its values are False, True."""
        return self._declare(Variable(name, "state", STATE_VALUES))

    def variable(self, name: str, values: Sequence[Any]) -> Variable:
        """Declare a variable of your own with named values.

        Args:
            name: its name.
            values: its values, at least one, all different (strings, numbers...).

        Returns:
            The new :class:`Variable`; factor functions receive its values as given here.
        """
        values = tuple(values) if not isinstance(values, str) else ()
        if not values:
            raise InputError(self.source, f"variable {name!r}", "needs a list of at least one value")
        if len(set(map(repr, values))) != len(values):
            raise InputError(self.source, f"variable {name!r}", "two values are the same")
        return self._declare(Variable(name, "variable", values))

    def _declare(self, var: Variable) -> Variable:
        if not isinstance(var.name, str) or not var.name:
            raise InputError(self.source, "variable", "a variable needs a non-empty name")
        if var.name in self._variables or any(v.key == var.name or v.name == var.key
                                              for v in self._variables.values()):
            raise InputError(self.source, f"variable {var.name!r}", "declared twice")
        self._variables[var.name] = var
        return var

    @property
    def variables(self) -> tuple[Variable, ...]:
        """The declared variables, in declaration order."""
        return tuple(self._variables.values())

    def var(self, name: str) -> Variable:
        """The variable called `name` (a location may also be named ``L[obj]``).

        Raises:
            InputError: no such variable (the message lists the declared ones).
        """
        found = self._variables.get(name)
        if found is None:
            found = next((v for v in self._variables.values() if v.key == name), None)
        if found is None:
            known = ", ".join(self._variables) or "none declared"
            raise InputError(self.source, f"variable {name!r}", f"unknown variable (known: {known})")
        return found

    def site(self, name: str) -> SiteValue:
        """The site called `name`, e.g. to measure distances from it in a factor function.

        Raises:
            InputError: no such site.
        """
        for s in self.sites:
            if s.name == name:
                return s
        raise InputError(self.source, f"site {name!r}",
                         f"unknown site (known: {', '.join(s.name for s in self.sites) or 'none'})")

    # -- factors ---------------------------------------------------------------------------

    def factor(self, *scope: str, name: str | None = None, learnable: bool = False,
               replace: bool = False, vectorised: bool = False) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
        """Decorator: a factor whose weight is a Python function of its variables' values.

        The function receives one value per scope variable, in scope order (a
        :class:`SiteValue` for a location, a bool for a state, the declared value otherwise),
        and returns a finite non-negative weight. It is evaluated once over every assignment
        of the scope when declared (a loop, at most :data:`FUNCTION_LIMIT` assignments), and
        stored as a table. With ``vectorised=True`` it is called once with arrays instead
        (:mod:`fg_tea.model.program_vector`: a location is a ``SiteArray``, a state a bool
        array) and returns an array of weights.

        Args:
            *scope: the variables' names (one to all of the program's variables).
            name: the factor's name (default: the function's name).
            learnable: mark the table as learnable.
            replace: replace the factor of that name instead of refusing a duplicate.
            vectorised: call the function once with arrays over every assignment.

        Returns:
            A decorator that declares the factor and returns the function unchanged.
        """
        def declare(func: Callable[..., Any]) -> Callable[..., Any]:
            label = str(name or getattr(func, "__name__", "factor"))
            self._add(self._evaluate(label, scope, func, vectorised), learnable, "function", replace)
            return func
        return declare

    def function(self, scope: Sequence[str], func: Callable[..., Any], name: str | None = None,
                 learnable: bool = False, vectorised: bool = False) -> ProgramFactor:
        """Declare a function factor without the decorator; see :meth:`factor`.

        Returns:
            The stored :class:`ProgramFactor`.
        """
        label = str(name or getattr(func, "__name__", "factor"))
        return self._add(self._evaluate(label, tuple(scope), func, vectorised), learnable, "function", False)

    def table(self, scope: Sequence[str] | str, weights: Any, name: str | None = None,
              learnable: bool = False) -> ProgramFactor:
        """Declare a factor given as a table of weights.

        Args:
            scope: the variables' names (a single name is a one-variable scope).
            weights: an array-like of shape (values of each scope variable), first variable
                first; or, for one variable, a mapping value (or site name) -> weight, with
                missing values weighing 0.
            name: the factor's name (default ``"table(a, b)"``).
            learnable: mark the table as learnable.

        Returns:
            The stored :class:`ProgramFactor`.
        """
        scope = (scope,) if isinstance(scope, str) else tuple(scope)
        label = name or f"table({', '.join(scope)})"
        return self._add(self._tabulate(label, scope, weights), learnable, "table", False)

    def remove(self, name: str) -> ProgramFactor:
        """Remove the factor called `name` and return it.

        Raises:
            InputError: no factor has that name.
        """
        self._factor_named(name)
        return self._factors.pop(name)

    def replace(self, name: str, weights: Any = None, *, function: Callable[..., Any] | None = None,
                scope: Sequence[str] | None = None, learnable: bool | None = None,
                vectorised: bool = False) -> ProgramFactor:
        """Replace the factor called `name` by a new table or function (same name and place).

        Args:
            name: the factor to replace.
            weights: the new table (as for :meth:`table`), or None with `function`.
            function: the new weight function (as for :meth:`factor`).
            scope: the new scope (default: the old one).
            learnable: the new mark (default: the old one).
            vectorised: the new function takes arrays (see :meth:`factor`).

        Returns:
            The new :class:`ProgramFactor`.
        """
        old = self._factor_named(name)
        new_scope = old.scope if scope is None else tuple(scope)
        if (weights is None) == (function is None):
            raise InputError(self.source, f"factor {name!r}", "replace needs a table or a function, not both")
        made = (self._evaluate(name, new_scope, function, vectorised) if function is not None
                else self._tabulate(name, new_scope, weights))
        mark = old.learnable if learnable is None else learnable
        return self._add(made, mark, "function" if function is not None else "table", True)

    @property
    def factors(self) -> tuple[ProgramFactor, ...]:
        """The factors, in declaration order."""
        return tuple(self._factors.values())

    @property
    def learnable(self) -> tuple[str, ...]:
        """Names of the factors marked learnable."""
        return tuple(f.name for f in self._factors.values() if f.learnable)

    def learnable_transition(self, name: str) -> str:
        """Mark the model's transition `name` (``"boil"``) learnable: ``fg-tea learn`` counts the
        success of each of its effects from the program's episodes (docs/design.md §12.5, eqs.
        61-63) and the learned program uses the learned successes; so does ``compare --lifelong``.

        The transitions are the base model's (the module's ``base``); a name it does not declare
        is refused in one line when the program is built.

        Args:
            name: the transition's name, as the model's ``[transitions]`` table names it.

        Returns:
            `name`.
        """
        if not isinstance(name, str) or not name:
            raise InputError(self.source, "learnable_transition", "needs a transition's name (a string)")
        known = getattr(self.model, "transitions", None)
        if known is not None and name not in known:
            raise InputError(self.source, f"learnable_transition {name!r}",
                             f"unknown transition (known: {', '.join(sorted(known))})")
        if name not in self._learnable_transitions:
            self._learnable_transitions.append(name)
        return name

    @property
    def learnable_transitions(self) -> tuple[str, ...]:
        """Names of the model's transitions marked learnable (:meth:`learnable_transition`)."""
        return tuple(self._learnable_transitions)

    def factor_named(self, name: str) -> ProgramFactor:
        """The factor called `name` (InputError naming the known factors otherwise)."""
        return self._factor_named(name)

    def _factor_named(self, name: str) -> ProgramFactor:
        if name not in self._factors:
            known = ", ".join(self._factors) or "none declared"
            raise InputError(self.source, f"factor {name!r}", f"unknown factor (known: {known})")
        return self._factors[name]

    def _add(self, made: tuple[str, tuple[str, ...], np.ndarray], learnable: bool, origin: str,
             replace: bool) -> ProgramFactor:
        name, scope, table = made
        if name in self._factors and not replace:
            raise InputError(self.source, f"factor {name!r}", "declared twice (use replace to change it)")
        return self._put(ProgramFactor(name, scope, table, bool(learnable), origin), replace)

    def _put(self, made: ProgramFactor, replace: bool = False) -> ProgramFactor:
        """Store a made factor (a bundled model's structured factors come in this way)."""
        if made.name in self._factors and not replace:
            raise InputError(self.source, f"factor {made.name!r}", "declared twice (use replace to change it)")
        self._factors[made.name] = made  # a replaced factor keeps its place in the order
        return made

    def _scope(self, label: str, scope: tuple[str, ...]) -> tuple[Variable, ...]:
        if not scope:
            raise InputError(self.source, f"factor {label!r}", "names no variable")
        if any(not isinstance(s, str) for s in scope):
            raise InputError(self.source, f"factor {label!r}", "variables are given by name (strings)")
        variables = []
        for s in scope:
            try:
                variables.append(self.var(s))
            except InputError as exc:
                raise InputError(self.source, f"factor {label!r}", exc.fault.replace(
                    "unknown variable", f"unknown variable {s!r}")) from None
        if len({v.name for v in variables}) != len(variables):
            raise InputError(self.source, f"factor {label!r}", "names a variable twice")
        return tuple(variables)

    def _evaluate(self, label: str, scope: tuple[str, ...], func: Callable[..., Any],
                  vectorised: bool = False) -> tuple[str, tuple[str, ...], np.ndarray]:
        variables = self._scope(label, scope)
        shape = tuple(v.card for v in variables)
        size = math.prod(shape)
        if vectorised:
            return label, tuple(v.name for v in variables), self._vectorised(label, variables, func)
        if size > FUNCTION_LIMIT:
            raise InputError(self.source, f"factor {label!r}",
                             f"a function over {size:,} assignments (limit {FUNCTION_LIMIT:,}); "
                             "give it as a table")
        if not callable(func):
            raise InputError(self.source, f"factor {label!r}", "is not a function")
        table = np.empty(size)
        for flat, index in enumerate(np.ndindex(*shape)):
            values = [v.values[i] for v, i in zip(variables, index)]
            try:
                weight = func(*values)
            except Exception as exc:  # a user's function: any failure is reported in one line
                raise InputError(self.source, f"factor {label!r}",
                                 f"raised {type(exc).__name__}: {exc} at {_where(variables, index)}") from None
            table[flat] = _weight(self.source, label, weight, variables, index)
        return label, tuple(v.name for v in variables), _checked(self.source, label, table.reshape(shape))

    def _vectorised(self, label: str, variables: tuple[Variable, ...], func: Callable[..., Any]) -> np.ndarray:
        from fg_tea.model.program_vector import arguments, broadcast_weights

        shape = tuple(v.card for v in variables)
        if math.prod(shape) > TABLE_LIMIT:
            raise InputError(self.source, f"factor {label!r}",
                             f"a table of {math.prod(shape):,} entries (limit {TABLE_LIMIT:,})")
        if not callable(func):
            raise InputError(self.source, f"factor {label!r}", "is not a function")
        try:
            result = func(*arguments(variables))
        except Exception as exc:  # a user's function: any failure is reported in one line
            raise InputError(self.source, f"factor {label!r}",
                             f"raised {type(exc).__name__}: {exc} (called once with arrays: vectorised=True)") from None
        table = broadcast_weights(result, shape)
        if isinstance(table, str):
            raise InputError(self.source, f"factor {label!r}", table)
        bad = np.flatnonzero(~np.isfinite(table) | (table < 0))
        if bad.size:
            index = np.unravel_index(int(bad[0]), shape)
            _weight(self.source, label, float(table[index]), variables, [int(i) for i in index])
        return _checked(self.source, label, table)

    def _tabulate(self, label: str, scope: tuple[str, ...],
                  weights: Any) -> tuple[str, tuple[str, ...], np.ndarray]:
        variables = self._scope(label, scope)
        shape = tuple(v.card for v in variables)
        if isinstance(weights, Mapping):
            if len(variables) != 1:
                raise InputError(self.source, f"factor {label!r}", "a mapping of weights needs a one-variable scope")
            table = self._mapped(label, variables[0], weights)
        else:
            try:
                table = np.array(weights, dtype=float)
            except (TypeError, ValueError) as exc:
                raise InputError(self.source, f"factor {label!r}", f"weights are not numbers: {exc}") from None
            if table.shape != shape:
                raise InputError(self.source, f"factor {label!r}",
                                 f"table has shape {table.shape}, expected {shape} "
                                 f"(values of {', '.join(v.name for v in variables)})")
        return label, tuple(v.name for v in variables), _checked(self.source, label, table)

    def _mapped(self, label: str, var: Variable, weights: Mapping[Any, Any]) -> np.ndarray:
        table = np.zeros(var.card)
        labels = {lab: i for i, lab in enumerate(var.labels)}
        for key, w in weights.items():
            i = labels.get(key if isinstance(key, str) else str(key).lower() if var.kind == "state" else str(key))
            if i is None:
                what = "site" if var.kind == "location" else "value"
                raise InputError(self.source, f"factor {label!r}",
                                 f"unknown {what} {key!r} of {var.name} (known: {', '.join(var.labels)})")
            table[i] = _weight(self.source, label, w, (var,), (i,))
        return table

    def __repr__(self) -> str:
        return (f"Program({self.source!r}: {len(self._variables)} variables, "
                f"{len(self._factors)} factors)")


def _site_value(site: Any, index: int) -> SiteValue:
    if isinstance(site, SiteValue):
        return SiteValue(site.name, site.room, site.furniture, site.capacity, site.position, index)
    if isinstance(site, str):
        return SiteValue(site, "", None, None, (0.0, 0.0, 0.0), index)
    x, y, z = (float(c) for c in site.position)
    return SiteValue(site.name, site.room, getattr(site, "furniture", None), getattr(site, "capacity", None),
                     (x, y, z), index)


def _where(variables: Sequence[Variable], index: Sequence[int]) -> str:
    return ", ".join(f"{v.name}={v.labels[i]}" for v, i in zip(variables, index))


def _weight(source: str, label: str, weight: Any, variables: Sequence[Variable], index: Sequence[int]) -> float:
    if isinstance(weight, (bool, np.bool_)):
        weight = float(weight)
    try:
        value = float(weight)
    except (TypeError, ValueError):
        raise InputError(source, f"factor {label!r}", f"returned {type(weight).__name__} {weight!r}, not a "
                         f"number, at {_where(variables, index)}") from None
    if not math.isfinite(value) or value < 0:
        raise InputError(source, f"factor {label!r}",
                         f"weight {value!r} at {_where(variables, index)} (weights must be finite and >= 0)")
    return value


def _checked(source: str, label: str, table: np.ndarray) -> np.ndarray:
    if not np.all(np.isfinite(table)):
        raise InputError(source, f"factor {label!r}", "table holds NaN or infinite weights")
    if np.any(table < 0):
        raise InputError(source, f"factor {label!r}", f"table holds a negative weight ({float(table.min()):g})")
    if not np.any(table > 0):
        raise InputError(source, f"factor {label!r}", "every weight is zero (the program would be impossible)")
    out = np.array(table, dtype=float)
    out.setflags(write=False)
    return out
