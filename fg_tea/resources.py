"""Where the bundled scenarios, models and tasks live, and how a name resolves to a file.

A user may pass a path, or just the name of a bundled file (``default_apartment``,
``factorised``, ``make_tea``). Bundled data sits at the repository root (``scenarios/``,
``models/``) and is installed under ``<prefix>/share/fg_tea`` for non-editable installs.
"""

from __future__ import annotations

import sys
from pathlib import Path

DEFAULT_SCENARIO = "default_apartment"
DEFAULT_MODEL = "factorised"
DEFAULT_TASK = "make_tea"


def _roots() -> list[Path]:
    here = Path(__file__).resolve().parent.parent
    return [here, Path(sys.prefix) / "share" / "fg_tea"]


def data_dir(kind: str) -> Path:
    """The bundled folder of `kind` ('scenarios', 'models', 'scenarios/tasks', ...)."""
    for root in _roots():
        if (root / kind).is_dir():
            return root / kind
    raise FileNotFoundError(f"bundled folder {kind!r} not found under {', '.join(map(str, _roots()))}")


def _exists(path: Path) -> bool:
    try:
        return path.exists()
    except (OSError, ValueError):  # a name too long, or with a NUL byte: no such file
        return False


def _resolve(name: str | Path, kind: str, suffix: str) -> Path:
    path = Path(name)
    if _exists(path) or path.suffix or len(path.parts) != 1 or str(name) in ("", ".", ".."):
        return path
    try:
        candidate = data_dir(kind) / f"{name}{suffix}"
    except FileNotFoundError:
        return path
    return candidate if _exists(candidate) else path


def resolve_scenario(name: str | Path) -> Path:
    return _resolve(name, "scenarios", ".json")


def resolve_model(name: str | Path) -> Path:
    return _resolve(name, "models", ".toml")


def resolve_task(name: str | Path) -> Path:
    return _resolve(name, "scenarios/tasks", ".json")


def bundled(kind: str, suffix: str) -> list[Path]:
    """All bundled files of a kind, sorted by name."""
    return sorted(data_dir(kind).glob(f"*{suffix}"))
