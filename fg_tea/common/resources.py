"""Where do the bundled scenarios, models, tasks and world distributions live, and how does a
name resolve to a file?

A user may pass a path, or just the name of a bundled file (``default_apartment``,
``factorised``, ``no_epistemic``, ``make_tea``, ``correlated``). Bundled data is package data of
:mod:`fg_tea._bundle`, read through :mod:`importlib.resources`, so it is found the same way from
a source checkout, an editable install, a wheel or an install with ``--prefix``, from any
directory. In the repository the files stay in the top-level ``scenarios/``, ``models/`` and
``cameras/`` folders; the build maps them into the package.
"""

from __future__ import annotations

import atexit
import contextlib
import difflib
import importlib.resources
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

from fg_tea.common.errors import InputError

DEFAULT_SCENARIO = "default_apartment"
DEFAULT_MODEL = "factorised"
DEFAULT_TASK = "make_tea"

#: Every bundled kind: its folder (relative to the bundle), file suffix and a description.
KINDS: dict[str, tuple[str, str, str]] = {
    "scenarios": ("scenarios", ".json", "houses with sites, objects and hidden truth"),
    "models": ("models", ".toml", "generative models the agent can assume"),
    "ablations": ("models/ablations", ".toml", "models with one ingredient removed or changed"),
    "tasks": ("scenarios/tasks", ".json", "task graphs, for --task"),
    "worlds": ("scenarios/worlds", ".json", "world distributions, for compare --world"),
    "cameras": ("cameras", ".toml", "what the camera reports, for --camera (docs/design.md §1.3)"),
}

_extracted = contextlib.ExitStack()  # files of a zipped install, extracted once per process
atexit.register(_extracted.close)


def _package(kind: str) -> str:
    parts = [p for p in kind.replace("\\", "/").split("/") if p]
    if (not parts or parts[0] not in ("scenarios", "models", "cameras")
            or not all(p.isidentifier() for p in parts)):
        raise FileNotFoundError(f"no bundled folder {kind!r}")
    return ".".join(["fg_tea._bundle", *parts])


def data_files(kind: str) -> Traversable:
    """The bundled folder of `kind` ('scenarios', 'models', 'scenarios/tasks', ...), as a
    :class:`~importlib.resources.abc.Traversable`.

    Raises:
        FileNotFoundError: `kind` is not a bundled folder.
    """
    try:
        folder = importlib.resources.files(_package(kind))
    except ModuleNotFoundError:
        raise FileNotFoundError(f"bundled folder {kind!r} not found") from None
    if not folder.is_dir():
        raise FileNotFoundError(f"bundled folder {kind!r} not found")
    return folder


def _as_path(item: Traversable) -> Path:
    """A file system path for a bundled file (extracted to a temporary file for zipped installs)."""
    if isinstance(item, Path):
        return item
    return _extracted.enter_context(importlib.resources.as_file(item))


def data_dir(kind: str) -> Path:
    """The bundled folder of `kind` as a path (installs on a file system only)."""
    folder = data_files(kind)
    for item in folder.iterdir():  # a namespace package's folder is the one its files are in
        if isinstance(item, Path):
            return item.parent
    if isinstance(folder, Path):
        return folder
    raise FileNotFoundError(f"bundled folder {kind!r} is not on a file system")


def _exists(path: Path) -> bool:
    try:
        return path.exists()
    except (OSError, ValueError):  # a name too long, or with a NUL byte: no such file
        return False


def _bundled_file(kind: str, name: str, suffix: str) -> Path | None:
    try:
        folder = data_files(kind)
    except FileNotFoundError:
        return None
    for item in folder.iterdir():
        if item.name == f"{name}{suffix}" and item.is_file():
            return _as_path(item)
    return None


def _resolve(name: str | Path, kind: str, suffix: str) -> Path:
    """`name` itself when it is an existing path or looks like one, else the bundled file
    ``<kind>/<name><suffix>`` when there is one, else `name` (so the caller reports it missing)."""
    path = Path(name)
    if _exists(path) or path.suffix or len(path.parts) != 1 or str(name) in ("", ".", ".."):
        return path
    found = _bundled_file(kind, str(name), suffix)
    return found if found is not None else path


def _bare(name: str | Path) -> bool:
    """A name that can only mean a bundled file: one part, no suffix, no such file here."""
    path = Path(name)
    return (not _exists(path) and not path.suffix and len(path.parts) == 1
            and str(name) not in ("", ".", ".."))


