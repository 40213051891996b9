"""Golden comparisons that keep behaviour strict and forgive last-bit noise.

A golden file records what a command produced: JSON events, or the rows of a CSV. Another machine,
CPU or numpy/scipy/opencv release may change the last bits of a float (a sum taken in another
order, another BLAS kernel), never a decision. So a comparison here is strict on everything that
is behaviour (strings, integers, booleans, keys, list lengths, the order of events, which rows
exist) and compares floats to 9 significant digits: ``|a - b| <= 1e-9 * max(|a|, |b|)``, with an
absolute floor of 1e-12 for values near 0 (a probability that is 0 here and 1e-17 there). Every
difference is reported with where it is (the file, the event's index and kind or the row's key,
the JSON path or the column) and both values, so a failure says which field moved.

Used by tests/test_golden_logs.py; usable for any future golden file (docs: tests/golden/README.md).
"""

from __future__ import annotations

import csv
import io
import json
import lzma
import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

REL = 1e-9   #: relative tolerance on floats: 9 significant digits
ABS = 1e-12  #: absolute floor, for values near 0 (far below any logged quantity's resolution)
SHOWN = 8    #: differences listed in a failure message (the first ones, in order)
_INTEGER = re.compile(r"[+-]?\d+")


def floats_match(expected: float, actual: float, rel: float = REL, abs_floor: float = ABS) -> bool:
    """Whether two floats agree to `rel` (relative) or `abs_floor` (absolute); NaN matches NaN."""
    if math.isnan(expected) or math.isnan(actual):
        return math.isnan(expected) and math.isnan(actual)
    return math.isclose(expected, actual, rel_tol=rel, abs_tol=abs_floor)


def differences(expected: Any, actual: Any, path: str = "$") -> Iterator[str]:
    """Each place where `actual` departs from `expected` (JSON values), as ``PATH: what``.

    Floats compare to 9 significant digits; anything else must be equal, type included (an
    integer that became a float, or a boolean that became a number, is a change).
    """
    if isinstance(expected, float) and isinstance(actual, float):
        if not floats_match(expected, actual):
            yield f"{path}: expected {expected!r}, got {actual!r}"
    elif type(expected) is not type(actual):
        yield (f"{path}: expected {type(expected).__name__} {_short(expected)}, "
               f"got {type(actual).__name__} {_short(actual)}")
    elif isinstance(expected, dict):
        missing, extra = sorted(set(expected) - set(actual)), sorted(set(actual) - set(expected))
        if missing or extra:
            yield f"{path}: keys missing {missing}, keys added {extra}"
        for key in expected:
            if key in actual:
                yield from differences(expected[key], actual[key], f"{path}.{key}")
    elif isinstance(expected, list):
        if len(expected) != len(actual):
            yield f"{path}: expected {len(expected)} items, got {len(actual)}"
        for i, (e, a) in enumerate(zip(expected, actual)):
            yield from differences(e, a, f"{path}[{i}]")
    elif expected != actual:
        yield f"{path}: expected {_short(expected)}, got {_short(actual)}"


def event_differences(expected: list[dict], actual: list[dict]) -> list[str]:
    """Differences between two event logs, each naming the event's index and kind."""
    out = []
    if len(expected) != len(actual):
        out.append(f"the log has {len(actual)} events, the golden one {len(expected)}")
    for i, (e, a) in enumerate(zip(expected, actual)):
        kind = e.get("event", "?") if isinstance(e, dict) else "?"
        out += [f"event {i} ({kind}): {d}" for d in differences(e, a)]
    return out


def cell_differences(expected: str, actual: str) -> Iterator[str]:
    """A CSV cell: equal text, or numbers within 9 significant digits (``;``-joined lists too).

    Integers compare as text (a count is exact), as does anything that is not a number.
    """
    if expected == actual:
        return
    parts_e, parts_a = expected.split(";"), actual.split(";")
    if len(parts_e) == len(parts_a) and all(_is_float(p) for p in parts_e + parts_a):
        for i, (e, a) in enumerate(zip(parts_e, parts_a)):
            if not floats_match(float(e), float(a)):
                where = f"[{i}] " if len(parts_e) > 1 else ""
                yield f"{where}expected {e}, got {a}"
        return
    yield f"expected {expected!r}, got {actual!r}"


