"""JSON Schemas for the input files, recorded from the validator as it reads (docs/design.md §1.3).

The validator is code: each parser asks a :class:`~fg_tea.common.inputs.Reader` for the keys it
needs (``req``, ``opt``, ``child``, ``items``, ``probability``, ``choice`` ...), and the reader
refuses any key no parser asked for. So the declarations a schema needs are the reader's calls.
:class:`SchemaRecorder` listens to them while the bundled files of one kind are parsed and
builds a JSON Schema (draft 2020-12) from what it heard:

- a key is a property of the object it was read from, with the types the parser accepted, and
  the bounds and choices the reader checks (a probability is in [0, 1], a choice is an enum);
- a key is required where the parser required it of every object of that place it entered;
- an object allows no other keys (the validator refuses them), except a free-form table (site
  names, state names ...), whose values have one schema.

A key the bundled files never lead a parser to is missing from the schema, so
``docs/tools/make_schemas.py`` reads every bundled file and the examples beside them, and
``tests/test_schemas.py`` checks that every bundled file validates and that a misspelt key fails
in the schema as it does in the validator. The validator's one-line messages stay the authority;
the schemas are for editors.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from fg_tea.common.inputs import RECORDING, Reader

#: JSON types of the Python types a parser asks for.
JSON_TYPES = {dict: "object", list: "array", tuple: "array", str: "string", int: "integer",
              float: "number", bool: "boolean"}
DIALECT = "https://json-schema.org/draft/2020-12/schema"

Segments = tuple[str, ...]


class SchemaRecorder:
    """Hears what the parsers read from one file at a time (:meth:`file`), over many files."""

    def __init__(self) -> None:
        self.target: str | None = None
        self.file_no = 0
        self.instances: dict[Segments, set[tuple[int, int]]] = {}
        self.maps: set[Segments] = set()
        self.keys: dict[Segments, dict[str, dict[str, Any]]] = {}

    @contextmanager
    def file(self, path: str | Path) -> Iterator[None]:
        """Listen while `path` is parsed; readers of other files (a base scenario) are ignored."""
        saved, RECORDING.recorder = RECORDING.recorder, self
        self.target, self.file_no = str(path), self.file_no + 1
        try:
            yield
        finally:
            RECORDING.recorder, self.target = saved, None

    def _mine(self, reader: Reader) -> bool:
        return self.target is not None and reader.file_of(reader.path) == self.target

    def entered(self, reader: Reader) -> None:
        if self._mine(reader) and isinstance(reader.data, dict):
            self.instances.setdefault(reader.segments, set()).add((self.file_no, id(reader.data)))

    def free_form(self, reader: Reader) -> None:
        if self._mine(reader):
            self.maps.add(reader.segments)

    def read(self, reader: Reader, key: str, how: str, kinds: tuple, detail: dict[str, Any]) -> None:
        if not self._mine(reader):
            return
        entry = self.keys.setdefault(reader.segments, {}).setdefault(
            key, {"kinds": set(), "required_in": set(), "detail": {}})
        entry["kinds"].update(kinds)
        if how == "required" and isinstance(reader.data, dict):
            entry["required_in"].add((self.file_no, id(reader.data)))
        entry["detail"].update(detail)

    # ------------------------------------------------------------------------------ building
    def schema(self, title: str, description: str) -> dict[str, Any]:
        """The JSON Schema of what was heard, with `title` and `description`."""
        built = _Builder(self)
        body = built.object_at(())
        return {"$schema": DIALECT, "title": title, "description": description, **body}


class _Builder:
    """Merges what was heard by place, a free-form table's entries into one place."""

    def __init__(self, recorder: SchemaRecorder) -> None:
        self.maps: set[Segments] = set()
        for _ in range(8):  # a table under a table: normalise until nothing moves
            self.maps = {self.place(m) for m in recorder.maps}
        self.instances: dict[Segments, set] = {}
        for segs, found in recorder.instances.items():
            self.instances.setdefault(self.place(segs), set()).update(found)
        self.keys: dict[Segments, dict[str, dict[str, Any]]] = {}
        for segs, keys in recorder.keys.items():
            merged = self.keys.setdefault(self.place(segs), {})
            for key, entry in keys.items():
                into = merged.setdefault(key, {"kinds": set(), "required_in": set(), "detail": {}})
                into["kinds"] |= entry["kinds"]
                into["required_in"] |= entry["required_in"]
                into["detail"].update(entry["detail"])

    def place(self, segments: Segments) -> Segments:
        out: list[str] = []
        for seg in segments:
            out.append("{}" if tuple(out) in self.maps and seg != "[]" else seg)
        return tuple(out)

    def known(self, place: Segments) -> bool:
        return place in self.instances or place in self.keys or place in self.maps

    def object_at(self, place: Segments) -> dict[str, Any]:
        keys = {k: v for k, v in self.keys.get(place, {}).items() if k != "{}"}
        out: dict[str, Any] = {"type": "object"}
        if keys:
            out["properties"] = {k: self.value(place + (k,), v) for k, v in sorted(keys.items())}
        entered = self.instances.get(place, set())
        required = sorted(k for k, v in keys.items() if entered and entered <= v["required_in"])
        if required:
            out["required"] = required
        if place in self.maps:
            entry = self.keys.get(place, {}).get("{}")
            inner = place + ("{}",)
            out["additionalProperties"] = (self.value(inner, entry) if entry is not None
                                           else self.object_at(inner) if self.known(inner) else True)
        else:
            out["additionalProperties"] = False
        return out

    def value(self, place: Segments, entry: dict[str, Any]) -> dict[str, Any]:
        detail = entry["detail"]
        types = sorted({JSON_TYPES[k] for k in entry["kinds"] if k in JSON_TYPES})
        if "integer" in types and "number" in types:
            types.remove("integer")
        if "numbers" in detail:
            n = detail["numbers"]
            return {"type": "array", "items": {"type": "number", "minimum": -detail["limit"],
                                               "maximum": detail["limit"]}, "minItems": n, "maxItems": n}
        out: dict[str, Any] = {}
        if types:
            out["type"] = types[0] if len(types) == 1 else types
        for bound in ("minimum", "maximum", "exclusiveMinimum"):
            if bound in detail:
                out[bound] = detail[bound]
        if "enum" in detail:
            out["enum"] = list(detail["enum"])
        if "object" in types and (self.known(place) or place in self.maps):
            out.update({k: v for k, v in self.object_at(place).items() if k != "type"})
        if "array" in types:
            item = place + ("[]",)
            if item in self.instances or item in self.keys:
                out["items"] = self.object_at(item)
        return out


__all__ = ["SchemaRecorder", "JSON_TYPES", "DIALECT"]
