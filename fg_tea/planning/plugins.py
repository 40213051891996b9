"""Planner plug-ins: how does a search planner written outside fg_tea get into an episode?

A planner is named by a string, and only the string travels (in :class:`~fg_tea.episode.runner.
RunConfig`, in a sweep's :class:`~fg_tea.study.sweep.Job`, to worker processes); each process builds
its own planner from it. Three kinds of name are accepted, tried in this order:

1. a built-in name (:func:`fg_tea.planning.planner_names`: ``efe``, ``factorised_efe``,
   ``nearest``, ``greedy``, ``random``, ``optimal``);
2. the name of an entry point in the group ``fg_tea.planners`` (:data:`ENTRY_POINT_GROUP`), so an
   installed package registers planners by name. In its ``pyproject.toml``::

       [project.entry-points."fg_tea.planners"]
       spiral = "my_package.planners:SpiralPlanner"

   A built-in name always wins over an entry point of the same name;
3. ``module:attribute`` (``mymod:MyPlanner``, ``pkg.sub:make_planner``, ``mymod:Outer.Inner``):
   the module is imported from ``sys.path`` or, failing that, from the current directory.

What the name points at (the entry point's object, or the attribute) may be

- a class or any other callable: it is called with those of the keyword arguments ``model``
  (the agent's :class:`~fg_tea.model.spec.Model`) and ``rng`` (a ``numpy.random.Generator`` seeded
  from the episode seed; use it for every random draw so episodes stay reproducible) that its
  signature names, and must return a planner;
- an object that already has a ``choose`` method: it is used as it is (shared by every episode
  of the process, so it should hold no per-episode state).

The planner must satisfy :class:`~fg_tea.planning.base.Planner`: a ``choose`` method that accepts
``(belief, objects, relevance, distances, inspected, excluded_sites, views=None)`` and returns a
:class:`~fg_tea.planning.base.Decision` naming one of the candidate viewpoints. A ``name``
attribute is optional for plug-ins (the spec string is logged as the episode's planner either
way). A name that cannot be resolved, or an object that does not satisfy the protocol, raises
:class:`PlannerSpecError` (an :class:`~fg_tea.common.errors.InputError`, so the CLI prints one line and
exits with status 2).
"""

from __future__ import annotations

import difflib
import importlib
import inspect
import os
import sys
from importlib import metadata
from typing import Any, Callable, Sequence

from fg_tea.common.errors import InputError
from fg_tea.common.plugins import PluginSpecError, attribute, import_module

#: The entry-point group in which installed packages register planners by name.
ENTRY_POINT_GROUP = "fg_tea.planners"
#: Keyword arguments a plug-in factory may ask for.
FACTORY_ARGUMENTS = ("model", "rng")
_FIELD = "planner"


class PlannerSpecError(InputError):
    """A planner name that does not resolve, or resolves to something that is not a planner."""

    def __init__(self, spec: str, fault: str, field: str = _FIELD) -> None:
        self.spec = spec
        super().__init__("<command line>", field, fault)

    def __reduce__(self):
        return (_rebuild, (self.spec, self.fault, self.path))


def _rebuild(spec: str, fault: str, field: str) -> "PlannerSpecError":
    return PlannerSpecError(spec, fault, field)


def is_module_spec(name: str) -> bool:
    """True for a ``module:attribute`` spec (as opposed to a built-in or entry-point name)."""
    return ":" in name


def entry_points() -> dict[str, metadata.EntryPoint]:
    """Planners registered by installed packages: entry-point name -> entry point, sorted."""
    found = metadata.entry_points(group=ENTRY_POINT_GROUP)
    return {ep.name: ep for ep in sorted(found, key=lambda ep: ep.name)}


def _import_module(spec: str, module: str):
    try:
        return import_module(spec, module, "planner", "mymod:MyPlanner")
    except PluginSpecError as exc:
        raise PlannerSpecError(spec, exc.fault) from None


def _attribute(spec: str, module_obj, name: str):
    try:
        return attribute(spec, module_obj, name)
    except PluginSpecError as exc:
        raise PlannerSpecError(spec, exc.fault) from None


def resolve(name: str, builtin: Sequence[str] = ()) -> Any:
    """The object a plug-in name points at (a class, factory or planner instance).

    Built-in names are not handled here (:func:`fg_tea.planning.make_planner` builds them).

    Raises:
        PlannerSpecError: not an entry-point name nor an importable ``module:attribute``.
    """
    if not isinstance(name, str) or not name.strip():
        raise PlannerSpecError(str(name), "expected a planner name or module:attribute")
    if is_module_spec(name):
        module, _, attribute = name.partition(":")
        if not module or not attribute:
            raise PlannerSpecError(name, f"{name!r}: expected module:attribute, e.g. mymod:MyPlanner")
        return _attribute(name, _import_module(name, module), attribute)
    if name in _REGISTERED:
        return _REGISTERED[name]
    points = entry_points()
    if name in points:
        try:
            return points[name].load()
        except Exception as exc:
            first = (str(exc).splitlines() or [""])[0]
            raise PlannerSpecError(name, f"entry point {name!r} ({points[name].value}) of group "
                                   f"{ENTRY_POINT_GROUP!r} cannot be loaded: "
                                   f"{type(exc).__name__}: {first}") from None
    known = list(builtin) + [n for n in points if n not in builtin]
    close = difflib.get_close_matches(name, known, n=1, cutoff=0.6)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    raise PlannerSpecError(name, f"unknown planner {name!r}{hint} (known: {', '.join(known)}; or "
                           "module:attribute for a planner of your own)")


