"""The built-in planners' names, for help texts, without importing the planners (docs/design.md §6).

Building the command line's parser must not load numpy or the planners (``fg-tea --help`` stays
instant, tests/test_flag_ranges.py), so the names a user may type live here as data.
:mod:`fg_tea.planning` builds each of them, and tests/test_limit_honest.py checks that this list
and its registry name the same planners.
"""

from __future__ import annotations

#: The planners named without settings, in the registry's order.
PLAIN = ("efe", "factorised_efe", "mi_efe", "nearest", "greedy", "random", "optimal", "lookahead", "exact",
         "near_exact")
#: The planner families whose names take settings after a colon, and how the settings are written.
FAMILY_FORMS = {"lookahead": "lookahead:depth=2,width=3,...", "exact": "exact:cap=N",
                "near_exact": "near_exact:cap=N,budget=E,restrict=R",
                "pouct": "pouct:N", "pomcp": "pomcp:N"}


def planner_help() -> str:
    """The built-in planners for a ``--planner`` help text: the plain names, then each family's
    settings form."""
    return (f"{', '.join(PLAIN)}, or a family with settings: {', '.join(FAMILY_FORMS.values())} "
            "(pouct and pomcp with the [peers] extra)")
