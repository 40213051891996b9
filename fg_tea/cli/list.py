"""``fg-tea list``: the bundled scenarios, models, ablations, tasks and world distributions.
"""

from __future__ import annotations

import argparse
from typing import Any

from fg_tea.cli.common import command
from fg_tea.common.errors import InputError


@command("list")
def cmd_list(args: argparse.Namespace) -> int:
    """Print the bundled scenarios, models, ablations, tasks and world distributions, and with the
    models the model programs installed packages register as entry points."""
    from fg_tea.common.resources import KINDS, bundled, describe

    kinds = args.kind or list(KINDS)
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        raise InputError("<command line>", "list", f"unknown kind {unknown[0]!r}; expected one of "
                         f"{', '.join(KINDS)}")
    if args.paths:
        for kind in kinds:
            folder, suffix, _ = KINDS[kind]
            for path in bundled(folder, suffix):
                print(path)
        return 0
    for i, kind in enumerate(kinds):
        folder, suffix, what = KINDS[kind]
        files = bundled(folder, suffix)
        width = max((len(p.name) - len(suffix) for p in files), default=0)
        print(("\n" if i else "") + f"{kind} ({what}):")
        for path in files:
            description = describe(path)
            if not description and path.suffix == ".toml":  # a model may inherit its description
                from fg_tea.model.spec import load_model

                try:
                    description = load_model(path).description
                except InputError:
                    description = ""
            line = f"  {path.name[: -len(suffix)]:<{width}}  {_first_sentence(description)}".rstrip()
            print(line)
        if kind == "models":
            _print_entry_point_models()
    return 0


def _print_entry_point_models() -> None:
    """The model programs installed packages register (group ``fg_tea.models``), each a name
    ``--model`` takes; a bundled model of the same name wins (docs/design.md §4.8)."""
    from fg_tea.common.resources import MODEL_ENTRY_POINT_GROUP, model_entry_points

    points = sorted(model_entry_points().items())
    if not points:
        return
    print(f"\nmodel programs of installed packages (entry points of group {MODEL_ENTRY_POINT_GROUP}):")
    width = max(len(name) for name, _ in points)
    for name, point in points:
        print(f"  {name:<{width}}  {point.value}")


def _first_sentence(text: str, limit: int = 100) -> str:
    """The first sentence of `text`, cut to `limit` characters with an ellipsis."""
    import re

    first = re.split(r"\.\s+(?=[A-Z])", text)[0]
    return first if len(first) <= limit else first[: limit - 3].rstrip() + "..."


def add_parser(sub: Any) -> None:
    from fg_tea.common.resources import KINDS  # noqa: F811 - for the help text

    p = sub.add_parser("list", help="list the bundled scenarios, models, ablations, tasks and worlds",
                       description="Print every bundled file by kind, with its one-line description, "
                       "and with the models the model programs installed packages register (entry "
                       "points of group fg_tea.models). Every command accepts these names in place of "
                       "a path.")
    p.add_argument("kind", nargs="*", metavar="KIND",  # checked in cmd_list: argparse rejects
                   help=f"kinds to list, among {', '.join(KINDS)} (default: all)")  # an empty list
    p.add_argument("--paths", action="store_true",
                   help="print the path of every bundled file instead, one per line (to copy or "
                   "pass to validate)")