def csv_differences(expected: str, actual: str, key: str) -> list[str]:
    """Differences between two CSV texts: the same columns, rows matched by `key`, cell by cell."""
    (cols_e, rows_e, twice_e), (cols_a, rows_a, twice_a) = _read_csv(expected, key), _read_csv(actual, key)
    out = [f"{which} CSV has the key {k!r} more than once"
           for which, twice in (("the golden", twice_e), ("the new", twice_a)) for k in twice]
    if cols_e != cols_a:
        out.append(f"columns: missing {[c for c in cols_e if c not in cols_a]}, "
                   f"added {[c for c in cols_a if c not in cols_e]}" if set(cols_e) != set(cols_a)
                   else f"columns reordered: expected {cols_e}, got {cols_a}")
    missing, extra = [k for k in rows_e if k not in rows_a], [k for k in rows_a if k not in rows_e]
    if missing or extra:
        out.append(f"rows missing {missing[:3]}{' …' if len(missing) > 3 else ''} ({len(missing)}), "
                   f"rows added {extra[:3]}{' …' if len(extra) > 3 else ''} ({len(extra)})")
    elif list(rows_e) != list(rows_a):
        out.append("the same rows in another order")
    for k, row in rows_e.items():
        if k in rows_a:
            for col in cols_e:
                if col in rows_a[k]:
                    out += [f"row {k!r}, column {col}: {d}" for d in cell_differences(row[col], rows_a[k][col])]
    return out


def table_differences(expected: str, actual: str) -> list[str]:
    """Differences between two CSV texts read in order (no key column): the same header and
    number of rows, cell by cell as :func:`cell_differences` compares them."""
    rows_e, rows_a = list(csv.reader(io.StringIO(expected))), list(csv.reader(io.StringIO(actual)))
    if len(rows_e) != len(rows_a):
        return [f"{len(rows_e)} lines expected, got {len(rows_a)}"]
    out = []
    for i, (row_e, row_a) in enumerate(zip(rows_e, rows_a)):
        if len(row_e) != len(row_a) or (i == 0 and row_e != row_a):
            out.append(f"line {i + 1}: expected {row_e}, got {row_a}")
            continue
        out += [f"line {i + 1}, column {j + 1}: {d}" for j, (e, a) in enumerate(zip(row_e, row_a))
                for d in cell_differences(e, a)]
    return out


def report(golden: str | Path, found: list[str]) -> str:
    """The failure message for `found` differences from the golden file `golden` ('' if none)."""
    if not found:
        return ""
    more = f"\n  … and {len(found) - SHOWN} more" if len(found) > SHOWN else ""
    return (f"{golden}: {len(found)} difference(s) from the golden file (floats to 9 significant "
            f"digits, everything else exact):\n  " + "\n  ".join(found[:SHOWN]) + more)


# ----------------------------------------------------------------- golden files (xz, compact)

def read_xz_text(path: Path) -> str:
    return lzma.decompress(path.read_bytes()).decode()


def write_xz_text(path: Path, text: str) -> None:
    """Write `text` xz-compressed, atomically (a temporary file, then a rename)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(lzma.compress(text.encode(), preset=9 | lzma.PRESET_EXTREME))
    tmp.replace(path)


def read_logs(path: Path) -> dict[str, list[dict]]:
    """Logs kept in one JSON-lines file: ``{"golden": NAME, "events": N}`` then N events, per log."""
    lines, logs = read_xz_text(path).splitlines(), {}
    i = 0
    while i < len(lines):
        head = json.loads(lines[i])
        logs[head["golden"]] = [json.loads(line) for line in lines[i + 1:i + 1 + head["events"]]]
        i += 1 + head["events"]
    return logs


def logs_text(logs: dict[str, list[dict]]) -> str:
    """The text `read_logs` reads: sorted keys, no spaces, one event a line."""
    out = []
    for name in sorted(logs):
        out.append(json.dumps({"golden": name, "events": len(logs[name])}))
        out += [json.dumps(e, sort_keys=True, separators=(",", ":")) for e in logs[name]]
    return "\n".join(out) + "\n"


def _read_csv(text: str, key: str) -> tuple[list[str], dict[str, dict[str, str]], list[str]]:
    """(columns, rows by `key`, keys seen more than once)."""
    reader = csv.DictReader(io.StringIO(text))
    rows: dict[str, dict[str, str]] = {}
    twice = []
    for row in reader:
        if row[key] in rows:
            twice.append(row[key])
        rows[row[key]] = row
    return list(reader.fieldnames or []), rows, twice


def _is_float(text: str) -> bool:
    if _INTEGER.fullmatch(text.strip()):
        return False
    try:
        float(text)
    except ValueError:
        return False
    return True


def _short(value: Any, width: int = 120) -> str:
    text = json.dumps(value) if not isinstance(value, str) else repr(value)
    return text if len(text) <= width else text[:width] + "…"

