"""Render the measured numbers of the README and the docs from the committed result files.

Every measured number quoted in ``README.md`` and ``docs/**/*.md`` sits between two HTML comments
(invisible on GitHub and on the documentation site) that say where it comes from::

    <!-- n experiments/results/compare/summary.csv model=joint,planner=efe search_distance_mean .2f -->17.09<!-- /n -->

is the value of column ``search_distance_mean`` in the one row of that CSV whose ``model`` is
``joint`` and ``planner`` is ``efe`` (filters separated by ``;`` instead when a value has a comma), formatted with ``.2f`` (any Python format spec; ``%`` for a
share written as a percentage). A whole table is quoted with a block::

    <!-- table experiments/results/ablations/ablations.md "## Paired differences" -->
    | ... the first markdown table under that heading ... |
    <!-- /table -->

A block may keep only some rows and columns: after the heading, ``COLUMN=VALUE`` keeps the rows
whose cell in that column is VALUE (``A|B`` for either; several columns must all match), and
``columns=A|B`` keeps those columns in that order. A heading nested under another is named as
``"## outer" "### inner"`` (each found after the one before).

An inline marker may also read a cell of a markdown table: FILE is then ``PATH#HEADING[#HEADING]``
(the table under the first heading, or bold line, that starts so, nested headings as above, ``#``
signs not compared),
and ``COLUMN@K`` takes the K-th number written in the cell (``0.883 [0.783, 0.986]``: ``@0`` is
0.883, ``@2`` is 0.986); a number written with a thousands comma or a sign is read as one.

A figure made by an experiment is copied into ``docs/`` under a marker naming both files::

    <!-- figure experiments/results/joint_vs_factorised/houses/houses_heatmap.png figures/jvf_houses.png -->
    ![...](figures/jvf_houses.png)

``python docs/tools/render_numbers.py`` rewrites every marked number and table from the files and copies
every marked figure;
``python docs/tools/render_numbers.py --check`` changes nothing and exits 1, listing each stale place,
when a quoted number differs from its result file (``tests/test_docs_numbers.py`` runs it). A
marker naming a missing file, row or column is an error too. ``--check`` also lists every decimal,
percentage or time written by hand outside a marker (and outside code, comments and headings)
that ``docs/tools/given_numbers.txt`` does not declare a setting, a target or a derived value.
"""

from __future__ import annotations

import argparse
import csv
import re
import shlex
import sys
from functools import lru_cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from fg_tea.common.files import atomic_path, atomic_write_text  # noqa: E402
from fg_tea.common.tables import markdown_table  # noqa: E402
INLINE = re.compile(r"<!-- n (?P<spec>[^>]*?) -->(?P<value>.*?)<!-- /n -->", re.S)
BLOCK = re.compile(r"<!-- table (?P<spec>[^>]*?) -->\n(?P<value>.*?)<!-- /table -->", re.S)
FIGURE = re.compile(r"<!-- figure (?P<source>\S+) (?P<copy>\S+) -->")


class MarkerError(ValueError):
    """A marker that names a missing file, row, column or heading."""


def _table_lines(path: str, headings: list[str]) -> list[str]:
    """The lines of the first markdown table under the (nested) headings of a result file."""
    file = ROOT / path
    if not file.is_file():
        raise MarkerError(f"{path}: no such result file")
    lines = file.read_text(encoding="utf-8").splitlines()
    start = -1
    for heading in headings:
        bare = heading.lstrip("#").strip()
        try:
            start = next(i for i in range(start + 1, len(lines))
                         if lines[i].strip() == heading or (lines[i].startswith(("#", "**")) and lines[i]
                                                             .lstrip("#* ").startswith(bare)))
        except StopIteration:
            raise MarkerError(f"{path}: no heading {heading!r}") from None
    body: list[str] = []
    for line in lines[start + 1:]:
        if line.startswith("|"):
            body.append(line)
        elif body or line.startswith("#"):
            break
    if len(body) < 2:
        raise MarkerError(f"{path}: no table under {headings[-1]!r}")
    return body


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


