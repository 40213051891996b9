"""Atomic output files: written under a temporary name in the same folder, then renamed.

An interrupted run never leaves a half-written CSV, PNG, JSON or MP4 under its final name.
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator


@contextmanager
def atomic_path(path: str | Path, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path beside `path`; rename it to `path` if the block succeeds.

    Args:
        path: the final file name (its folder is created).
        suffix: appended to the temporary name, for writers that choose a format by extension
            (``".png"``, ``".mp4"``).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _remove_stale(path)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}{suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write `text` (UTF-8) to `path` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def _remove_stale(path: Path) -> None:
    """Remove temporaries of `path` left by writers killed before they could (dead pids only)."""
    prefix = f".{path.name}.tmp"
    try:
        leftovers = [p for p in path.parent.iterdir() if p.name.startswith(prefix)]
    except OSError:
        return
    for tmp in leftovers:
        digits = ""
        for ch in tmp.name[len(prefix):]:
            if not ch.isdigit():
                break
            digits += ch
        if digits and int(digits) != os.getpid() and not pid_alive(int(digits)):
            try:
                tmp.unlink()
            except OSError:
                pass


def pid_alive(pid: int) -> bool:
    """Whether a process with this id exists (on this machine)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OSError, OverflowError):
        return True
    return True
