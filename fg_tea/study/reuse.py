"""Rows of another sweep CSV copied instead of run (``compare_at_scale.py --reuse``; docs/results.md).

A row's ``key`` names its job completely (:attr:`fg_tea.study.sweep.Job.key`), but it names a
world, model or camera *file* by the path the run was given. The detectability and related tables
write their files under ``--out`` (``OUT/TABLE/models/joint_n50_25.toml``), so the same job run
into another folder has another key. Here a row stands for a job of this run when its key is the
job's key, or when it differs from it only in such paths and each of them names a file of the
same name with the same bytes (sha256) as the job's file. The row's file is looked for at the path
its key gives and beside the CSV (``<the CSV's folder>/models/joint_n50_25.toml``), so a table
folder still matches after it was moved or committed; found at both with different bytes, it
stands for nothing. Every other part of the key (world seed, knobs, planner, episode seed, ...)
must be equal, as text.

Keys on disk are never rewritten, so committed CSVs stay as they are: a copied row takes the key
and ``model_ref`` of the job it stands for, the only cells that name a path, and so is the row
that job would write. Every row not copied is counted under one reason, one stderr line per
reason, and the jobs left to run are counted too: nothing asked for is run again silently.
"""

from __future__ import annotations

import csv
import hashlib
import sys
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

from fg_tea.common.errors import InputError
from fg_tea.study.rows import write_csv_atomic
from fg_tea.study.sweep import Job

#: Key parts in the order :attr:`Job.key` writes them, with the words a reason uses for them.
PARTS = {"world": "world", "ws": "world seed", "knobs": "world knobs", "model": "model",
         "mo": "model overrides", "planner": "planner", "seed": "episode seed", "env": "environment",
         "camera": "camera", "eo": "environment overrides", "frames": "frame limit",
         "steps": "step limit", "task": "task"}
#: Key parts that may name a file.
FILE_PARTS = ("world", "model", "camera")


def key_parts(key: str) -> dict[str, str] | None:
    """A key's ``name=value`` parts, in order (None: not a job key). ``"|".join`` of them again
    (:func:`joined`) gives the key back."""
    try:
        return dict(part.split("=", 1) for part in key.split("|"))
    except ValueError:
        return None


def joined(parts: dict[str, str]) -> str:
    return "|".join(f"{name}={value}" for name, value in parts.items())


def is_file(value: str) -> bool:
    """Whether a world, model or camera reference is a path (else a bundled name)."""
    return "/" in value or "\\" in value or value.endswith((".toml", ".json"))


def digest(path: Path) -> str:
    """The sha256 of a file's bytes."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


@dataclass
class Reuse:
    """What a CSV holds for a job list: the rows that stand for its jobs, and why the rest do not.

    Attributes:
        source: the CSV read.
        rows: per job key, the row that stands for it (with the job's key and ``model_ref``).
        keys: every row's key as this run would spell it (for
            :func:`fg_tea.study.seeds.check_episode_seeds`).
        total: rows read.
        reasons: per reason (kind, key part), its count, up to three examples and whether there are
            more.
    """

    source: Path
    rows: dict[str, dict[str, str]] = field(default_factory=dict)
    keys: list[str] = field(default_factory=list)
    total: int = 0
    reasons: dict[tuple[str, str], list] = field(default_factory=dict)

    def note(self, reason: tuple[str, str], example: str) -> None:
        entry = self.reasons.setdefault(reason, [0, [], False])  # count, examples, more of them
        entry[0] += 1
        if example not in entry[1]:
            if len(entry[1]) < 3:
                entry[1].append(example)
            else:
                entry[2] = True


class _Files:
    """Where a key's files are and what bytes they hold (each file read once)."""

    def __init__(self, source: Path) -> None:
        self.folder = source.parent
        self._digests: dict[Path, str] = {}

    def digest(self, path: Path) -> str:
        path = path.resolve()
        if path not in self._digests:
            self._digests[path] = digest(path)
        return self._digests[path]

    def of_row(self, ref: str) -> tuple[str | None, str]:
        """(digest, "") of the file a row's key names, or (None, fault: missing or ambiguous)."""
        path = Path(ref)
        found = {p.resolve() for p in (self.folder / path.parent.name / path.name, path) if p.is_file()}
        digests = {self.digest(p) for p in found}
        if not digests:
            return None, "missing"
        return (digests.pop(), "") if len(digests) == 1 else (None, "ambiguous")


