"""The `fg-tea` command line: a thin wrapper over the package's public API.

Exit statuses, the same for every command: 0 when the command did what it was asked; 1 when it
ran and failed for a reason that is not the user's input (an episode that ended without completing
its task, a sweep job that failed, a fault of a built-in planner), in one line; 2 for bad input:
every input fault (scenario, model or task file; bad option; a plug-in planner that raises, exits
or breaks the Planner contract) is printed as one line naming the file, the field and what is
wrong; 130 when interrupted.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Callable, Sequence

import fg_tea.cli.beliefs as beliefs
import fg_tea.cli.compare as compare
import fg_tea.cli.explore as explore
import fg_tea.cli.house as house
import fg_tea.cli.learn as learn
import fg_tea.cli.list as listing
import fg_tea.cli.run as run
import fg_tea.cli.validate as validate
from fg_tea.cli.common import COMMANDS, Failed, Parser
from fg_tea.common.errors import ContradictionError, InputError
from fg_tea.common.options import DeprecatedAlias, check_aliases


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="fg-tea", description="A tea-making drone that reasons with exact beliefs.")
    from fg_tea._version import __version__

    parser.add_argument("--version", action="version", version=f"fg-tea {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser, metavar="COMMAND",
                                help="what to do (fg-tea COMMAND --help for its options)")

    for command in (beliefs, validate, listing, run, compare, explore, house, learn):  # one module each
        command.add_parser(sub)
    return parser


#: BLAS thread variables the command line sets to 1 unless the user set them (see main).
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def single_threaded_blas_defaults(environ=os.environ) -> list[str]:
    """Default the BLAS thread counts to 1, keeping any value the user set; returns the names set.

    The planner's matrix products are small (docs/design.md §6.2), and on a shared machine a
    multi-threaded BLAS mostly waits for busy cores: the joint gain's products were measured 40-70
    times slower under load with the default thread count. Only effective before numpy is
    imported, so :func:`main` calls it first; child processes (sweep workers) inherit it.
    """
    chosen = [v for v in BLAS_THREAD_VARIABLES if v not in environ]
    for v in chosen:
        environ[v] = "1"
    return chosen


def main(argv: Sequence[str] | None = None,
         parser_factory: Callable[[], argparse.ArgumentParser] | None = None) -> int:
    """Run one command; `parser_factory` (default :func:`build_parser`) builds the parser, whose
    namespace names the command in ``command`` (as experiments/compare_beliefs.py does)."""
    single_threaded_blas_defaults()
    parser = (parser_factory or build_parser)()
    try:  # option types import plug-in planners: an interrupt there is one line too
        args = parser.parse_args(argv)
    except KeyboardInterrupt:
        _error("interrupted", prefix="fg-tea: ")
        return 130
    check_aliases(parser, args, sys.argv[1:] if argv is None else list(argv))
    notes = list(getattr(args, DeprecatedAlias.NOTES, []))  # written after the command, or
    if hasattr(args, DeprecatedAlias.NOTES):                 # folded into its one error line
        delattr(args, DeprecatedAlias.NOTES)
    try:
        status = COMMANDS[args.command](args)
        sys.stdout.flush()
        for note in notes:
            _error(note, prefix="fg-tea: note: ")
        return status
    except InputError as exc:
        _error(str(exc) + "".join(f" (note: {n})" for n in notes))
        return 2
    except Failed as exc:
        _error(str(exc) + "".join(f" (note: {n})" for n in notes))
        return 1
    except ContradictionError as exc:  # the model (the user's input) contradicted by the world
        model = getattr(args, "model", None)
        _error(f"{model or '<model>'}: {exc}")
        return 2
    except BrokenPipeError:
        # The reader of our output went away (``fg-tea ... | head``): end quietly.
        _silence_stdout()
        return 141
    except OSError as exc:  # disk full, permissions, a vanished folder: one line, not a traceback
        where = exc.filename if exc.filename is not None else "<output>"
        _error(f"{where}: {exc.strerror or exc}")
        return 2
    except KeyboardInterrupt:
        _error("interrupted", prefix="fg-tea: ")
        return 130


def _error(message: str, prefix: str = "fg-tea: error: ") -> None:
    """Write one line to stderr; any character the terminal cannot show is escaped."""
    from fg_tea.common.errors import shorten_long_words

    text = shorten_long_words((prefix + message).replace("\n", " ").replace("\r", " "))
    try:
        sys.stderr.write(text.encode("utf-8", "backslashreplace").decode("utf-8") + "\n")
        sys.stderr.flush()
    except (OSError, ValueError):
        pass


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's exit flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass
