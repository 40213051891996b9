"""Sweep rows on disk: one CSV line per episode, appended as episodes finish, read back typed.

A crash mid-write leaves at most a partial last line, which the reader skips and the next append
replaces; the final file is rewritten sorted by key, atomically. Progress lines go to stderr.
"""

from __future__ import annotations

import csv
import io
import math
import sys
from pathlib import Path
from typing import Any, Mapping, Sequence

from fg_tea.common.errors import InputError
from fg_tea.common.files import atomic_path


# ---------------------------------------------------------------------------------- the CSV
def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(value)
    return " ".join(str(value).split()) if isinstance(value, str) else str(value)


def parse_cell(text: str) -> Any:
    """A CSV cell back to Python: '' -> None, True/False -> bool, numbers -> int/float, else str."""
    if text == "":
        return None
    if text in ("True", "False"):
        return text == "True"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def read_good_lines(path: Path) -> tuple[list[str], list[list[str]], int]:
    """Header, complete rows, and the byte length of the valid prefix of a sweep CSV.

    A last line without its newline (a crash mid-write) and any row with the wrong number of
    fields are dropped.

    Raises:
        InputError: the file is not UTF-8 text (naming the line).
    """
    data = path.read_bytes()
    if b"\n" not in data:
        return [], [], 0
    good = data if data.endswith(b"\n") else data.rsplit(b"\n", 1)[0] + b"\n"
    try:
        text = good.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = good[:exc.start].count(b"\n") + 1
        raise InputError(path, f"line {line}", f"not UTF-8 text (byte 0x{good[exc.start]:02x} at "
                         f"offset {exc.start}), so not a sweep CSV fg_tea wrote; choose another "
                         "output or do not resume") from None
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        header = next(reader)
    except StopIteration:
        return [], [], 0
    rows = [r for r in reader if len(r) == len(header)]
    return header, rows, len(good)


def read_rows(path: str | Path) -> list[dict[str, Any]]:
    """The rows of a sweep CSV, typed with :func:`parse_cell` (a truncated last line is ignored).

    Raises:
        InputError: the file does not exist or has no ``key`` column.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(path, "$", "file not found")
    header, rows, _ = read_good_lines(path)
    if header and "key" not in header:
        raise InputError(path, "header", "not a sweep CSV (no 'key' column)")
    return [{h: parse_cell(v) for h, v in zip(header, r)} for r in rows]


def _header(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """Columns in the order of the row with the smallest key (else the first row), then others sorted."""
    if not rows:
        return []
    first = min(rows, key=lambda r: str(r["key"])) if all("key" in r for r in rows) else rows[0]
    header = list(first)
    extra = sorted({c for r in rows for c in r} - set(header))
    return header + extra


def write_csv_atomic(path: str | Path, rows: Sequence[Mapping[str, Any]],
                     header: Sequence[str] | None = None) -> Path:
    """Write rows to a CSV through a temporary file and a rename (all or nothing)."""
    path = Path(path)
    header = list(header) if header is not None else _header(rows)
    with atomic_path(path) as tmp, tmp.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(header)
        for row in rows:
            writer.writerow([_cell(row.get(c)) for c in header])
    return path


#: The column whose value says a row holds a finished episode (True or False; sweep rows always
#: have it, docs/design.md §11): a row without it (empty, NaN) is not a result.
FINISHED_COLUMN = "success"


def finished(row: Mapping[str, str]) -> bool:
    """Whether a CSV row (cells as text) holds a finished episode: its ``success`` is True/False."""
    return row.get(FINISHED_COLUMN) in ("True", "False")


class CsvSink:
    """A sweep CSV that grows one flushed row at a time and can be resumed.

    Args:
        path: the CSV file.
        resume: keep the rows already in `path` (their keys count as done); otherwise start empty.
            In a CSV with a ``success`` column (a sweep's), rows that hold no finished episode
            (:func:`finished`: every cell NaN or empty, say) are dropped from the file at once,
            said so on `stream`, and so run again.
        stream: where that note goes (default: stderr).

    Rows are kept in memory as strings keyed by ``key``; :meth:`finalize` rewrites the file sorted
    by key. If a new row brings columns the file's header lacks, the file is rewritten with the
    union of columns before appending.
    """

    def __init__(self, path: str | Path, resume: bool = True, stream=None) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.rows: dict[str, dict[str, str]] = {}
        self.header: list[str] = []
        #: Keys of rows found without a finished episode (dropped, so run again).
        self.unfinished: list[str] = []
        if resume and self.path.exists():
            header, rows, valid = read_good_lines(self.path)
            if header and "key" not in header:
                raise InputError(self.path, "header", "not a sweep CSV (no 'key' column); "
                                 "choose another output or do not resume")
            self.header = header
            for r in rows:
                row = dict(zip(header, r))
                self.rows[row["key"]] = row
            if FINISHED_COLUMN in header:  # a sweep's episodes (other keyed CSVs: every row)
                self.unfinished = [k for k, row in self.rows.items() if not finished(row)]
            if self.unfinished:  # never a result: rewritten without them, and run again
                for key in self.unfinished:
                    del self.rows[key]
                write_csv_atomic(self.path, list(self.rows.values()), self.header)
                n = len(self.unfinished)
                (stream if stream is not None else sys.stderr).write(
                    f"{n} row{'s' * (n != 1)} of {self.path} hold{'s' * (n == 1)} no finished episode "
                    f"({FINISHED_COLUMN} is neither True nor False; first key {self.unfinished[0]}): "
                    "removed, and run again\n")
            elif valid != self.path.stat().st_size:  # drop a truncated last line before appending
                with self.path.open("r+b") as fh:
                    fh.truncate(valid)
        elif self.path.exists():
            self.path.unlink()
        self.resumed = len(self.rows)
        self._fh: io.TextIOWrapper | None = None

    def done(self, key: str) -> bool:
        return key in self.rows

    def write(self, row: Mapping[str, Any]) -> None:
        """Append one row (flushed to disk)."""
        cells = {k: _cell(v) for k, v in row.items()}
        self.rows[cells["key"]] = cells
        if not self.header or set(cells) - set(self.header):
            self._close()
            self.header = _header(list(self.rows.values()))
            write_csv_atomic(self.path, list(self.rows.values()), self.header)
            return
        if self._fh is None:
            self._fh = self.path.open("a", newline="", encoding="utf-8")
        csv.writer(self._fh, lineterminator="\n").writerow([cells.get(c, "") for c in self.header])
        self._fh.flush()

    def _close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def finalize(self) -> Path:
        """Rewrite the CSV sorted by key (atomically); return its path."""
        self._close()
        rows = [self.rows[k] for k in sorted(self.rows)]
        return write_csv_atomic(self.path, rows, _header(rows) if rows else self.header)


# ---------------------------------------------------------------------------------- progress
def sweep_progress(total: int, resumed: int = 0, stream=None, every: float = 10.0, label: str = "sweep"):
    """Sweep progress on stderr: done/total episodes, rate, elapsed time and ETA
    (:func:`fg_tea.common.progress.progress`: redrawn on a terminal, a line every `every`
    seconds elsewhere)."""
    from fg_tea.common.progress import progress

    return progress(total, label, "episodes", initial=resumed, stream=stream, every=every,
                    note=f"({resumed} resumed)" if resumed else "")


__all__ = ["CsvSink", "sweep_progress", "read_rows", "parse_cell", "write_csv_atomic", "finished",
           "FINISHED_COLUMN"]