#: The arguments the runner passes to ``choose`` (positional, then ``views`` by keyword).
_CHOOSE_ARGS = ("belief", "objects", "relevance", "distances", "inspected", "excluded_sites")


def _check_choose(spec: str, choose: Any, bound: bool) -> None:
    if not callable(choose):
        raise PlannerSpecError(spec, f"{spec!r} does not satisfy the Planner protocol: it has no "
                               "choose() method (see fg_tea.planning.base.Planner)")
    try:
        signature = inspect.signature(choose)
    except (TypeError, ValueError):  # a builtin without a signature: accept, it fails loudly later
        return
    args = ([] if bound else [None]) + [None] * len(_CHOOSE_ARGS)
    try:
        signature.bind(*args, views=None)
    except TypeError:
        raise PlannerSpecError(spec, f"{spec!r} does not satisfy the Planner protocol: "
                               f"choose{signature} cannot be called as choose(belief, objects, "
                               "relevance, distances, inspected, excluded_sites, views=None)") from None


def _factory_kwargs(factory: Callable, available: dict[str, Any]) -> dict[str, Any]:
    try:
        parameters = inspect.signature(factory).parameters
    except (TypeError, ValueError):
        return {}
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values()):
        return dict(available)
    return {k: v for k, v in available.items() if k in parameters}


def check_plugin(name: str, builtin: Sequence[str] = ()) -> None:
    """Check, without building it, that `name` names a plug-in planner (built-in names are
    :func:`fg_tea.planning.check_planner`'s). The module is imported and the ``choose`` signature
    checked; a factory function can only be checked when it is called.

    Raises:
        PlannerSpecError: unknown name, import failure, missing attribute, or no usable choose().
    """
    target = resolve(name, builtin)
    if inspect.isclass(target):
        _check_choose(name, getattr(target, "choose", None), bound=False)
    elif callable(getattr(target, "choose", None)):
        _check_choose(name, target.choose, bound=True)
    elif not callable(target):
        raise PlannerSpecError(name, f"{name!r} is a {type(target).__name__}, not a planner class, "
                               "factory or instance (see fg_tea.planning.base.Planner)")


def build(name: str, model, rng, builtin: Sequence[str] = ()) -> Any:
    """Build the planner a plug-in name points at, and check it against the protocol.

    Args:
        name: an entry-point name or ``module:attribute``.
        model: the agent's model (passed to a factory that names ``model``).
        rng: the episode's planner Generator (passed to a factory that names ``rng``).

    Raises:
        PlannerSpecError: see :func:`resolve`; or the factory raised or exited, or built no planner.
    """
    target = resolve(name, builtin)
    if callable(getattr(target, "choose", None)) and not inspect.isclass(target):
        planner = target
    elif callable(target):
        kwargs = _factory_kwargs(target, {"model": model, "rng": rng})
        try:
            planner = target(**kwargs)
        except KeyboardInterrupt:
            raise
        except SystemExit as exc:  # exit() as a factory (builtins:exit): never a silent success
            raise PlannerSpecError(name, f"building planner {name!r} called exit({exc.code!r}); a "
                                   "planner factory must return a planner, not exit") from None
        except BaseException as exc:  # an error, or a BaseException of the plug-in's own
            first = (str(exc).splitlines() or [""])[0]
            raise PlannerSpecError(name, f"building planner {name!r} raised "
                                   f"{type(exc).__name__}: {first}") from None
    else:
        raise PlannerSpecError(name, f"{name!r} is a {type(target).__name__}, not a planner class, "
                               "factory or instance (see fg_tea.planning.base.Planner)")
    _check_choose(name, getattr(planner, "choose", None), bound=True)
    if callable(getattr(planner, "check", None)):
        return planner
    try:  # a plug-in that states no limits: a no-op check (the Planner protocol's default)
        planner.check = _no_limits
        return planner
    except (AttributeError, TypeError):  # __slots__ or a read-only object: wrap it
        return _WithoutLimits(planner)


def _no_limits(belief, objects) -> None:
    return None


class _WithoutLimits:
    """A plug-in planner that states no limits: :meth:`~fg_tea.planning.base.Planner.check` is a
    no-op; everything else is the plug-in's own."""

    def __init__(self, planner: Any) -> None:
        self._planner = planner

    def __getattr__(self, attribute: str) -> Any:
        return getattr(self._planner, attribute)

    def check(self, belief, objects) -> None:
        return None

    def choose(self, *args: Any, **kwargs: Any) -> Any:
        return self._planner.choose(*args, **kwargs)


__all__ = ["ENTRY_POINT_GROUP", "FACTORY_ARGUMENTS", "PlannerSpecError", "is_module_spec",
           "entry_points", "resolve", "check_plugin", "build", "register"]


#: Planners registered in this process by :func:`register_planner` (name -> factory or planner).
_REGISTERED: dict[str, Any] = {}


def register(name: str, planner: Any) -> None:
    """Store `planner` under `name` for this process (see :func:`fg_tea.planning.register_planner`).

    Raises:
        PlannerSpecError: the object is not a planner or a factory.
    """
    if hasattr(planner, "choose"):
        _check_choose(name, planner.choose, bound=not inspect.isclass(planner))
    elif not callable(planner):
        raise PlannerSpecError(name, "expected a planner (an object with choose) or a factory")
    _REGISTERED[name] = planner
