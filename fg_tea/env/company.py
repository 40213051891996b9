"""The company table's layout, shared by every environment (docs/design.md §3.4, "Facing and
company"): the heading offsets a look may end at, the category pairs, and the table of a camera
in which nothing depends on the heading or hides anything."""

from __future__ import annotations

from typing import Mapping, Sequence

#: Heading offsets of the company table, as fractions of the face tolerance: the midpoints of four
#: equal bins of [-1, 1]. A look ends anywhere within the tolerance of facing its site.
FACING_FRACTIONS = (-0.75, -0.25, 0.25, 0.75)


def facing_offsets(tolerance_deg: float) -> list[float]:
    """The heading offsets (degrees) of the company table for a face tolerance."""
    return [f * float(tolerance_deg) for f in FACING_FRACTIONS]


def category_pairs(categories: Sequence[str]) -> list[tuple[str, str]]:
    """Ordered pairs (c, c2) of the company table: every two different categories, and a category
    with itself where `categories` names it more than once."""
    unique = list(dict.fromkeys(categories))
    return [(c, c2) for c in unique for c2 in unique
            if c != c2 or list(categories).count(c) > 1]


def company_from_alone(alone: Mapping[str, Sequence[float]], categories: Sequence[str],
                       headings: int) -> dict[str, dict[str, list]]:
    """One site's company entry for a camera without heading dependence or occlusion: every
    heading and every companion leaves the alone count (`alone`: category -> count per slot)."""
    facing = {c: [[float(n)] * headings for n in slots] for c, slots in alone.items()}
    company = {f"{c}|{c2}": [[None if s == s2 else float(n) for s2 in range(len(alone[c2]))]
                             for s, n in enumerate(alone[c])]
               for c, c2 in category_pairs(categories)}
    return {"facing": facing, "company": company}
