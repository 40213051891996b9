"""Importing what a user names by ``module:attribute`` (docs/design.md §7.6 and §4.8).

Planner plug-ins (:mod:`fg_tea.planning.plugins`) and model programs
(:mod:`fg_tea.model.program_file`) are both named this way; both import through here, so a name
that does not resolve gives the same one-line fault whatever it names.
"""

from __future__ import annotations

import importlib
import os
import sys
from typing import Any

from fg_tea.common.errors import InputError


class PluginSpecError(InputError):
    """A ``module:attribute`` name that does not import or has no such attribute."""

    def __init__(self, spec: str, fault: str) -> None:
        self.spec = spec
        super().__init__("<command line>", spec, fault)

    def __reduce__(self):
        return (PluginSpecError, (self.spec, self.fault))


def import_module(spec: str, module: str, what: str = "planner", example: str = "mymod:MyPlanner") -> Any:
    """The module `module` of the name `spec`, imported from ``sys.path`` or, failing that, from
    the current directory.

    Args:
        spec: the whole name as given (``mymod:MyPlanner``), for the message.
        module: its module part.
        what: what a module of this kind holds (``planner``, ``model``), for the message.
        example: an example of such a name, for the message.

    Raises:
        PluginSpecError: not a module name, not found, or importing it raised or exited.
    """
    parts = module.split(".")
    if not all(p.isidentifier() for p in parts):
        raise PluginSpecError(spec, f"{spec!r}: {module!r} is not a module name "
                                    f"(expected module:attribute, e.g. {example})")
    cwd = os.getcwd()
    if cwd not in sys.path and "" not in sys.path:  # the current directory, after everything else
        sys.path.append(cwd)
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name is not None and module.startswith(exc.name):
            raise PluginSpecError(spec, f"{spec!r}: no module named {exc.name!r} on sys.path or "
                                        f"in the current directory ({cwd})") from None
        raise PluginSpecError(spec, f"{spec!r}: importing {module!r} failed: {exc}") from None
    except SystemExit as exc:  # the user's module called exit(): it is not a module of plug-ins
        raise PluginSpecError(spec, f"{spec!r}: importing {module!r} called exit"
                                    f"({exc.code!r}); a {what} module must not exit") from None
    except Exception as exc:  # the user's module raised while importing: say so in one line
        first = (str(exc).splitlines() or [""])[0]
        raise PluginSpecError(spec, f"{spec!r}: importing {module!r} raised "
                                    f"{type(exc).__name__}: {first}") from None


def attribute(spec: str, module_obj: Any, name: str) -> Any:
    """The (dotted) attribute `name` of `module_obj`.

    Raises:
        PluginSpecError: not an attribute name, or the module has no such attribute.
    """
    value = module_obj
    for part in name.split("."):
        if not part.isidentifier():
            raise PluginSpecError(spec, f"{spec!r}: {name!r} is not an attribute name")
        try:
            value = getattr(value, part)
        except AttributeError:
            raise PluginSpecError(spec, f"{spec!r}: module {module_obj.__name__!r} has no "
                                        f"attribute {name!r}") from None
    return value
