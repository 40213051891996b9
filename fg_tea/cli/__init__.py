"""The ``fg-tea`` command line, one module per command (docs/design.md §1.2).

:mod:`fg_tea.cli.main` builds the parser and dispatches; :mod:`fg_tea.cli.common` holds what the
commands share. Each command module registers its function and adds its parser.
"""

from fg_tea.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
