"""A model file and its ``extends`` chain, read as one document (docs/design.md §5).

A model file may extend another (a bundled model's name, a file beside it, or a path relative to
it); the chain is read child first and merged root first, each child overriding its parent key by
key (a list of tables, such as relations, replaces the parent's). Every key path remembers the file
that set it, so a fault names the file a user must edit.
"""

from __future__ import annotations

from pathlib import Path
from typing import Mapping

from fg_tea.common.errors import InputError
from fg_tea.common.inputs import read_toml

#: Longest ``extends`` chain a model may have.
MAX_EXTENDS_DEPTH = 32


def merge(base: dict, override: dict) -> dict:
    out = dict(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merge(out[key], value)
        else:
            out[key] = value
    return out


#: How a detection updates q(L_o) (docs/design.md §3.2): ``"collapse"`` onto the site seen, with
#: the floor elsewhere (eq. 4); ``"likelihood"``, a plain detection likelihood (eq. 31).

def origin_lookup(origins: Mapping[str, str]):
    def lookup(path: str) -> str | None:
        while path:
            if path in origins:
                return origins[path]
            cut = max(path.rfind("."), path.rfind("["))
            path = path[:cut] if cut > 0 else ""
        return None
    return lookup


def _record(data: dict, file: str, path: str, origins: dict[str, str]) -> None:
    """Note `file` as the origin of every key path in `data` (tables and values)."""
    stack = [(data, path)]
    while stack:
        table, base = stack.pop()
        for key, value in table.items():
            sub = f"{base}.{key}"
            origins[sub] = file
            if isinstance(value, dict):
                stack.append((value, sub))


def extended_file(path: Path, parent: object) -> Path:
    """The file that `extends = parent` in model `path` names, or an :class:`InputError`."""
    from fg_tea.common.resources import resolve_model

    if not isinstance(parent, str):
        raise InputError(path, "$.extends", "expected the name or path of another model")
    if not parent.strip() or parent.strip() in (".", "..") or parent.endswith(("/", "\\")) \
            or "\0" in parent:
        raise InputError(path, "$.extends", f"{parent!r} does not name a model file")
    if len(parent) > 255:
        raise InputError(path, "$.extends", f"a model name of {len(parent)} characters is too long")
    hint = ""
    try:
        candidate = path.parent / f"{parent}.toml"
        named = Path(parent)
        if candidate.is_file():  # a model beside this one wins over a bundled model
            parent_path = candidate
        elif named.suffix or len(named.parts) > 1:  # a path: relative to the extending file
            parent_path = named if named.is_absolute() else path.parent / named
        else:
            try:
                parent_path = Path(resolve_model(parent))
            except InputError as exc:
                parent_path, hint = named, exc.fault.partition(";")[2].rstrip("?")
                hint = f" ({hint.strip()}?)" if hint else ""
        exists = parent_path.exists()
    except OSError as exc:
        raise InputError(path, "$.extends", f"model {parent!r} cannot be read: {exc.strerror}") from None
    if not exists:
        raise InputError(path, "$.extends", f"model {parent!r} is referenced but not found{hint}")
    if not parent_path.is_file():
        raise InputError(path, "$.extends", f"{parent!r} is not a model file")
    return parent_path


def load_document(path: Path, seen: tuple[Path, ...],
                   origins: dict[str, str] | None = None) -> dict:
    """The merged document of `path` and its ``extends`` chain (walked without recursion)."""
    chain: list[tuple[Path, dict]] = []
    current = path
    while True:
        data = read_toml(current)
        parent = data.pop("extends", None)
        chain.append((current, data))
        if parent is None:
            break
        if len(chain) > MAX_EXTENDS_DEPTH:
            raise InputError(current, "$.extends", f"the extends chain is longer than "
                             f"{MAX_EXTENDS_DEPTH} models")
        parent_path = extended_file(current, parent)
        if parent_path.resolve() in seen:
            raise InputError(current, "$.extends",
                             f"models extend each other in a cycle through {parent!r}")
        seen = seen + (parent_path.resolve(),)
        current = parent_path
    merged: dict = {}
    for file, data in reversed(chain):  # the root model first; each child overrides
        if origins is not None:
            _record(data, str(file), "$", origins)
        # Lists of tables (relations) replace rather than merge.
        merged = merge(merged, data)
    return merged
