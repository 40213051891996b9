"""Import pybullet without the build banner it prints from C at import time."""

from __future__ import annotations

import os
import sys


def _flush_c_stdio() -> None:
    """Flush C's stdio buffers while fd 1 still points at /dev/null (the banner is printf'd)."""
    try:
        import ctypes

        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError):
        pass


def _quiet_import():
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        saved = (os.dup(1), os.dup(2))
    except OSError:  # no file descriptors to redirect (embedded interpreters)
        import pybullet
        return pybullet
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 1)
            os.dup2(devnull.fileno(), 2)
            import pybullet
            _flush_c_stdio()
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        os.close(saved[0])
        os.close(saved[1])
    return pybullet


pybullet = _quiet_import()