def _not_bundled(name: str | Path, what: str, kinds: tuple[str, ...]) -> InputError:
    """One line for a bare name that is no file and no bundled name, with the nearest names."""
    known = [n for k in kinds for n in bundled_names(k)]
    close = difflib.get_close_matches(str(name), known, n=3, cutoff=0.6)
    hint = (f"; did you mean {' or '.join(repr(c) for c in close)}?" if close
            else f" (bundled: {', '.join(known)})")
    return InputError(name, "$", f"no such file, nor a bundled {what} of that name{hint}")


def _resolve_named(name: str | Path, what: str, kinds: tuple[str, ...]) -> Path:
    for kind in kinds:
        folder, suffix, _ = KINDS[kind]
        path = _resolve(name, folder, suffix)
        if _exists(path) or not _bare(name):
            return path
    raise _not_bundled(name, what, kinds)


def resolve_scenario(name: str | Path) -> Path:
    """A scenario path, or the bundled scenario of that name.

    Raises:
        InputError: a bare name that is neither a file nor a bundled scenario ("did you mean").
    """
    return _resolve_named(name, "scenario", ("scenarios",))


#: The entry-point group under which installed packages register model programs (docs/design.md §4.8).
MODEL_ENTRY_POINT_GROUP = "fg_tea.models"


def model_entry_points() -> dict[str, Any]:
    """Model programs registered by installed packages: entry-point name -> entry point."""
    from importlib import metadata

    return {ep.name: ep for ep in metadata.entry_points(group=MODEL_ENTRY_POINT_GROUP)}


def is_program_ref(ref: str | Path) -> bool:
    """True when `ref` names a model program rather than a TOML model: a ``.py`` file,
    ``module:attribute``, or a bare name registered in :data:`MODEL_ENTRY_POINT_GROUP` that is no
    file (a bundled model's name wins over an entry point of the same name)."""
    text = str(ref)
    if text.endswith(".py"):
        return True
    if text.endswith(".toml") or _exists(Path(text)):
        return False
    module, colon, attribute = text.partition(":")
    if colon:
        return all(p.isidentifier() for p in module.split(".") + attribute.split("."))
    if "/" in text or "\\" in text or "." in text or not text:
        return False
    if any(_bundled_file(kind, text, ".toml") for kind in ("models", "models/ablations")):
        return False
    return text in model_entry_points()


def resolve_model(name: str | Path) -> Path:
    """A model path, or the bundled model of that name, or else the bundled ablation of that name; a
    model program's reference (``.py``, ``module:attribute``, entry point) is returned as it is."""
    if is_program_ref(name):
        return Path(name)
    return _resolve_named(name, "model or ablation", ("models", "ablations"))


def resolve_task(name: str | Path) -> Path:
    """A task path, or the bundled task of that name."""
    return _resolve_named(name, "task", ("tasks",))


def resolve_world(name: str | Path) -> Path:
    """A world-distribution path, or the bundled world distribution of that name."""
    return _resolve_named(name, "world distribution", ("worlds",))


def resolve_camera(name: str | Path) -> Path:
    """A camera path, or the bundled camera of that name (``visibility``, ``threshold``, ...)."""
    return _resolve_named(name, "camera", ("cameras",))


def bundled(kind: str, suffix: str) -> list[Path]:
    """All bundled files of a kind (a folder such as ``'models/ablations'``), sorted by name."""
    items = [item for item in data_files(kind).iterdir()
             if item.name.endswith(suffix) and item.is_file()]
    return [_as_path(item) for item in sorted(items, key=lambda item: item.name)]


def bundled_names(what: str) -> list[str]:
    """Names of the bundled files of one of :data:`KINDS` (``'scenarios'``, ``'ablations'``, ...)."""
    folder, suffix, _ = KINDS[what]
    return [p.name[: -len(suffix)] for p in bundled(folder, suffix)]


def describe(path: Path) -> str:
    """A one-line description of a bundled file: its ``description`` field when it has one."""
    import json
    import tomllib

    try:
        if path.suffix == ".toml":
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        else:
            data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return ""
    text = data.get("description", "") if isinstance(data, dict) else ""
    return " ".join(str(text).split()) if isinstance(text, str) else ""
