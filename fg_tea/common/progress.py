"""One progress display for every long run: an episode, a video, a sweep (tqdm underneath).

On a terminal the line is redrawn in place as tqdm draws it. Anywhere else (a CI log, a file, a
pipe) one whole line is written at most every `every` seconds and at the end, so a log keeps a
readable history instead of carriage returns. Everything goes to stderr unless a stream is given.
"""

from __future__ import annotations

import sys
from typing import Any, TextIO

from tqdm import tqdm  # type: ignore[import-untyped]  # tqdm ships no annotations

#: Seconds between lines when stderr is not a terminal.
EVERY = 10.0


class _Lines:
    """A file for tqdm that turns its in-place redraws into whole lines (a stream that is no
    terminal): ``"\\rtext   "`` becomes ``"text\\n"``, the closing newline is dropped, and so is
    every line drawn before any work was done (so a run refused before its first job writes
    only its one-line error)."""

    def __init__(self, stream: TextIO, start: int) -> None:
        self.stream, self.start = stream, start
        self.bar: Any = None

    def write(self, text: str) -> None:
        line = text.lstrip("\r").rstrip()
        if line and self.bar is not None and self.bar.n > self.start:
            self.stream.write(line + "\n")

    def flush(self) -> None:
        self.stream.flush()


def is_terminal(stream: Any) -> bool:
    return bool(getattr(stream, "isatty", lambda: False)())


def progress(total: int, label: str, unit: str, *, initial: int = 0, stream: TextIO | None = None,
             every: float = EVERY, bar: bool = False, note: str = "", status: str | None = None) -> tqdm:
    """A progress display of `total` `unit` (``update(n)``, ``set_postfix_str(text)``, ``close()``).

    Args:
        total: the work to do, counted in `unit`.
        label: the line's prefix (``"sweep"``, ``"rendering video"``).
        unit: what is counted (``"episodes"``, ``"frames"``, ``"actions"``).
        initial: work already done (a resumed sweep's rows).
        stream: where to write (default stderr).
        every: seconds between lines off a terminal.
        bar: draw a bar (the episode's task), else counts, rate and time left.
        note: said after the count (``"(12 resumed)"``).
        status: said at the end of the first line (later ones: ``set_postfix_str``).
    """
    stream = stream if stream is not None else sys.stderr
    terminal = is_terminal(stream)
    counts = f"{{n_fmt}}/{{total_fmt}} {unit}{' ' + note if note else ''}"
    shape = (f"{{desc}}: |{{bar:24}}| {counts}{{postfix}}" if bar else
             f"{{desc}}: {counts} · {{rate_fmt}} · elapsed {{elapsed}} · ETA {{remaining}}{{postfix}}")
    lines = None if terminal else _Lines(stream, initial)
    shown = tqdm(total=total, initial=initial, desc=label, unit=unit, file=stream if lines is None else lines,
                 mininterval=0.1 if terminal else every, miniters=1, ascii=" #", bar_format=shape,
                 dynamic_ncols=terminal, leave=True, postfix=status)
    if lines is not None:
        lines.bar = shown
    return shown


__all__ = ["progress", "is_terminal", "EVERY"]
