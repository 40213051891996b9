"""Process hygiene: how do worker processes die with the command that started them?

A pool worker (video segments, sweep episodes) is started with :func:`die_with_parent` as its
initializer. On Linux it asks the kernel to send it SIGKILL when its parent ends
(``prctl(PR_SET_PDEATHSIG)``), so ``kill -9`` of the command leaves no orphaned workers; elsewhere
it is a no-op and the pools' own shutdown is all there is.
"""

from __future__ import annotations

import os
import signal
import sys

_PR_SET_PDEATHSIG = 1


def die_with_parent(parent_pid: int | None = None) -> None:
    """Make this process receive SIGKILL when its parent process ends (Linux; no-op elsewhere).

    Args:
        parent_pid: the parent's pid as the parent saw it; if the parent already ended before
            this call (a race the kernel flag cannot cover), the process exits at once.
    """
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):  # no libc prctl: nothing more to do
        return
    if parent_pid is not None and os.getppid() != parent_pid:
        os._exit(1)
