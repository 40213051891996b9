"""The errors fg_tea raises on purpose, and the one-line exit every command and script shares.

- :class:`InputError`: a bad input (file, field, fault), reported as one line with exit status 2;
- :class:`ContradictionError`: evidence the model rules out entirely (docs/design.md §3.4);
- :func:`run_script`: the shared main wrapper of the experiment scripts.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable


class InputError(ValueError):
    """A fault in an input file: `file: path: fault`."""

    def __init__(self, file: str | Path, path: str, fault: str) -> None:
        self.file = str(file)
        self.path = path
        self.fault = fault
        super().__init__(f"{self.file}: {path}: {fault}")

    def __reduce__(self):
        # Rebuilt from its three parts, so it crosses process boundaries (worker pools).
        return (type(self), (self.file, self.path, self.fault))


def run_script(main: Callable[[], int], prog: str) -> None:
    """Run an experiment script's `main` and exit with its status; an :class:`InputError` (bad
    flag, file or name) becomes one line ``prog: error: file: path: fault`` and status 2."""
    import sys

    try:
        status = main()
    except InputError as exc:
        sys.stderr.write(f"{prog}: error: {exc}\n")
        raise SystemExit(2) from None
    raise SystemExit(status)


class ContradictionError(ValueError):
    """Evidence that has probability zero under the model (the posterior would be undefined)."""
