"""The event-sourced episode log: one JSON line per meaningful transition, flushed as it happens.

Event kinds (field ``event``; fields and when each is written: docs/design.md §9):
``episode_start``, ``activate``, ``skip``, ``decision``, ``observation``, ``confirm_search``,
``state_reading``, ``action``, ``action_failed``, ``fail``, ``reopen``, ``alternative_site``,
``give_up``, ``stuck``, ``belief``, ``episode_end``, ``metrics``. Every event carries ``seq`` (its
index) and ``frame`` (the frame count when it was written). Nothing in the log
depends on wall-clock time, so the same scenario, model and seed give the same bytes; timings go to
a separate sidecar file.

A crash leaves a valid log up to the last event: each line is written whole and flushed.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping

import numpy as np

from fg_tea.common.files import check_output_file

#: Every event kind a log holds (docs/design.md §9 documents each one's fields).
EVENT_KINDS = ("episode_start", "activate", "skip", "decision", "observation", "confirm_search",
               "state_reading", "action", "action_failed", "fail", "reopen", "alternative_site",
               "give_up", "substitute", "alternative_method", "stuck", "belief", "episode_end", "metrics")
#: The executor's own records, merged by the runner into ``action`` and ``state_reading``
#: (``state_reading.executor_event`` names which); never events of their own.
MERGED_KINDS = ("complete", "inspect", "observe_state")
#: A log is read whole (its parsed events take a few times its bytes); 50,000 frames write well
#: under 100 MB, and a file this size still fits in a workstation's memory when read.
LOG_MAX_BYTES = 256 * 1024 ** 2
_write = os.write  # the one call that puts log bytes on disk (tests replace it to fill the disk)
DIGITS = 9  # floats are rounded so that logs are stable across platforms' last-bit noise
#: Keys whose floats are tiny by nature (a disagreement of ~1e-16): kept to DIGITS significant
#: digits (scientific notation) instead of DIGITS decimals, which would round them to 0.0.
SIGNIFICANT_KEYS = frozenset({"gtsam_agreement"})


def _significant(value: Any) -> Any:
    if isinstance(value, (np.floating, float)) and math.isfinite(float(value)):
        return float(f"{float(value):.{DIGITS - 1}e}")
    return _clean(value)


def _clean(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): (_significant(v) if k in SIGNIFICANT_KEYS else _clean(v))
                for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return _clean(value.tolist())
    if isinstance(value, (np.floating, float)):
        x = float(value)
        if math.isnan(x):
            raise ValueError("NaN in a log event")
        return x if math.isinf(x) else round(x, DIGITS)
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, frozenset | set):
        return sorted(_clean(v) for v in value)
    return value


def encode(event: dict) -> str:
    """One event as one canonical JSON line (no trailing newline)."""
    return json.dumps(_clean(event), separators=(",", ":"), allow_nan=True)


class EventLog:
    """Appends events to a JSONL file (or keeps them in memory when `path` is None).

    Args:
        path: where to write; the parent folder is created. None keeps events in memory only.
    """

    def __init__(self, path: str | Path | None = None) -> None:
        self.path = Path(path) if path is not None else None
        self.events: list[dict] = []
        self._fd: int | None = None
        self._size = 0  # bytes of complete lines on disk
        if self.path is not None:
            check_output_file(self.path, "log")  # opening a FIFO would block; a device, be written
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666)

    def write(self, event: dict) -> dict:
        event = {"seq": len(self.events), **event}
        line = encode(event)
        if self._fd is not None:
            self._write_line((line + "\n").encode("utf-8"))
        self.events.append(json.loads(line))
        return self.events[-1]

    def _write_line(self, data: bytes) -> None:
        """Write one whole line unbuffered; on failure cut the file back to its last whole line."""
        assert self._fd is not None, "the log is open"
        done = 0
        try:
            while done < len(data):
                done += _write(self._fd, data[done:])
        except OSError:
            try:
                os.ftruncate(self._fd, self._size)
                os.lseek(self._fd, self._size, os.SEEK_SET)
            except OSError:
                pass
            raise
        self._size += len(data)

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> "EventLog":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_log(path: str | Path, strict: bool = False) -> list[dict]:
    """The events of a log file, read through the guarded input reader (one reader for every
    command that reads logs: render, learn, explore, the quality checks).

    A FIFO, a device, a folder, an oversized or non-UTF-8 file, NUL bytes, a line that is not an
    event, and every fault of meaning :mod:`fg_tea.episode.log_check` lists (a duplicate key, a
    bare ``NaN``, an infinity anywhere but an unreachable ``distance``, a lone surrogate, ``seq``
    not rising from ``episode_start``, a field of the wrong type) are refused in every mode. A
    truncated last line (a crash mid-write) ends the log; with `strict`, it is an error too, as
    is a log with no event.

    Raises:
        InputError: one line naming the file, the line (and the field) and the fault.
    """
    return read_events(path, strict)[0]


def read_events(path: str | Path, strict: bool = False) -> tuple[list[dict], bool]:
    """:func:`read_log`'s events, and whether a partial last line was left out (never with
    `strict`)."""
    import gc

    from fg_tea.common.errors import InputError

    collecting = gc.isenabled()
    gc.disable()  # parsed events hold no cycles; collecting while they are built costs up to half the time
    try:
        return _read_events(path, strict)
    except MemoryError:
        raise InputError(path, "$", "too large to read into memory (a log is read whole)") from None
    finally:
        if collecting:
            gc.enable()


def _read_events(path: str | Path, strict: bool) -> tuple[list[dict], bool]:
    from fg_tea.common.errors import InputError
    from fg_tea.common.inputs import read_text
    from fg_tea.episode import log_check

    text = read_text(path, max_bytes=LOG_MAX_BYTES)
    nul = text.find("\0")
    if nul >= 0:
        raise InputError(path, f"line {text.count(chr(10), 0, nul) + 1}",
                         "a NUL byte (padding a crash or a copy can leave): not log text")
    infinite, surrogate = log_check.suspect_lines(text)  # lines that could hold either
    lines = text.split("\n")
    del text
    last = max((n for n, line in enumerate(lines, 1) if line.strip()), default=0)
    events: list[dict] = []
    previous: dict | None = None
    for n, line in enumerate(lines, 1):
        if not line.strip():
            continue
        event: Any = None
        try:
            event = log_check.parse_line(line)
            if n in infinite or n in surrogate:
                log_check.check_walked(event, n in infinite, n in surrogate)
            log_check.check_event(event, previous)
        except log_check.Fault as exc:
            kind = event.get("event") if isinstance(event, dict) else None
            raise log_check.refuse(path, n, exc, kind if isinstance(kind, str) else None) from None
        except RecursionError:
            raise InputError(path, f"line {n}", "nested too deeply to be an event") from None
        except ValueError:
            if strict or n != last:
                raise InputError(path, f"line {n}", "not a JSON line") from None
            return events, True  # a crash mid-write left a partial last line
        events.append(event)
        previous = event
    if strict and not events:
        raise InputError(path, "line 1", "a log starts with an episode_start event")
    return events, False


def episode_digest(events: Iterable[Mapping]) -> str:
    """The sha256 of an episode's content: its events, keys sorted, in canonical JSON. Two logs
    of the same episode have the same digest whatever their bytes (key order, spacing, blank
    lines); ``fg-tea learn`` counts an episode once by it."""
    import hashlib

    digest = hashlib.sha256()
    for event in events:
        digest.update(json.dumps(event, sort_keys=True, separators=(",", ":")).encode("utf-8"))
        digest.update(b"\n")
    return digest.hexdigest()


def iter_events(events: Iterable[Mapping], kind: str) -> Iterator[Mapping]:
    return (e for e in events if e.get("event") == kind)
