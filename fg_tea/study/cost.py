"""What a large sweep will cost: its number of episodes and an estimate of its CPU time.

A sweep of more than :data:`ESTIMATE_ABOVE` episodes says on stderr, before its first episode
finishes, how many episodes it will run; once its first :data:`TIMING_EPISODES` jobs (in the
order they were submitted, so not just the quickest to finish) are back, it says::

    compare: 120,000 episodes, about 57 CPU-hours (from a timing of 24 episodes: 1.71 s CPU each, ...)

The timing is the CPU time each job took in the process that ran it (``time.process_time``,
every thread of that process), on the workers that run the sweep, so a cluster's nodes are timed
as they are. Each worker's first job pays its start-up (imports, per-house tables not yet
cached), so a short timing errs high. The timing never reaches the CSV: rows hold no clock
readings, so a sweep's CSV stays a pure function of its jobs.
"""

from __future__ import annotations

import sys
from typing import Sequence, TextIO

#: Sweeps of more than this many episodes (still to run) print their size and a CPU-time estimate.
ESTIMATE_ABOVE = 1_000

#: The estimate is the mean CPU time of the first this many jobs submitted, times the job count.
TIMING_EPISODES = 24


def cpu_hours_text(hours: float) -> str:
    """CPU hours to a few significant figures: 0.05, 1.7, 57, 1,234."""
    if hours >= 100:
        return f"{hours:,.0f}"
    return f"{hours:.2g}" if hours < 10 else f"{hours:.0f}"


class CostEstimate:
    """Announces a large sweep's size, then its estimated CPU time from its first jobs' timing.

    Args:
        keys: the keys of the jobs still to run, in submission order.
        label: the prefix of the lines (the sweep's progress label).
        stream: where the lines go (stderr).
        above: sweeps of at most this many jobs say nothing (default :data:`ESTIMATE_ABOVE`).
        timing: how many of the first jobs are timed (default :data:`TIMING_EPISODES`).
    """

    def __init__(self, keys: Sequence[str], label: str = "sweep", stream: TextIO | None = None,
                 above: int | None = None, timing: int | None = None) -> None:
        self.total = len(keys)
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        above = ESTIMATE_ABOVE if above is None else above
        timing = TIMING_EPISODES if timing is None else timing
        self.active = self.total > above
        self._timed = set(keys[:max(1, timing)]) if self.active else set()
        self._seconds: list[float] = []
        self.line: str | None = None

    def start(self) -> None:
        """Say how many episodes will run, before any has (large sweeps only)."""
        if self.active:
            self._say(f"{self.label}: {self.total:,} episodes to run; an estimate of their CPU time "
                      f"follows when the first {len(self._timed)} are back")

    def record(self, key: str, cpu_seconds: float) -> None:
        """Note one finished job; after the last timed one, print the estimate."""
        if key not in self._timed:
            return
        self._timed.discard(key)
        self._seconds.append(float(cpu_seconds))
        if not self._timed:
            k = len(self._seconds)
            mean = sum(self._seconds) / k
            hours = mean * self.total / 3600.0
            self.line = (f"{self.label}: {self.total:,} episodes, about {cpu_hours_text(hours)} CPU-hours "
                         f"(from a timing of {k} episodes: {mean:.2f} s CPU each, mean; each worker's "
                         "start-up included)")
            self._say(self.line)

    def _say(self, text: str) -> None:
        tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.stream.write(("\n" if tty else "") + text + "\n")  # below a progress line redrawn in place
        self.stream.flush()


__all__ = ["ESTIMATE_ABOVE", "TIMING_EPISODES", "CostEstimate", "cpu_hours_text"]
