"""Per-episode result files: how a long study resumes (docs/design.md §11).

A study that runs episodes one by one (the planner frontier, the exact-policy yardstick) keeps
each episode's row as one JSON file in ``<out>/episodes/``, written atomically; run again, it
reads the rows already there and runs only the rest, so an interrupted run resumes where it
stopped. This module is the one home of the file names and of the read-or-run step.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Callable

from fg_tea.common.errors import InputError
from fg_tea.common.files import atomic_write_text


def file_part(name: str) -> str:
    """A planner spec (``lookahead:depth=2,width=3``) as a piece of a file name."""
    return name.replace(":", "_").replace(",", "_").replace("=", "-")


def kept_or_run(path: Path, run: Callable[[], dict[str, Any]] | None,
                check: Callable[[dict[str, Any]], str | None] | None = None) -> dict[str, Any] | None:
    """The row kept in `path`, or else ``run()``'s row, written there atomically first (None when
    there is none and `run` is None: a summary of what is there).

    Raises:
        InputError: `path` holds no JSON row, or `check` says why the row kept there does not
            belong to this run (its fault names the field).
    """
    if path.is_file():
        try:
            row = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise InputError(path, "$", f"not an episode row ({type(exc).__name__}); delete it to run it again") \
                from None
        fault = check(row) if check is not None else None
        if fault is not None:
            raise InputError(path, fault.split(":", 1)[0], fault.split(":", 1)[1].strip())
        return row
    if run is None:
        return None
    row = run()
    atomic_write_text(path, json.dumps(row) + "\n")
    return row


__all__ = ["file_part", "kept_or_run"]