@lru_cache(maxsize=None)
def _rows(path: str) -> tuple[dict[str, str], ...]:
    """The rows of a CSV file, or of a markdown table named ``FILE#HEADING[#HEADING]``."""
    if "#" in path:
        file, *headings = path.split("#")
        body = _table_lines(file, headings)
        names = _cells(body[0])
        names = [n if n not in names[:i] else f"{n} ({names[:i].count(n) + 1})"
                 for i, n in enumerate(names)]  # a repeated header: "CPU", "CPU (2)"
        return tuple(dict(zip(names, _cells(line))) for line in body[2:])
    file = ROOT / path
    if not file.is_file():
        raise MarkerError(f"{path}: no such result file")
    with file.open(newline="", encoding="utf-8") as fh:
        return tuple(csv.DictReader(fh))


NUMBER = re.compile(r"[-+−]?\d[\d,]*(?:\.\d+)?(?:e[-+]?\d+)?")


def _split_filter(word: str, names: set[str]) -> tuple[str, str]:
    """``COLUMN=VALUE`` split at the first '=' whose left side names a column (names may hold '=')."""
    for i, ch in enumerate(word):
        if ch == "=" and word[:i] in names:
            return word[:i], word[i + 1:]
    return word.split("=", 1)[0], word.split("=", 1)[1]


def number(spec: str) -> str:
    """The text of an inline marker's value: ``FILE FILTER COLUMN FORMAT``."""
    try:
        path, where, column, fmt = shlex.split(spec)
    except ValueError:
        raise MarkerError(f"{spec!r}: expected FILE FILTER COLUMN FORMAT") from None
    sep = ";" if ";" in where else ","  # ';' separates the filters when a value has a comma
    rows = _rows(path)
    names = set(rows[0]) if rows else set()
    wanted = dict(_split_filter(kv, names) for kv in where.split(sep) if "=" in kv) if where != "-" else {}
    found = [r for r in rows if all(r.get(k) == v for k, v in wanted.items())]
    if len(found) != 1:
        raise MarkerError(f"{path}: {len(found)} rows match {where!r} (expected exactly one)")
    column, _, index = column.partition("@")
    if column not in found[0]:
        raise MarkerError(f"{path}: no column {column!r}")
    raw = found[0][column]
    if index:
        written = NUMBER.findall(raw)
        if not index.isdigit() or int(index) >= len(written):
            raise MarkerError(f"{path}: column {column!r} of the row {where!r} is {raw!r}, "
                              f"with no number {index}")
        raw = written[int(index)].replace(",", "").replace("−", "-")
    if fmt == "s":
        return raw
    try:
        value = float(raw)
    except ValueError:
        raise MarkerError(f"{path}: column {column!r} of the row {where!r} is {raw!r}, not a number") from None
    return format(value, fmt)


def table(spec: str) -> str:
    """The text of a table block: the first markdown table under a heading of a result file,
    with the rows and columns its ``COLUMN=VALUE`` and ``columns=`` words keep."""
    try:
        path, *words = shlex.split(spec)
    except ValueError:
        raise MarkerError(f"{spec!r}: expected FILE \"HEADING\" [COLUMN=VALUE ...]") from None
    headings = [w for w in words if w.startswith("#")]
    keep = dict(w.split("=", 1) for w in words if not w.startswith("#") and "=" in w)
    if not headings or len(headings) + len(keep) != len(words):
        raise MarkerError(f"{spec!r}: expected FILE \"HEADING\" [COLUMN=VALUE ...]")
    body = _table_lines(path, headings)
    if not keep:
        return "\n".join(body) + "\n"
    names = _cells(body[0])
    columns = keep.pop("columns", "|".join(names)).split("|")
    for name in [*keep, *columns]:
        if name not in names:
            raise MarkerError(f"{path}: no column {name!r} under {headings[-1]!r}")
    rows = [_cells(line) for line in body[2:]]
    rows = [r for r in rows if all(r[names.index(k)] in v.split("|") for k, v in keep.items())]
    if not rows:
        raise MarkerError(f"{path}: no row under {headings[-1]!r} matches {keep!r}")
    pick = [names.index(c) for c in columns]
    return markdown_table(columns, [[r[i] for i in pick] for r in rows], align="left")


def render(text: str) -> str:
    """`text` with every marked number and table rendered from its file."""
    text = BLOCK.sub(lambda m: f"<!-- table {m.group('spec')} -->\n{table(m.group('spec'))}"
                               "<!-- /table -->", text)
    return INLINE.sub(lambda m: f"<!-- n {m.group('spec')} -->{number(m.group('spec'))}<!-- /n -->", text)


