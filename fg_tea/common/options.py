"""Command-line option helpers shared by ``fg-tea`` and the experiment scripts.

Which question it answers: how does an old option name stay usable for a release without a
second line of output when the command then fails?
"""

from __future__ import annotations

import argparse
import sys
from typing import Any, Sequence


class DeprecatedAlias(argparse.Action):
    """An old option name kept for one release: stores into the new option's destination and
    leaves a one-line deprecation note (written by ``fg_tea.cli.main`` after the command, for a parser
    with ``defer_notes``; at once by any other parser).

    Add it with ``default=argparse.SUPPRESS`` so that the new option's default stands.
    """

    NOTES = "_deprecation_notes"

    def __init__(self, option_strings: Sequence[str], dest: str, new: str = "", **kwargs: Any) -> None:
        self.new = new
        kwargs.setdefault("help", f"deprecated alias of {new}")
        kwargs.setdefault("default", argparse.SUPPRESS)
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        setattr(namespace, self.dest, values)
        note = f"{option_string} is deprecated; use {self.new}"
        if getattr(parser, "defer_notes", False):
            notes = getattr(namespace, self.NOTES, [])
            if note not in notes:
                setattr(namespace, self.NOTES, notes + [note])
        else:
            sys.stderr.write(f"note: {note}\n")


__all__ = ["DeprecatedAlias"]
