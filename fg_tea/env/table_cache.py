"""Tables a house computes once and keeps: in this process, and on disk under ``cache_dir()``.

The expected-pixel tables of a PyBullet house (docs/design.md §3.4, §3.5) take seconds to render
and depend only on the house's geometry and the camera, so :func:`cached_table` keeps each under
a hash of everything it depends on: in memory for the process, and as JSON in
``$FG_TEA_CACHE_DIR`` (default ``~/.cache/fg_tea``), which nodes of a cluster may share
(docs/how-to/sweep-on-ray.md). An unreadable file is recomputed; an unwritable folder only costs
time.
"""

from __future__ import annotations

import copy
import json
import os
from pathlib import Path
from typing import Callable

from fg_tea.common.files import atomic_write_text

#: Tables already computed in this process (cache key -> table).
MEMORY: dict[str, dict] = {}


def cache_dir() -> Path:
    """Where computed tables are cached: ``$FG_TEA_CACHE_DIR``, else ``~/.cache/fg_tea``."""
    env = os.environ.get("FG_TEA_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "fg_tea"


def cached_table(kind: str, key: str, compute: Callable[[], dict]) -> dict:
    """The table of `kind` under `key`: from memory, else from disk, else `compute()` (then kept
    in both). A fresh copy each time, so a caller may change it."""
    if key in MEMORY:
        return copy.deepcopy(MEMORY[key])
    path = cache_dir() / kind / f"{key}.json"
    table = None
    if path.is_file():
        try:
            table = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            table = None
    if table is None:
        table = compute()
        try:
            atomic_write_text(path, json.dumps(table, sort_keys=True))
        except OSError:
            pass  # an unwritable cache only costs time
    MEMORY[key] = table
    return copy.deepcopy(table)


__all__ = ["MEMORY", "cache_dir", "cached_table"]
