"""The one markdown table writer of the package and of experiments/ (docs/how-to/new-experiment.md).

Every table a report, a summary or an experiment's result file shows is written here, so every
table has the same form: a header row, a separator row, one row per record, each row ``| a | b |``
(cells joined by `` | ``, no padding), the separator ``|---|---:|`` (``---:`` right-aligns a column).
The docs read numbers back out of the committed tables (docs/tools/render_numbers.py), so the form is
fixed byte for byte.

Not tabulate: its markdown formats pad every cell to its column's width (``| x      |``,
``|--------|``), and the committed tables are unpadded.
"""

from __future__ import annotations

from typing import Any, Iterable, Sequence

#: Separator cell of each alignment letter: ``l`` the default (left) alignment, ``r`` right.
SEPARATORS = {"l": "---", "r": "---:"}


def _looks_numeric(value: Any) -> bool:
    """Whether a cell reads as a number (its first word parses as a float: ``1.5 [1.2, 1.8]`` does)."""
    if isinstance(value, (int, float)):
        return True
    try:
        float(str(value).split(" ")[0])
        return True
    except ValueError:
        return False


def table_lines(header: Sequence[str], rows: Iterable[Sequence[Any]], align: str = "auto",
                formats: Sequence[str] | None = None) -> list[str]:
    """The lines of a markdown table (no line ends): the header, the separator, one line per row.

    Args:
        header: the column names.
        rows: one sequence of cells per row, as many as `header` has. A cell is written as
            ``format(cell, spec)`` with its column's spec from `formats` (``str(cell)`` when there is
            none); a string cell is written as it is, so a row may carry ``"–"`` in a number column.
            A ``|`` inside a cell is escaped (``\\|``), so it stays one cell.
        align: ``"auto"``: a column whose every cell reads as a number is right-aligned (``---:``),
            the others not (``---``); ``"left"``: no column right-aligned; otherwise one letter per
            column, ``l`` (``---``) or ``r`` (``---:``), such as ``"llrr"``.
        formats: one format spec per column (``".3f"``, ``","``, ``""`` for none), or None.

    Raises:
        ValueError: a row, `align` or `formats` whose length is not the header's, or an unknown
            alignment letter.
    """
    width = len(header)
    body = [list(row) for row in rows]
    for i, row in enumerate(body):
        if len(row) != width:
            raise ValueError(f"markdown table: row {i} has {len(row)} cells, the header {width} ({list(header)})")
    if formats is not None:
        if len(formats) != width:
            raise ValueError(f"markdown table: {len(formats)} formats for {width} columns")
        body = [[c if isinstance(c, str) else format(c, spec) for c, spec in zip(row, formats)] for row in body]
    if align == "auto":
        letters = "".join("r" if body and all(_looks_numeric(r[i]) for r in body) else "l" for i in range(width))
    elif align == "left":
        letters = "l" * width
    else:
        letters = align
    if len(letters) != width or set(letters) - set(SEPARATORS):
        raise ValueError(f"markdown table: align {align!r} is not 'auto', 'left' or one letter l/r per column "
                         f"({width} columns)")

    def line(cells: Sequence[Any]) -> str:
        return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"

    return ([line(header), "|" + "|".join(SEPARATORS[a] for a in letters) + "|"]
            + [line(row) for row in body])


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[Any]], align: str = "auto",
                   formats: Sequence[str] | None = None) -> str:
    """:func:`table_lines` as one text, each line ended by a newline."""
    return "\n".join(table_lines(header, rows, align, formats)) + "\n"


__all__ = ["SEPARATORS", "markdown_table", "table_lines"]
