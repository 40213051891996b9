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

    #: Where the alias leaves the value it was given, for :func:`check_aliases`.
    GIVEN = "_alias_given_"

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        setattr(namespace, self.dest, values)
        setattr(namespace, self.GIVEN + self.dest, (option_string, values))
        note = f"{option_string} is deprecated; use {self.new}"
        if getattr(parser, "defer_notes", False):
            notes = getattr(namespace, self.NOTES, [])
            if note not in notes:
                setattr(namespace, self.NOTES, notes + [note])
        else:
            sys.stderr.write(f"note: {note}\n")


def check_aliases(parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                  argv: Sequence[str]) -> None:
    """After parsing: an old option name given together with its new one is an error (one line,
    exit 2), whatever the values and their order; the alias's bookkeeping is then removed."""
    new_names = {a.dest: a.new for a in _aliases(parser)}
    for key in [k for k in vars(namespace) if k.startswith(DeprecatedAlias.GIVEN)]:
        dest = key[len(DeprecatedAlias.GIVEN):]
        option, _ = getattr(namespace, key)
        delattr(namespace, key)
        new = new_names.get(dest, "")
        if new and any(a == new or a.startswith(new + "=") for a in argv):
            parser.error(f"{option} and {new} name the same setting; give {new} once")


def _aliases(parser: argparse.ArgumentParser) -> list[DeprecatedAlias]:
    """Every DeprecatedAlias of `parser` and of its subcommands' parsers."""
    found = [a for a in parser._actions if isinstance(a, DeprecatedAlias)]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                found += _aliases(sub)
    return found


class DefaultsHelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Show each option's default after its help, unless the help already states it.

    Lists are shown as they are typed (``6 8 12``); no default is shown for an option whose
    default is None or False (a flag, or a value resolved later: its help says what happens).
    """

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        if ("%(default)" in text or "(default" in text or default is None or default is False
                or default is argparse.SUPPRESS or not action.option_strings):
            return text
        if isinstance(default, (list, tuple)):
            shown = " ".join("x".join(map(str, d)) if isinstance(d, tuple) else str(d) for d in default)
        else:
            shown = str(default)
        return f"{text} (default: {shown.replace('%', '%%')})"


#: Help of the options several experiment scripts share (their defaults differ per script).
WORLD_HELP = "world distribution: a bundled name or a world JSON file"
MODELS_HELP = "models: bundled names, bundled ablations or model .toml files"
MODEL_HELP = "model: a bundled name, a bundled ablation or a model .toml file"
SCENARIO_HELP = "scenario: a bundled name or a scenario JSON file"
PLANNER_HELP = "planner name, e.g. efe, greedy, nearest, optimal"
SEED_HELP = "random seed (an integer; the same seed gives the same run)"
ENV_HELP = "PyBullet house or the fake oracle house (straight-line travel, oracle pixel counts)"
WORKERS_HELP = "worker processes"
OUT_HELP = "output folder"


def _option_strings(parser: argparse.ArgumentParser) -> list[str]:
    """Every option string of `parser` and of its subcommands' parsers."""
    out = []
    for action in parser._actions:  # noqa: SLF001 - argparse keeps no public list
        out += [o for o in action.option_strings if o.startswith("--")]
        if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
            for sub in action.choices.values():
                out += _option_strings(sub)
    return sorted(set(out))


def with_suggestions(parser: argparse.ArgumentParser, message: str) -> str:
    """`message` with "did you mean" for each unrecognised ``--option`` close to a known one."""
    import difflib

    prefix = "unrecognized arguments: "
    if not message.startswith(prefix):
        return message
    known = _option_strings(parser)
    hints = []
    for word in message[len(prefix):].split():
        flag = word.split("=", 1)[0]
        if flag in known:  # an option of another subcommand, not a typo
            hints.append(f"{flag}: not an option of this command, see its --help")
        elif flag.startswith("--"):
            close = difflib.get_close_matches(flag, known, n=1, cutoff=0.7)
            if close:
                hints.append(f"{flag}: did you mean {close[0]}?")
    return message + (" (" + "; ".join(hints) + ")" if hints else "")


class OneLineParser(argparse.ArgumentParser):
    """argparse that reports a usage fault in one line, ``PROG: error: ...``, with exit status 2
    (argparse prints the whole usage first), and "did you mean" for a mistyped option."""

    def error(self, message: str):  # noqa: D401 - argparse API
        import sys

        from fg_tea.common.errors import shorten_long_words

        sys.stderr.write(f"{self.prog}: error: {shorten_long_words(with_suggestions(self, message))}\n")
        raise SystemExit(2)


def experiment_parser(doc: str | None, file: str, section: str, **kwargs: Any) -> argparse.ArgumentParser:
    """The argparse parser of an experiment script (``experiments/NAME.py``).

    `doc` is the script's module docstring: its first paragraph is the description. `file` is
    the script's ``__file__``, whose name is the program name. `section` names the part of
    docs/design.md the script implements (e.g. ``"§11"``), cited in the epilog. Every option's
    default is shown after its help (:class:`DefaultsHelpFormatter`). A usage fault is one line
    and exit 2 (:class:`OneLineParser`).
    """
    from pathlib import Path

    first = (doc or "").strip().split("\n\n")[0]
    kwargs.setdefault("prog", Path(file).name)
    kwargs.setdefault("description", " ".join(first.split()))
    kwargs.setdefault("epilog", f"Implements docs/design.md {section}; the module docstring of "
                      f"experiments/{Path(file).name} has examples and what it writes.")
    kwargs.setdefault("formatter_class", DefaultsHelpFormatter)
    return OneLineParser(**kwargs)


__all__ = ["with_suggestions", "OneLineParser", "DefaultsHelpFormatter", "DeprecatedAlias", "ENV_HELP",
           "MODEL_HELP", "MODELS_HELP", "OUT_HELP", "PLANNER_HELP", "SCENARIO_HELP", "SEED_HELP",
           "WORKERS_HELP", "WORLD_HELP", "experiment_parser"]
