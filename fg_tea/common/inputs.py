"""Errors that fg_tea raises for bad input and for incoherent beliefs.

`InputError` is the single error type for every scenario, model and task file fault: it names the
file, the path inside it (JSON path or TOML key path) and what is wrong, so the CLI can print it as
one line and exit with status 2.
"""

from __future__ import annotations

import difflib
import json
import math
import stat
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Literal, overload

from fg_tea.common.errors import InputError

_TYPE_NAMES = {str: "a string", int: "an integer", float: "a number", bool: "true or false",
               list: "a list", dict: "an object", tuple: "a list"}

#: Largest magnitude of any number in an input file. No quantity of the model or the house comes
#: near it (the largest are pixel counts, ~1e6); it keeps 1e308 and its overflows out.
MAX_MAGNITUDE = 1e9
#: Largest magnitude of a coordinate (m): a house 20 km across is a typo, not a house.
MAX_COORDINATE = 1e4
#: Largest input file read (bytes): the bundled files are a few kB.
MAX_FILE_BYTES = 16 * 1024 * 1024
#: Deepest nesting of lists/objects accepted (the bundled files nest 6 deep).
MAX_DEPTH = 64


def _suggest(key: str, known: Iterable[str]) -> str:
    close = difflib.get_close_matches(key, sorted(known), n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def path_segments(path: str) -> tuple[str, ...]:
    """``$.a.b[2].c`` as ``("a", "b", "[]", "c")`` (list indices become ``"[]"``)."""
    import re

    return tuple("[]" if part.startswith("[") else part for part in re.findall(r"\[\d+\]|[^.\[\]$]+", path))


class _Recording:
    """Where a schema recorder listens while bundled files are read (fg_tea.common.schemas)."""

    recorder: Any = None


RECORDING = _Recording()


class _Document:
    """What all Readers of one document share: which keys were read, and where each came from."""

    def __init__(self, origins: Callable[[str], str] | None) -> None:
        self.origins = origins
        self.read: dict[int, set[str]] = {}
        self.readers: list[Reader] = []


class Reader:
    """Walks a parsed JSON/TOML document, remembering the path, so every fault names where it is.

    Every key a parser reads (``req``, ``opt``, ``child``, ``items``, ``mapping``, ``names`` ...)
    is recorded; :meth:`finish` then rejects every key of every object the parser entered that it
    never read, with a "did you mean" suggestion. So a misspelt key is an error, and keys added
    later by other parsers are accepted as soon as they are read.

    Args:
        data: the parsed value at this path.
        file: the file it came from (for messages).
        path: the JSON-path-like location of `data`, e.g. ``$.sites[2]``.
        origins: maps a path to the file that holds it, for documents merged from several files
            (a model's ``extends`` chain); by default everything is in `file`.
    """

    def __init__(self, data: Any, file: str | Path, path: str = "$",
                 origins: Callable[[str], str] | None = None, _doc: _Document | None = None,
                 _segments: tuple[str, ...] | None = None) -> None:
        self.data = data
        self._file = str(file)
        self.path = path
        self._doc = _doc or _Document(origins)
        self._doc.readers.append(self)
        #: The path as keys, ``"[]"`` for a list item: a key of a free-form table may hold a dot.
        self.segments = _segments if _segments is not None else path_segments(path)
        if RECORDING.recorder is not None:
            RECORDING.recorder.entered(self)

    @property
    def file(self) -> str:
        """The file holding this value (the parent model's file for an inherited table)."""
        return self.file_of(self.path)

    def file_of(self, path: str) -> str:
        if self._doc.origins is not None:
            return self._doc.origins(path) or self._file
        return self._file

    def fail(self, fault: str, key: str | int | None = None) -> InputError:
        path = self._sub(key) if key is not None else self.path
        return InputError(self.file_of(path), path, fault)

    def _sub(self, key: str | int) -> str:
        return f"{self.path}[{key}]" if isinstance(key, int) else f"{self.path}.{key}"

    def _mark(self, key: str) -> None:
        if isinstance(self.data, dict):
            self._doc.read.setdefault(id(self.data), set()).add(key)

    def _new(self, data: Any, path: str, segment: str) -> "Reader":
        return Reader(data, self._file, path, _doc=self._doc, _segments=(*self.segments, segment))

    def _note(self, key: str, how: str, kind: type | tuple = (), **detail: Any) -> None:
        """Tell a schema recorder, if one listens, what was read here (docs/design.md §1.3)."""
        if RECORDING.recorder is not None:
            RECORDING.recorder.read(self, key, how, kind if isinstance(kind, tuple) else (kind,), detail)

    def _check_type(self, value: Any, kind: type | tuple, where: str | int) -> Any:
        kinds = kind if isinstance(kind, tuple) else (kind,)
        ok = any(
            (isinstance(value, k) and not (k in (int, float) and isinstance(value, bool)))
            or (k is float and isinstance(value, int) and not isinstance(value, bool))
            for k in kinds
        )
        if not ok:
            want = " or ".join(_TYPE_NAMES.get(k, k.__name__) for k in kinds)
            raise self.fail(f"expected {want}, got {type(value).__name__} {_short(value)}", where)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if not math.isfinite(value):
                raise self.fail(f"expected a finite number, got {value}", where)
            if abs(value) > MAX_MAGNITUDE:
                raise self.fail(f"{_short(value)} is out of range (magnitude at most {MAX_MAGNITUDE:g})",
                                where)
        return float(value) if kinds == (float,) else value

    def has(self, key: str) -> bool:
        return isinstance(self.data, dict) and key in self.data

    def missing(self, key: str) -> InputError:
        """The fault of a required `key` that is absent: a key of this object close to it that no
        parser has read is named as the typo (``$.beliefs.strcture: unknown field; did you mean
        'structure'?``); otherwise the key is missing."""
        if isinstance(self.data, dict):
            read = self._doc.read.get(id(self.data), set())
            unread = [k for k in self.data if isinstance(k, str) and k not in read]
            close = difflib.get_close_matches(key, unread, n=1, cutoff=0.8)
            if close:
                return self.fail(f"unknown field; did you mean {key!r}?", close[0])
        return self.fail("missing required field", key)

    def req(self, key: str, kind: type | tuple) -> Any:
        if not isinstance(self.data, dict):
            raise self.fail("expected an object")
        self._note(key, "required", kind)
        if key not in self.data:
            raise self.missing(key)
        self._mark(key)
        return self._check_type(self.data[key], kind, key)

    def opt(self, key: str, kind: type | tuple, default: Any) -> Any:
        self._note(key, "optional", kind)
        self._mark(key)
        if not isinstance(self.data, dict) or key not in self.data or self.data[key] is None:
            return default
        return self._check_type(self.data[key], kind, key)

    @overload
    def child(self, key: str, required: Literal[True] = ...) -> "Reader": ...

    @overload
    def child(self, key: str, required: bool) -> "Reader | None": ...

    def child(self, key: str, required: bool = True) -> "Reader | None":
        self._note(key, "required" if required else "optional", dict)
        self._mark(key)
        if not self.has(key):
            if required:
                raise self.missing(key)
            return None
        self._check_type(self.data[key], dict, key)
        return self._new(self.data[key], self._sub(key), key)

    def items(self, key: str, required: bool = True) -> Iterator["Reader"]:
        self._note(key, "required" if required else "optional", list)
        self._mark(key)
        if not self.has(key):
            if required:
                raise self.missing(key)
            return iter(())
        values = self._check_type(self.data[key], list, key)
        base = self._sub(key)
        item = self._new(values, base, key)  # the list itself, so a recorder sees it entered
        return (item._new(v, f"{base}[{i}]", "[]") for i, v in enumerate(values))

    def names(self) -> list[str]:
        """The keys of a free-form table (site names, sensor names, ...), all counted as read."""
        if not isinstance(self.data, dict):
            raise self.fail("expected an object")
        if RECORDING.recorder is not None:
            RECORDING.recorder.free_form(self)
        for key in self.data:
            self._mark(key)
        return list(self.data)

    def mapping(self, key: str, kind: type | tuple, required: bool = False) -> dict[str, Any]:
        """A dict of name -> value of `kind` (e.g. affordance weights)."""
        sub = self.child(key, required=required)
        if sub is None:
            return {}
        sub._note("{}", "optional", kind)
        return {name: sub._check_type(sub.data[name], kind, name) for name in sub.names()}

    @overload
    def vector(self, key: str, length: Literal[2], required: bool = ..., default: Any = ...,
               limit: float = ...) -> tuple[float, float]: ...

    @overload
    def vector(self, key: str, length: Literal[3], required: bool = ..., default: Any = ...,
               limit: float = ...) -> tuple[float, float, float]: ...

    @overload
    def vector(self, key: str, length: Literal[4], required: bool = ..., default: Any = ...,
               limit: float = ...) -> tuple[float, float, float, float]: ...

    @overload
    def vector(self, key: str, length: int, required: bool = ..., default: Any = ...,
               limit: float = ...) -> tuple[float, ...]: ...

    def vector(self, key: str, length: int, required: bool = True, default: Any = None,
               limit: float = MAX_COORDINATE) -> tuple[float, ...]:
        """A list of `length` finite numbers, each of magnitude at most `limit` (metres)."""
        self._note(key, "required" if required else "optional", list, numbers=length, limit=limit)
        self._mark(key)
        if not self.has(key):
            if required:
                raise self.missing(key)
            return default
        values = self._check_type(self.data[key], list, key)
        if len(values) != length:
            raise self.fail(f"expected {length} numbers, got {len(values)}", key)
        sub = Reader(values, self._file, self._sub(key), _doc=self._doc)
        out = tuple(float(sub._check_type(v, float, i)) for i, v in enumerate(values))
        for i, v in enumerate(out):
            if abs(v) > limit:
                raise sub.fail(f"{v:g} is out of range (magnitude at most {limit:g})", i)
        return out

    def probability(self, key: str, default: float | None = None) -> float:
        self._note(key, "optional" if default is not None else "required", float, minimum=0.0, maximum=1.0)
        value = self.req(key, float) if default is None else self.opt(key, float, default)
        value = float(value)
        if not 0.0 <= value <= 1.0:
            raise self.fail(f"probability {value} is outside [0, 1]", key)
        return value

    def positive(self, key: str, default: float | None = None, allow_zero: bool = False) -> float:
        bound = {"minimum": 0.0} if allow_zero else {"exclusiveMinimum": 0.0}
        self._note(key, "optional" if default is not None else "required", float, **bound)
        value = float(self.req(key, float) if default is None else self.opt(key, float, default))
        if value < 0 or (value == 0 and not allow_zero):
            raise self.fail(f"must be {'non-negative' if allow_zero else 'positive'}, got {value}", key)
        return value

    def choice(self, key: str, options: tuple[str, ...], default: str | None = None) -> str:
        self._note(key, "optional" if default is not None else "required", str, enum=tuple(options))
        value = self.req(key, str) if default is None else self.opt(key, str, default)
        if value not in options:
            raise self.fail(f"must be one of {', '.join(options)}; got {value!r}", key)
        return value

    def done(self) -> None:
        """Reject any key of this object that no parser read (a misspelling, or an unknown key)."""
        if not isinstance(self.data, dict):
            return
        read = self._doc.read.get(id(self.data), set())
        for key in self.data:
            if key not in read:
                known = read | set()
                raise self.fail(f"unknown field{_suggest(str(key), known)}", str(key))

    def finish(self) -> None:
        """:meth:`done` for every object of the document that a parser entered, in reading order."""
        seen: set[int] = set()
        for reader in list(self._doc.readers):
            if isinstance(reader.data, dict) and id(reader.data) not in seen:
                seen.add(id(reader.data))
                reader.done()


def _short(value: Any) -> str:
    text = repr(value) if not isinstance(value, int) or abs(value) < 10 ** 40 else "a huge integer"
    return text if len(text) <= 40 else text[:37] + "..."


class _Duplicates(dict):
    """A JSON object some of whose keys were given twice (`repeated`); refused by _walk_check,
    which knows its path."""

    repeated: list[str]


def _object_pairs(pairs: list[tuple[str, Any]]) -> dict:
    """The ``object_pairs_hook`` of :func:`read_json`: a dict, marked when a key repeats (JSON
    itself keeps the last value silently, so a doubled key would hide its first value)."""
    out = dict(pairs)
    if len(out) == len(pairs):
        return out
    marked = _Duplicates(out)
    seen: set[str] = set()
    marked.repeated = []
    for key, _ in pairs:
        if key in seen:
            marked.repeated.append(key)
        seen.add(key)
    return marked


def _walk_check(data: Any, file: str | Path) -> None:
    """Reject what no parser should see: deep nesting, NaN/inf, lone surrogates (not UTF-8),
    a key given twice in one JSON object."""
    stack = [(data, "$", 0)]
    while stack:
        value, path, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise InputError(file, path, f"nested more than {MAX_DEPTH} levels deep")
        if isinstance(value, _Duplicates):
            key = value.repeated[0]
            _check_text(key, file, path)
            raise InputError(file, f"{path}.{key}", f"duplicate key {key!r} in one object (only "
                             "one value can hold; JSON would keep the last silently)")
        if isinstance(value, dict):
            for key, v in value.items():
                _check_text(key, file, path)
                stack.append((v, f"{path}.{key}", depth + 1))
        elif isinstance(value, list):
            stack.extend((v, f"{path}[{i}]", depth + 1) for i, v in enumerate(value))
        elif isinstance(value, str):
            _check_text(value, file, path)
        elif isinstance(value, float) and not math.isfinite(value):
            raise InputError(file, path, f"expected a finite number, got {value}")


def refuse_null(data: Any, file: str | Path, what: str) -> None:
    """Refuse any JSON ``null`` in `data`: in a task or world file no field takes null, and a
    reader would otherwise take it for the field left out (its default), silently."""
    stack = [(data, "$")]
    while stack:
        value, path = stack.pop()
        if value is None:
            raise InputError(file, path, f"null is not a value of any field of a {what} file; leave "
                             "the field out for its default")
        if isinstance(value, dict):
            stack.extend((v, f"{path}.{k}") for k, v in reversed(list(value.items())))
        elif isinstance(value, list):
            stack.extend((v, f"{path}[{i}]") for i, v in reversed(list(enumerate(value))))


def _check_text(text: str, file: str | Path, path: str) -> None:
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        raise InputError(file, path, "text is not valid Unicode (a lone surrogate escape)") from None


def read_text(path: str | Path, max_bytes: int = MAX_FILE_BYTES) -> str:
    """The UTF-8 text of a regular input file; every way of not being one is an :class:`InputError`.

    Directories, FIFOs, devices, symlink loops, unreadable, oversized and non-UTF-8 files are
    refused with one line (a FIFO is never opened, so it cannot hang the reader).
    """
    path = Path(path)
    try:
        info = path.stat()
    except FileNotFoundError:
        raise InputError(path, "$", "file not found") from None
    except OSError as exc:
        raise InputError(_printable(path), "$", f"cannot read: {exc.strerror or exc}") from None
    if stat.S_ISDIR(info.st_mode):
        raise InputError(path, "$", "is a directory, not a file")
    if not stat.S_ISREG(info.st_mode):
        raise InputError(path, "$", "is not a regular file (a FIFO, socket or device)")
    if info.st_size > max_bytes:
        raise InputError(path, "$", f"file of {info.st_size:,} bytes is larger than the "
                         f"{max_bytes:,} bytes accepted")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(path, "$", f"cannot read: {exc.strerror or exc}") from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise InputError(path, f"line {line}", f"not UTF-8 text (byte {exc.start})") from None


def _printable(path: str | Path) -> str:
    text = str(path)
    return text if len(text) <= 200 else text[:100] + "..." + text[-60:]


def read_json(path: str | Path) -> Any:
    """Parse a JSON input file; any way it cannot be read or parsed is an :class:`InputError`."""
    text = read_text(path)
    try:
        data = json.loads(text, object_pairs_hook=_object_pairs)
    except json.JSONDecodeError as exc:
        raise InputError(path, f"line {exc.lineno} column {exc.colno}", f"invalid JSON: {exc.msg}") from None
    except RecursionError:
        raise InputError(path, "$", "invalid JSON: nested too deeply") from None
    except ValueError as exc:  # e.g. an integer of more digits than Python converts
        raise InputError(path, "$", f"invalid JSON: {str(exc).split(';')[0]}") from None
    _walk_check(data, path)
    return data


def read_toml(path: str | Path) -> dict:
    """Parse a TOML input file; any way it cannot be read or parsed is an :class:`InputError`."""
    import tomllib

    text = read_text(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(path, "$", f"invalid TOML: {exc}") from None
    except RecursionError:
        raise InputError(path, "$", "invalid TOML: nested too deeply") from None
    except ValueError as exc:
        raise InputError(path, "$", f"invalid TOML: {str(exc).split(';')[0]}") from None
    _walk_check(data, path)
    return data
