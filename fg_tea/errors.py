"""Errors that fg_tea raises for bad input and for incoherent beliefs.

`InputError` is the single error type for every scenario, model and task file fault: it names the
file, the path inside it (JSON path or TOML key path) and what is wrong, so the CLI can print it as
one line and exit with status 2.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Iterator


class InputError(ValueError):
    """A fault in an input file: `file: path: fault`."""

    def __init__(self, file: str | Path, path: str, fault: str) -> None:
        self.file = str(file)
        self.path = path
        self.fault = fault
        super().__init__(f"{self.file}: {path}: {fault}")


class ContradictionError(ValueError):
    """Evidence that has probability zero under the model (the posterior would be undefined)."""


_TYPE_NAMES = {str: "a string", int: "an integer", float: "a number", bool: "true or false",
               list: "a list", dict: "an object", tuple: "a list"}


class Reader:
    """Walks a parsed JSON/TOML document, remembering the path, so every fault names where it is.

    Args:
        data: the parsed value at this path.
        file: the file it came from (for messages).
        path: the JSON-path-like location of `data`, e.g. ``$.sites[2]``.
    """

    def __init__(self, data: Any, file: str | Path, path: str = "$") -> None:
        self.data = data
        self.file = str(file)
        self.path = path

    def fail(self, fault: str, key: str | int | None = None) -> InputError:
        return InputError(self.file, self._sub(key) if key is not None else self.path, fault)

    def _sub(self, key: str | int) -> str:
        return f"{self.path}[{key}]" if isinstance(key, int) else f"{self.path}.{key}"

    def _check_type(self, value: Any, kind: type | tuple, where: str | int) -> Any:
        kinds = kind if isinstance(kind, tuple) else (kind,)
        ok = any(
            (isinstance(value, k) and not (k in (int, float) and isinstance(value, bool)))
            or (k is float and isinstance(value, int) and not isinstance(value, bool))
            for k in kinds
        )
        if not ok:
            want = " or ".join(_TYPE_NAMES.get(k, k.__name__) for k in kinds)
            raise self.fail(f"expected {want}, got {type(value).__name__} {value!r:.40}", where)
        return float(value) if kinds == (float,) else value

    def has(self, key: str) -> bool:
        return isinstance(self.data, dict) and key in self.data

    def req(self, key: str, kind: type | tuple) -> Any:
        if not isinstance(self.data, dict):
            raise self.fail("expected an object")
        if key not in self.data:
            raise self.fail("missing required field", key)
        return self._check_type(self.data[key], kind, key)

    def opt(self, key: str, kind: type | tuple, default: Any) -> Any:
        if not isinstance(self.data, dict) or key not in self.data or self.data[key] is None:
            return default
        return self._check_type(self.data[key], kind, key)

    def child(self, key: str, required: bool = True) -> "Reader | None":
        if not self.has(key):
            if required:
                raise self.fail("missing required field", key)
            return None
        self._check_type(self.data[key], dict, key)
        return Reader(self.data[key], self.file, self._sub(key))

    def items(self, key: str, required: bool = True) -> Iterator["Reader"]:
        if not self.has(key):
            if required:
                raise self.fail("missing required field", key)
            return iter(())
        values = self._check_type(self.data[key], list, key)
        base = self._sub(key)
        return (Reader(v, self.file, f"{base}[{i}]") for i, v in enumerate(values))

    def mapping(self, key: str, kind: type | tuple, required: bool = False) -> dict[str, Any]:
        """A dict of name -> value of `kind` (e.g. affordance weights)."""
        sub = self.child(key, required=required)
        if sub is None:
            return {}
        return {name: sub._check_type(v, kind, name) for name, v in sub.data.items()}

    def vector(self, key: str, length: int, required: bool = True, default: Any = None) -> tuple[float, ...]:
        if not self.has(key):
            if required:
                raise self.fail("missing required field", key)
            return default
        values = self._check_type(self.data[key], list, key)
        if len(values) != length:
            raise self.fail(f"expected {length} numbers, got {len(values)}", key)
        sub = Reader(values, self.file, self._sub(key))
        return tuple(float(sub._check_type(v, float, i)) for i, v in enumerate(values))

    def probability(self, key: str, default: float | None = None) -> float:
        value = self.req(key, float) if default is None else self.opt(key, float, default)
        value = float(value)
        if not 0.0 <= value <= 1.0:
            raise self.fail(f"probability {value} is outside [0, 1]", key)
        return value

    def positive(self, key: str, default: float | None = None, allow_zero: bool = False) -> float:
        value = float(self.req(key, float) if default is None else self.opt(key, float, default))
        if value < 0 or (value == 0 and not allow_zero):
            raise self.fail(f"must be {'non-negative' if allow_zero else 'positive'}, got {value}", key)
        return value

    def choice(self, key: str, options: tuple[str, ...], default: str | None = None) -> str:
        value = self.req(key, str) if default is None else self.opt(key, str, default)
        if value not in options:
            raise self.fail(f"must be one of {', '.join(options)}; got {value!r}", key)
        return value


def read_json(path: str | Path) -> Any:
    """Parse a JSON input file; a missing file or a syntax error is an :class:`InputError`."""
    try:
        return json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise InputError(path, "$", "file not found") from None
    except json.JSONDecodeError as exc:
        raise InputError(path, f"line {exc.lineno} column {exc.colno}", f"invalid JSON: {exc.msg}") from None
