"""Atomic output files: written under a temporary name in the same folder, then renamed.

An interrupted run never leaves a half-written CSV, PNG, JSON or MP4 under its final name.
"""

from __future__ import annotations

import os
import stat
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, Sequence

from fg_tea.common.errors import InputError

#: What a path that is not a regular file is, for the one-line refusal.
_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def not_a_regular_file(path: str | Path) -> str | None:
    """What `path` is when it exists and is not a regular file (links followed), else None."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):  # missing (or a dangling link), or a name the OS refuses
        return None
    if stat.S_ISREG(mode):
        return None
    return next((what for test, what in _KINDS if test(mode)), "not a regular file")


def check_output_file(path: str | Path, option: str = "--out") -> Path:
    """Refuse, before any work, an output file that exists and is not a regular file.

    An output is written under a temporary name and renamed over its target, which would replace
    a device node, a FIFO or a socket with a plain file (as root, ``/dev/null`` itself).

    Raises:
        InputError: one line naming the option, the path and what it is.
    """
    what = not_a_regular_file(path)
    if what is not None:
        raise InputError("<command line>", option, f"{path} exists and is {what}, not a regular file")
    return Path(path)


def check_outputs_in(folder: str | Path, names: Sequence[str], option: str = "--out") -> None:
    """:func:`check_output_file` for each file a command will write into `folder`."""
    for name in names:
        check_output_file(Path(folder) / name, option)


def check_out_dir(path: Path, flag: str = "--out") -> Path:
    """Create the output folder `path` (and parents), or fail with one line saying why not."""
    if path.exists() and not path.is_dir():
        raise InputError("<command line>", flag, f"{path} exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError("<command line>", flag, f"cannot create folder {path}: "
                         f"{exc.strerror or exc}") from None
    import tempfile

    try:  # the only sure test of writability (root, read-only mounts, /proc)
        with tempfile.NamedTemporaryFile(dir=path, prefix=".fg-tea-probe-"):
            pass
    except OSError as exc:
        raise InputError("<command line>", flag, f"cannot write into folder {path}: "
                         f"{exc.strerror or exc}") from None
    return path


def check_out_file(path: Path, flag: str = "--out") -> Path:
    """Check that the output file `path` can be written (atomically, beside itself)."""
    if path.is_dir():
        raise InputError("<command line>", flag, f"{path} is a folder; name a file")
    check_output_file(path, flag)
    check_out_dir(path.parent if str(path.parent) else Path("."), flag)
    return path


def out_folder(text: str) -> str:
    """An argparse ``type`` for an output folder: created and probed at parse time, so a folder
    that cannot be written is one line and exit 2 before any work (experiment scripts)."""
    import argparse

    try:
        check_out_dir(Path(text))
    except InputError as exc:
        raise argparse.ArgumentTypeError(exc.fault) from None
    return text


def out_file(text: str) -> Path:
    """An argparse ``type`` for an output file, checked as :func:`check_out_file` does."""
    import argparse

    try:
        return check_out_file(Path(text))
    except InputError as exc:
        raise argparse.ArgumentTypeError(exc.fault) from None


@contextmanager
def atomic_path(path: str | Path, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path beside `path`; rename it to `path` if the block succeeds.

    Args:
        path: the final file name (its folder is created).
        suffix: appended to the temporary name, for writers that choose a format by extension
            (``".png"``, ``".mp4"``).
    """
    path = Path(path)
    what = not_a_regular_file(path)
    if what is not None:  # never rename a file over a device, a FIFO, a socket or a folder
        raise InputError(path, "$", f"exists and is {what}, not a regular file; not replaced")
    path.parent.mkdir(parents=True, exist_ok=True)
    _remove_stale(path)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}{suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_png(path: str | Path, rgb, params: Sequence[int] = ()) -> Path:
    """Encode an RGB image as PNG in memory and write it atomically.

    OpenCV's ``imwrite`` reports a failed write (a full disk) by printing libpng's own message to
    stderr and returning False; encoding first and writing from Python makes the same failure an
    :class:`OSError` naming the file, which the commands turn into one line. `params` are
    OpenCV's (e.g. ``[cv2.IMWRITE_PNG_COMPRESSION, 9]``); the bytes are those ``imwrite`` writes.
    """
    import cv2

    ok, data = cv2.imencode(".png", rgb[:, :, ::-1], list(params))
    if not ok:
        raise OSError(f"cannot encode a PNG image for {path}")
    with atomic_path(path, ".png") as tmp:
        tmp.write_bytes(data.tobytes())
    return Path(path)


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
