"""Render the measured numbers of the README and the docs from the committed result files.

Every measured number quoted in ``README.md`` and ``docs/**/*.md`` sits between two HTML comments
(invisible on GitHub and on the documentation site) that say where it comes from::

    <!-- n experiments/results/compare/summary.csv model=joint,planner=efe search_distance_mean .2f -->17.09<!-- /n -->

is the value of column ``search_distance_mean`` in the one row of that CSV whose ``model`` is
``joint`` and ``planner`` is ``efe``, formatted with ``.2f`` (any Python format spec; ``%`` for a
share written as a percentage). A whole table is quoted with a block::

    <!-- table experiments/results/ablations/ablations.md "## Paired differences" -->
    | ... the first markdown table under that heading ... |
    <!-- /table -->

A figure made by an experiment is copied into ``docs/`` under a marker naming both files::

    <!-- figure experiments/results/joint_vs_factorised/houses/houses_heatmap.png figures/jvf_houses.png -->
    ![...](figures/jvf_houses.png)

``python docs/tools/render_numbers.py`` rewrites every marked number and table from the files and copies
every marked figure;
``python docs/tools/render_numbers.py --check`` changes nothing and exits 1, listing each stale place,
when a quoted number differs from its result file (``tests/test_docs_numbers.py`` runs it). A
marker naming a missing file, row or column is an error too.
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
INLINE = re.compile(r"<!-- n (?P<spec>[^>]*?) -->(?P<value>.*?)<!-- /n -->", re.S)
BLOCK = re.compile(r"<!-- table (?P<spec>[^>]*?) -->\n(?P<value>.*?)<!-- /table -->", re.S)
FIGURE = re.compile(r"<!-- figure (?P<source>\S+) (?P<copy>\S+) -->")


class MarkerError(ValueError):
    """A marker that names a missing file, row, column or heading."""


@lru_cache(maxsize=None)
def _rows(path: str) -> tuple[dict[str, str], ...]:
    file = ROOT / path
    if not file.is_file():
        raise MarkerError(f"{path}: no such result file")
    with file.open(newline="", encoding="utf-8") as fh:
        return tuple(csv.DictReader(fh))


def number(spec: str) -> str:
    """The text of an inline marker's value: ``FILE FILTER COLUMN FORMAT``."""
    try:
        path, where, column, fmt = shlex.split(spec)
    except ValueError:
        raise MarkerError(f"{spec!r}: expected FILE FILTER COLUMN FORMAT") from None
    wanted = dict(kv.split("=", 1) for kv in where.split(",") if "=" in kv) if where != "-" else {}
    found = [r for r in _rows(path) if all(r.get(k) == v for k, v in wanted.items())]
    if len(found) != 1:
        raise MarkerError(f"{path}: {len(found)} rows match {where!r} (expected exactly one)")
    if column not in found[0]:
        raise MarkerError(f"{path}: no column {column!r}")
    raw = found[0][column]
    if fmt == "s":
        return raw
    try:
        value = float(raw)
    except ValueError:
        raise MarkerError(f"{path}: column {column!r} of the row {where!r} is {raw!r}, not a number") from None
    return format(value, fmt)


def table(spec: str) -> str:
    """The text of a table block: the first markdown table under a heading of a result file."""
    try:
        path, heading = shlex.split(spec)
    except ValueError:
        raise MarkerError(f"{spec!r}: expected FILE \"HEADING\"") from None
    file = ROOT / path
    if not file.is_file():
        raise MarkerError(f"{path}: no such result file")
    lines = file.read_text(encoding="utf-8").splitlines()
    try:
        start = next(i for i, line in enumerate(lines) if line.strip() == heading)
    except StopIteration:
        raise MarkerError(f"{path}: no heading {heading!r}") from None
    body: list[str] = []
    for line in lines[start + 1:]:
        if line.startswith("|"):
            body.append(line)
        elif body or line.startswith("#"):
            break
    if not body:
        raise MarkerError(f"{path}: no table under {heading!r}")
    return "\n".join(body) + "\n"


def render(text: str) -> str:
    """`text` with every marked number and table rendered from its file."""
    text = BLOCK.sub(lambda m: f"<!-- table {m.group('spec')} -->\n{table(m.group('spec'))}"
                               "<!-- /table -->", text)
    return INLINE.sub(lambda m: f"<!-- n {m.group('spec')} -->{number(m.group('spec'))}<!-- /n -->", text)


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