def match(source: str | Path, jobs: Sequence[Job]) -> Reuse:
    """The rows of `source` that stand for `jobs` (see the module doc), and why the others do not.

    Raises:
        InputError: `source` is not a readable sweep CSV.
    """
    source = Path(source)
    by_key = {job.key: job for job in jobs}
    values: dict[str, set] = defaultdict(set)        # part -> every job's value (None: absent)
    ours: dict[tuple[str, str], dict[str, str]] = defaultdict(dict)  # (part, file name) -> digest -> path
    files = _Files(source)
    for key in by_key:
        parts = key_parts(key) or {}
        for name in {*PARTS, *parts}:
            values[name].add(parts.get(name))
        for name in FILE_PARTS:
            ref = parts.get(name)
            if ref and is_file(ref) and Path(ref).is_file():
                ours[(name, Path(ref).name)][files.digest(Path(ref))] = ref
    found = Reuse(source)
    try:
        with source.open(newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            if not reader.fieldnames or "key" not in reader.fieldnames:
                raise InputError(source, "key", "not an episodes CSV written by a sweep")
            for row in reader:
                found.total += 1
                _match_row(row, found, by_key, values, ours, files)
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise InputError(source, "$", f"cannot read: {getattr(exc, 'strerror', None) or exc}") from None
    return found


def _match_row(row: dict, found: Reuse, by_key: dict[str, Job], values: dict[str, set],
               ours: dict[tuple[str, str], dict[str, str]], files: _Files) -> None:
    key = str(row.get("key"))
    parts = key_parts(key) if isinstance(row.get("key"), str) else None
    if parts is None or None in row.values() or None in row:
        found.note(("broken", ""), key)
        return
    faults: dict[str, tuple[str, str]] = {}
    for name in FILE_PARTS:
        ref = parts.get(name, "")
        targets = ours.get((name, Path(ref).name)) if ref and is_file(ref) else None
        if not targets or ref in targets.values():
            continue  # a bundled name, a file this run has none of that name, or this run's own path
        sha, fault = files.of_row(ref)
        if sha is not None and sha in targets:
            parts[name] = targets[sha]
        elif fault:
            faults[name] = (fault, ref)
        else:
            faults[name] = ("content", f"{ref} (this run: {', '.join(sorted(targets.values()))})")
    spelt = joined(parts)
    found.keys.append(spelt)
    job = by_key.get(spelt)
    if job is not None:
        if spelt in found.rows:
            found.note(("duplicate", ""), key)
            return
        found.rows[spelt] = {**row, "key": spelt, **({"model_ref": job.model} if "model_ref" in row else {})}
        return
    for name in [*PARTS, *(p for p in parts if p not in PARTS)]:
        if name in faults:
            found.note((faults[name][0], name), faults[name][1])
            return
        if parts.get(name) not in values[name]:
            found.note(("differ", name), parts.get(name, "(none)"))
            return
    found.note(("combination", ""), key)


def _examples(values: Sequence[str], limit: int = 3, more: bool = False) -> str:
    return ", ".join(list(values)[:limit]) + (", …" if more or len(values) > limit else "")


def reason_lines(found: Reuse, values_here: dict[str, list[str]] | None = None) -> list[str]:
    """One line per reason a row of `found.source` was not copied, with its count and examples."""
    phrases = {
        "missing": "their {what} files are found neither at their keys' paths nor beside the CSV, so "
                   "their content cannot be checked: {ex}",
        "ambiguous": "their {what} files beside the CSV differ from the files at their keys' paths: {ex}",
        "content": "their {what} files' content differs from this run's: {ex}",
        "duplicate": "the same job as an earlier row: {ex}",
        "combination": "no job of this run (each part of the key occurs in some job, not together): {one}",
        "broken": "not a complete row with a job key: {one}"}
    lines = []
    for (kind, part), (count, examples, more) in sorted(found.reasons.items(), key=lambda r: -r[1][0]):
        what = PARTS.get(part, part)
        head = f"reuse: {count} of {found.total} rows of {found.source} not copied: "
        if kind == "differ":
            here = (values_here or {}).get(part)
            lines.append(f"{head}{what} not this run's: {_examples(examples, more=more)}"
                         + (f" (this run: {_examples(here)})" if here else ""))
        else:
            lines.append(head + phrases[kind].format(what=what, ex=_examples(examples, more=more),
                                                     one=_examples(examples, 1)))
    return lines


def copy_rows(found: Reuse, jobs: Sequence[Job], csv_path: str | Path, resume: bool) -> int:
    """Copy into `csv_path` the rows `found` holds for jobs not yet there; report on stderr what
    was copied, why every other row was not, and how many jobs are left to run. Columns the two
    files do not share are merged as a sweep merges them (empty where a row has none).

    Returns:
        The number of rows copied.
    """
    csv_path = Path(csv_path)
    have: list[dict] = []
    header: list[str] = []
    if resume and csv_path.exists():
        with csv_path.open(newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            header = list(reader.fieldnames or [])
            have = [row for row in reader if None not in row.values()]
    done = {row["key"] for row in have}
    new = [row for key, row in found.rows.items() if key not in done]
    if new:
        columns = header + [c for c in new[0] if c not in header]
        write_csv_atomic(csv_path, have + new, columns)
    already = len(found.rows) - len(new)
    print(f"reused {len(new)} rows of {found.source}: {len(found.rows)} of its {found.total} rows are "
          f"jobs of this run" + (f", {already} of them already in {csv_path}" if already else ""),
          file=sys.stderr)
    keys = [job.key for job in jobs]
    here: dict[str, list[str]] = {}
    for key in dict.fromkeys(keys):
        for name, value in (key_parts(key) or {}).items():
            if value not in here.setdefault(name, []):
                here[name].append(value)
    for line in reason_lines(found, {k: sorted(v) for k, v in here.items()}):
        print(line, file=sys.stderr)
    left = len(set(keys) - done - set(found.rows))
    if left:
        print(f"reuse: {left} of this run's {len(set(keys))} jobs are in neither {found.source} nor "
              f"{csv_path}: they run now", file=sys.stderr)
    return len(new)


__all__ = ["FILE_PARTS", "PARTS", "Reuse", "copy_rows", "digest", "is_file", "joined", "key_parts",
           "match", "reason_lines"]
