"""MkDocs hook: the command-line reference, generated from fg_tea's own argparse parsers.

``docs/reference/cli.md`` holds the placeholder line ``<!-- fg-tea commands -->``; at build time
:func:`on_page_markdown` replaces it with one section per command, holding that command's
``fg-tea COMMAND --help`` text (``format_help()`` of the parser ``fg_tea.cli.build_parser``
builds). Nothing is written to the source tree: the page is filled in memory, so the reference
cannot fall behind the parsers. Registered under ``hooks:`` in ``mkdocs.yml``.
"""

from __future__ import annotations

import argparse
import os
from contextlib import contextmanager

PLACEHOLDER = "<!-- fg-tea commands -->"
PAGE = "reference/cli.md"
#: Help is wrapped at this width whatever the terminal of the build, so the page is reproducible.
WIDTH = "100"


@contextmanager
def _columns(width: str):
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = width
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = old


def commands() -> list[tuple[str, str, str]]:
    """``(name, one-line help, --help text)`` of every ``fg-tea`` command, in the parser's order,
    after ``("fg-tea", ..., the top-level --help)``."""
    from fg_tea.cli import build_parser

    with _columns(WIDTH):
        parser = build_parser()
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        helps = {choice.dest: choice.help or "" for choice in sub._choices_actions}
        found = [("fg-tea", parser.description or "", parser.format_help())]
        for name, command in sub.choices.items():
            found.append((name, helps.get(name, ""), command.format_help()))
    return found


def markdown() -> str:
    """The generated part of the page: a table of the commands, then each one's help."""
    found = commands()
    lines = ["| command | what it does |", "|---|---|"]
    for name, summary, _ in found[1:]:
        lines.append(f"| [`{name}`](#{name}) | {summary.replace('|', '&#124;')} |")
    lines.append("")
    for name, summary, text in found:
        title = name if name == "fg-tea" else f"fg-tea {name}"
        anchor = "fg-tea" if name == "fg-tea" else name
        lines += [f"## `{title}` {{#{anchor}}}", "", summary, "", "```text", text.rstrip(), "```", ""]
    return "\n".join(lines)


def on_page_markdown(markdown_text: str, page, config, files):  # noqa: ARG001 - MkDocs hook API
    if page.file.src_uri != PAGE:
        return markdown_text
    if PLACEHOLDER not in markdown_text:
        raise ValueError(f"{PAGE} lost its placeholder line {PLACEHOLDER!r}")
    return markdown_text.replace(PLACEHOLDER, markdown())