CODE = re.compile(r"```.*?```|`[^`\n]*`|<!--.*?-->|\]\([^)]*\)", re.S)
TYPED = re.compile(r"(?<![\w§.#/:=-])[−-]?\d+(?:,\d{3})*\.\d+(?![\w.])"
                   r"|(?<![\w.])\d+(?:\.\d+)? ?(?:%|ms|µs|s)(?!\w)")
GIVEN = ROOT / "docs" / "tools" / "given_numbers.txt"


def typed(text: str) -> list[str]:
    """The numbers of `text` written by hand: decimals, percentages and times outside markers,
    code, comments, link targets and headings."""
    text = INLINE.sub(" ", BLOCK.sub(" ", text))
    text = CODE.sub(" ", text)
    lines = [line for line in text.splitlines() if not line.lstrip().startswith("#")]
    return [m.group(0).replace("−", "-") for m in TYPED.finditer("\n".join(lines))]


def given() -> dict[str, set[str]]:
    """The hand-written numbers each document may hold (docs/tools/given_numbers.txt)."""
    out: dict[str, set[str]] = {}
    for line in GIVEN.read_text(encoding="utf-8").splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            doc, _, numbers = line.partition(":")
            out.setdefault(doc.strip(), set()).update(numbers.split())
    return out


def unexplained() -> list[str]:
    """One line per hand-written number that is neither marked nor declared a setting."""
    allowed = given()
    out = []
    for doc in documents():
        name = str(doc.relative_to(ROOT))
        extra = sorted(set(n.replace(" ", "") for n in typed(doc.read_text(encoding="utf-8")))
                       - allowed.get(name, set()))
        if extra:
            out.append(f"{name}: {' '.join(extra)}")
    return out


def figures(doc: Path, text: str) -> list[tuple[Path, Path]]:
    """(result file, its copy under docs/) for every figure marker of `doc`."""
    out = []
    for m in FIGURE.finditer(text):
        source = ROOT / m.group("source")
        if not source.is_file():
            raise MarkerError(f"{m.group('source')}: no such result file")
        out.append((source, doc.parent / m.group("copy")))
    return out


def documents() -> list[Path]:
    """The README and every page of the docs."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def stale() -> list[str]:
    """One line per document whose marked numbers differ from the result files."""
    out = []
    for doc in documents():
        text = doc.read_text(encoding="utf-8")
        new = render(text)
        if new != text:
            changed = [f"{a.group('spec')}: {a.group('value')!r} -> {b.group('value')!r}"
                       for a, b in zip(INLINE.finditer(text), INLINE.finditer(new))
                       if a.group("value") != b.group("value")]
            tables = sum(a.group("value") != b.group("value")
                         for a, b in zip(BLOCK.finditer(text), BLOCK.finditer(new)))
            out.append(f"{doc.relative_to(ROOT)}: " + "; ".join(changed[:5] + ([f"{tables} table(s)"]
                                                                               if tables else [])))
        for source, copy in figures(doc, text):
            if not copy.is_file() or copy.read_bytes() != source.read_bytes():
                out.append(f"{doc.relative_to(ROOT)}: figure {copy.relative_to(ROOT)} is not "
                           f"{source.relative_to(ROOT)}")
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="render_numbers.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--check", action="store_true", help="change nothing; exit 1 if a number is stale")
    args = p.parse_args(argv)
    try:
        if args.check:
            problems = stale()
            for line in problems:
                print(f"stale: {line}")
            typed_by_hand = unexplained()
            for line in typed_by_hand:
                print(f"typed by hand: {line} (render it with a marker, or declare it in "
                      f"docs/tools/given_numbers.txt if it is not measured)")
            problems += typed_by_hand
            return 1 if problems else 0
        for doc in documents():
            text = doc.read_text(encoding="utf-8")
            new = render(text)
            if new != text:
                atomic_write_text(doc, new)
                print(f"rendered: {doc.relative_to(ROOT)}")
            for source, copy in figures(doc, new):
                if not copy.is_file() or copy.read_bytes() != source.read_bytes():
                    copy.parent.mkdir(parents=True, exist_ok=True)
                    with atomic_path(copy) as tmp:
                        tmp.write_bytes(source.read_bytes())
                    print(f"copied: {copy.relative_to(ROOT)}")
    except MarkerError as exc:
        print(f"render_numbers.py: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
