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


#: Longest word an error line shows whole; a longer one (a path beyond PATH_MAX, a pasted blob)
#: keeps its two ends and says how long it was, so the line stays one readable line.
LONGEST_WORD = 200


def shorten_long_words(text: str) -> str:
    """`text` with every run of non-space characters over :data:`LONGEST_WORD` shortened."""
    import re

    def short(m: "re.Match[str]") -> str:
        word = m.group(0)
        return f"{word[:80]}…{word[-80:]} ({len(word):,} characters)"

    return re.sub(r"\S{%d,}" % (LONGEST_WORD + 1), short, text)


def run_script(main: Callable[[], int], prog: str) -> None:
    """Run an experiment script's `main` and exit with its status; an :class:`InputError` (bad
    flag, file or name) becomes one line ``prog: error: file: path: fault`` and status 2, as does
    a :class:`PlannerRefused` (a planner asked for that cannot plan in the house: ``prog: error:
    <its reason>``), and an interrupt (Ctrl-C) one line ``prog: interrupted`` and status 130 (what
    was written stays: sweeps resume from it)."""
    import sys

    try:
        status = main()
    except (InputError, PlannerRefused) as exc:
        sys.stderr.write(f"{prog}: error: {shorten_long_words(str(exc))}\n")
        raise SystemExit(2) from None
    except KeyboardInterrupt:
        sys.stderr.write(f"{prog}: interrupted\n")
        raise SystemExit(130) from None
    raise SystemExit(status)


class PlannerRefused(ValueError):
    """A planner cannot plan for this house or belief (docs/design.md §6.5-§6.7).

    Raised by :meth:`fg_tea.planning.Planner.check` before the first decision (and by a planner
    that meets the limit later in a search). ``kind`` says which limit: ``"size"`` (too many sites
    or truths for the planner's exact tables) or ``"belief"`` (a correlated joint belief too large
    for the planner to hold). Commands report it in one line with status 2; sweeps record a
    ``refused: KIND: ...`` row and go on.
    """

    KINDS = ("size", "belief")

    def __init__(self, message: str, kind: str, planner: str) -> None:
        if kind not in self.KINDS:
            raise ValueError(f"unknown refusal kind {kind!r} (known: {', '.join(self.KINDS)})")
        super().__init__(message)
        self.kind, self.planner = kind, planner

    def __reduce__(self):  # crosses process boundaries in sweeps
        return (type(self), (str(self), self.kind, self.planner))


class PlannerFault(RuntimeError):
    """A planner failed while deciding (it raised, exited, or returned no valid decision).

    The episode runner ends the episode with an ``episode_end`` whose reason says so, then raises
    this; ``fg-tea run`` and ``compare`` report it in one line naming the planner: exit status 2
    for a plug-in planner (the user's input), 1 for a built-in one (a fault of fg_tea).
    """

    def __init__(self, planner: str, what: str) -> None:
        super().__init__(f"planner {planner!r} {what}")
        self.planner, self.what = planner, what

    def __reduce__(self):  # rebuilt from its two parts, so it crosses process boundaries (sweeps)
        return (type(self), (self.planner, self.what))


class ContradictionError(ValueError):
    """Evidence that has probability zero under the model (the posterior would be undefined)."""
