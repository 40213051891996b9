"""Model programs as model files: ``--model my_model.py``, ``module:attr`` or an entry point.

A model program (docs/design.md §4.8, docs/how-to/model-as-program.md) is a Python function of the
scenario that returns a :class:`~fg_tea.model.program.Program` — the model's starting factors::

    import fg_tea as fg
    base = "joint"                      # the model whose other settings go with it (optional)

    def model(scenario):
        m = fg.program_from_model(scenario, fg.load_model(base))
        ...
        return m

Three kinds of reference name one, as plug-in planners are named (the import is
:mod:`fg_tea.planning.plugins`'s): a ``.py`` file (its function ``model``); ``module:attribute``;
or the name of an entry point in the group ``fg_tea.models``
(:data:`~fg_tea.common.resources.MODEL_ENTRY_POINT_GROUP`).

:func:`load_program_model` returns a :class:`~fg_tea.model.spec.Model` that is the base model
(the module's ``base``: a model name or file, default :data:`~fg_tea.common.resources.DEFAULT_MODEL`)
— planning weights, detection, sensors, transitions — named after the program, with
``Model.program`` set to a :class:`ProgramSource`. Every construction of the belief engine's graph
then builds the program for its scenario (:func:`program_for`, called by
:func:`fg_tea.beliefs.graph.build_graph`).

Faults are one :class:`~fg_tea.common.errors.InputError` line each (the CLI exits 2): a file that
does not import or defines no ``model`` function, a function that raises, exits or returns no
program, a factor's fault (:mod:`fg_tea.model.program`), a program built on another base model
than the module's ``base``, and a build or import that takes longer than the time limit
(:data:`BUILD_SECONDS`, or the environment variable ``FG_TEA_MODEL_SECONDS``; enforced with
SIGALRM in the main thread of Unix processes, where every fg-tea command builds it).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import signal
import sys
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable, Iterator

from fg_tea.common.errors import InputError
from fg_tea.common.plugins import PluginSpecError, attribute, import_module
from fg_tea.common import resources
from fg_tea.common.resources import MODEL_ENTRY_POINT_GROUP, is_program_ref

#: The entry-point group in which installed packages register model programs by name.
#: The function a model program file defines.
FUNCTION = "model"
#: Default time limit, in seconds, on importing a program file and on building its program.
BUILD_SECONDS = 60.0
#: The environment variable that overrides :data:`BUILD_SECONDS`.
SECONDS_VARIABLE = "FG_TEA_MODEL_SECONDS"
_FIELD = "model"


@dataclass(frozen=True, eq=False)
class ProgramSource:
    """Where a program model's starting factors come from.

    Attributes:
        spec: the reference as given (``my_model.py``, ``pkg.mod:model``, an entry-point name).
        file: the Python file that defines it: as given for a ``.py`` reference, else relative to
            its import root (``pkg/models.py``).
        sha256: the file's SHA-256 when loaded.
        function: the function of the scenario that returns the program.
        base: the base model's name or file (the module's ``base``).
        learned_from: for a program written by ``fg-tea learn``, the SHA-256 of the program it
            learned from (the module's ``learned_from``), so its logs can be learned from again.
        transition_terms: for a learned program, the eq. (61) terms of its learnable transitions'
            effects (the module's ``transition_terms``: ``{"boil.effect0": {"state", "terms"}}``),
            applied to the base model's transitions when it is loaded (docs/design.md §12.5).
        transition_strength: S_t of those terms (the module's ``transition_strength``).
    """

    spec: str
    file: str
    sha256: str
    function: Callable[[Any], Any]
    base: str
    learned_from: str = ""
    transition_terms: Any = None
    transition_strength: float = 0.0


class _Timeout(BaseException):
    """Raised by the alarm; a BaseException so that a program's ``except Exception`` cannot hide it."""


def build_seconds() -> float:
    """The time limit on importing and building a program (:data:`SECONDS_VARIABLE` or the default)."""
    text = os.environ.get(SECONDS_VARIABLE, "").strip()
    if not text:
        return BUILD_SECONDS
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value > 0 or value == float("inf"):
        raise InputError(f"${SECONDS_VARIABLE}", "$", f"{text!r} is not a positive number of seconds")
    return value


@contextmanager
def _time_limit(spec: str, what: str) -> Iterator[None]:
    seconds = build_seconds()
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "setitimer"):
        yield  # no alarm outside the main thread (the CLI builds programs in its main thread)
        return

    def alarm(signum: int, frame: Any) -> None:
        raise _Timeout()

    previous = signal.signal(signal.SIGALRM, alarm)
    outer, _ = signal.setitimer(signal.ITIMER_REAL, seconds)  # an alarm the caller had set
    started = time.monotonic()
    try:
        yield
    except _Timeout:
        raise InputError(spec, _FIELD, f"{what} did not finish within {seconds:g} s (the time limit; "
                         f"set {SECONDS_VARIABLE} to change it)") from None
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
        if outer > 0:  # the caller's alarm goes on, less the time spent here
            signal.setitimer(signal.ITIMER_REAL, max(outer - (time.monotonic() - started), 1e-3))


def _first(exc: BaseException) -> str:
    return (str(exc).splitlines() or [""])[0]


def _from_file(spec: str) -> tuple[Any, Path]:
    path = Path(spec)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(spec, "$", f"cannot read the model program: {exc.strerror or exc}") from None
    name = f"fg_tea_model_{hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:16]}"
    module_spec = importlib.util.spec_from_file_location(name, path)
    if module_spec is None or module_spec.loader is None:
        raise InputError(spec, "$", "not a Python file")
    module = importlib.util.module_from_spec(module_spec)
    try:
        code = compile(data, str(path), "exec")
    except (SyntaxError, ValueError) as exc:
        line, message = getattr(exc, "lineno", None), getattr(exc, "msg", None) or exc
        raise InputError(spec, f"line {line}" if line else "$",
                         f"not a Python model program: {type(exc).__name__}: {message}") from None
    sys.modules[name] = module
    try:
        with _time_limit(spec, "importing the file"):
            exec(code, module.__dict__)
    except InputError:
        raise
    except SystemExit as exc:
        raise InputError(spec, "$", f"importing it called exit({exc.code!r}); a model program must not exit") from None
    except Exception as exc:
        raise InputError(spec, "$", f"importing it raised {type(exc).__name__}: {_first(exc)}") from None
    return module, path


def _from_module(spec: str) -> tuple[Any, Any]:
    module_name, _, name = spec.partition(":")
    try:
        with _time_limit(spec, "importing the module"):
            module = import_module(spec, module_name, "model", "mymod:model")
        return module, attribute(spec, module, name)
    except PluginSpecError as exc:
        raise InputError(spec, _FIELD, exc.fault) from None


def _from_entry_point(spec: str) -> tuple[Any, Any]:
    point = resources.model_entry_points()[spec]
    try:
        with _time_limit(spec, "loading the entry point"):
            target = point.load()
    except InputError:
        raise
    except Exception as exc:
        raise InputError(spec, _FIELD, f"entry point {spec!r} ({point.value}) of group {MODEL_ENTRY_POINT_GROUP!r} "
                         f"cannot be loaded: {type(exc).__name__}: {_first(exc)}") from None
    return sys.modules.get(getattr(target, "__module__", "") or ""), target


def load_program_source(ref: str | Path) -> ProgramSource:
    """Import a model program (file, ``module:attribute`` or entry point) without building it.

    Raises:
        InputError: it does not import, or names no callable.
    """
    spec = str(ref)
    if spec.endswith(".py"):
        module, path = _from_file(spec)
        target = getattr(module, FUNCTION, None)
        if target is None:
            raise InputError(spec, "$", f"not a model program: it defines no function {FUNCTION}(scenario) "
                             "returning a fg.Program")
    elif ":" in spec:
        module, target = _from_module(spec)
        path = Path(getattr(module, "__file__", "") or spec)
    else:
        module, target = _from_entry_point(spec)
        path = Path(getattr(module, "__file__", "") or spec)
    if not callable(target):
        raise InputError(spec, _FIELD, f"{FUNCTION} is a {type(target).__name__}, not a function of the scenario")
    base = getattr(module, "base", None)
    if base is None:
        from fg_tea.common.resources import DEFAULT_MODEL

        base = DEFAULT_MODEL
    if not isinstance(base, (str, Path)):
        raise InputError(spec, "base", f"is a {type(base).__name__}; name a model (a bundled name or a file)")
    try:
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        digest = ""
    label = spec if spec.endswith(".py") else _module_file(module, path)
    learned_from = getattr(module, "learned_from", "")
    terms = getattr(module, "transition_terms", None)
    strength = getattr(module, "transition_strength", 0.0)
    return ProgramSource(spec, label, digest, target, str(base),
                         learned_from if isinstance(learned_from, str) else "",
                         terms, strength if isinstance(strength, (int, float)) else float("nan"))


def _module_file(module: Any, path: Path) -> str:
    """A module's file as the log names it: relative to its import root (``pkg/models.py``), so no
    absolute path enters a log."""
    name = getattr(module, "__name__", "") or path.stem
    return name.replace(".", "/") + ("/__init__.py" if path.name == "__init__.py" else path.suffix or ".py")


def load_program_model(ref: str | Path, load_model: Callable[[str], Any]) -> Any:
    """The model a program reference names: its base model's settings with ``program`` set.

    Args:
        ref: the program's reference.
        load_model: loads the base model by name or path (:func:`fg_tea.model.spec.load_model`).

    Raises:
        InputError: see :func:`load_program_source`; or the base model does not load.
    """
    source = load_program_source(ref)
    if is_program_ref(source.base):
        raise InputError(source.spec, "base", "must name a TOML model, not another program")
    base = load_model(source.base)
    if source.transition_terms is not None:
        from fg_tea.model.learned_transitions import with_transition_terms

        base = with_transition_terms(base, source.transition_terms, source.transition_strength, source.spec)
    name = Path(source.spec).stem if source.spec.endswith(".py") else source.spec
    return replace(base, name=name, description=f"model program {source.spec} (base {base.name})",
                   source=source.spec, program=source)


_BUILT: list[tuple[Any, Any, Any]] = []  # (source, scenario, program), the last few built


def program_for(scenario: Any, model: Any) -> Any:
    """The program of `model` over `scenario`, built under the time limit; None for a TOML model.

    Raises:
        InputError: the function raises, exits, times out or returns no program, or a program
            built on another base model than the module's ``base``.
    """
    source: ProgramSource | None = getattr(model, "program", None)
    if source is None:
        return None
    for s, sc, program in _BUILT:
        if s is source and sc is scenario:
            return program
    from fg_tea.model.program import Program

    try:
        with _time_limit(source.spec, f"building the program for scenario {scenario.name!r}"):
            program = source.function(scenario)
    except InputError as exc:  # a factor's fault: named by the program file, whatever source it was given
        raise InputError(source.spec, exc.path, exc.fault) from None
    except SystemExit as exc:
        raise InputError(source.spec, _FIELD, f"{FUNCTION}(scenario) called exit({exc.code!r})") from None
    except Exception as exc:
        raise InputError(source.spec, _FIELD,
                         f"{FUNCTION}(scenario) raised {type(exc).__name__}: {_first(exc)}") from None
    if not isinstance(program, Program):
        raise InputError(source.spec, _FIELD, f"{FUNCTION}(scenario) returned {type(program).__name__}, "
                         "not a fg.Program (not a model program)")
    if program.model is not None and not _same_settings(program.model, model):
        raise InputError(source.spec, "base", f"the program builds on model {program.model.name!r} but the "
                         f"module's base is {source.base!r}; set base = {program.model.name!r} so planning, "
                         "detection and transitions match")
    if program.learnable_transitions and getattr(model, "transition_form", "full") != "full":
        raise InputError(source.spec, f"learnable_transition {program.learnable_transitions[0]!r}",
                         f"the base model {source.base!r} uses the direct form of transitions; learning "
                         "them (docs/design.md §12.5) needs the full form of eq. 27")
    for name in program.learnable_transitions:
        if name not in model.transitions:
            raise InputError(source.spec, f"learnable_transition {name!r}", "unknown transition (the base "
                             f"model {source.base!r} declares: {', '.join(sorted(model.transitions))})")
    program.source = source.spec
    _BUILT.append((source, scenario, program))
    del _BUILT[:-4]
    return program


def _same_settings(a: Any, b: Any) -> bool:
    """Same settings apart from the names, and apart from transitions learned from episodes (eq. 63):
    each is compared by its declared transitions."""
    blank = {"name": "", "description": "", "source": "", "program": None, "declared_transitions": None}
    a, b = (replace(m, transitions=m.declared_transitions) if getattr(m, "declared_transitions", None) is not None
            else m for m in (a, b))
    try:
        return bool(replace(a, **blank) == replace(b, **blank))
    except (TypeError, ValueError):  # a field that does not compare as a whole (an array): by text
        return repr(replace(a, **blank)) == repr(replace(b, **blank))


__all__ = ["BUILD_SECONDS", "ProgramSource", "SECONDS_VARIABLE", "build_seconds",
           "is_program_ref", "load_program_model", "load_program_source", "program_for"]
