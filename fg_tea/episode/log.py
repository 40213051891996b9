"""The event-sourced episode log: one JSON line per meaningful transition, flushed as it happens.

Event kinds (field ``event``): ``episode_start``, ``decision``, ``observation``, ``state_reading``,
``skip``, ``action``, ``action_failed``, ``recovery``, ``belief``, ``episode_end``. Every event
carries ``seq`` (its index) and ``frame`` (the frame count when it was written). Nothing in the log
depends on wall-clock time, so the same scenario, model and seed give the same bytes; timings go to
a separate sidecar file.

A crash leaves a valid log up to the last event: each line is written whole and flushed.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Iterator, TextIO

import numpy as np

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
        self._fh: TextIO | None = None
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._fh = self.path.open("w", encoding="utf-8")

    def write(self, event: dict) -> dict:
        event = {"seq": len(self.events), **event}
        line = encode(event)
        self.events.append(json.loads(line))
        if self._fh is not None:
            self._fh.write(line + "\n")
            self._fh.flush()
        return self.events[-1]

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def __enter__(self) -> "EventLog":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_log(path: str | Path) -> list[dict]:
    """Read a log back; a truncated last line (a crash mid-write) is ignored."""
    events = []
    for line in Path(path).read_text(encoding="utf-8").splitlines():
        if not line.strip():
            continue
        try:
            events.append(json.loads(line))
        except json.JSONDecodeError:
            break
    return events


def iter_events(events: list[dict], kind: str) -> Iterator[dict]:
    return (e for e in events if e.get("event") == kind)
