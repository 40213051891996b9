"""Provenance: which inputs, code and libraries made this log?

An episode log must say what produced it without tying it to one machine, so that two checkouts
of the same commit write byte-identical logs (docs/design.md §9, "Provenance"):

- **input files** are named portably: a bundled file by its bundled name (``default_apartment``)
  and its path inside the bundle (``scenarios/default_apartment.json``), never by where the bundle
  happens to sit; a user's file as the user gave it (``my/house.json`` stays relative). Every
  file carries the sha256 of its bytes, so a log can be matched to the exact inputs;
- **library versions** come from the installed distributions' metadata (nothing is imported);
- **the git commit** is recorded when fg_tea runs from a git checkout (the package folder's
  parent is the top of a work tree), with ``dirty`` true when tracked files differ from it.

Two checkouts at the same commit give the same bytes; logs written at different commits differ
in ``git.commit`` (and, across releases, ``versions.fg_tea``) as they should. To compare the
behaviour of two commits, compare the events after ``episode_start``, or drop its ``git`` field
(:func:`without_git`).
"""

from __future__ import annotations

import hashlib
import os
import platform
import subprocess
from functools import lru_cache
from importlib import metadata
from pathlib import Path
from typing import Any, Mapping, Sequence

#: Distributions whose versions every log records (besides fg_tea itself and Python).
LIBRARIES = ("gtsam", "pybullet", "numpy", "scipy", "networkx")
#: The bundle's top-level folders; every bundled file lies in one of them.
BUNDLE_KINDS = ("scenarios", "models", "cameras")
_CHUNK = 1 << 20


def sha256_file(path: str | Path) -> str | None:
    """The sha256 (hex) of a file's bytes, or None when it cannot be read."""
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            while chunk := fh.read(_CHUNK):
                digest.update(chunk)
    except (OSError, ValueError):
        return None
    return digest.hexdigest()


def _stat_key(path: str | Path) -> tuple | None:
    """What identifies a file's version cheaply (for the caches below), or None if missing."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)


@lru_cache(maxsize=1)
def _bundle_dirs() -> tuple[tuple[str, Path], ...]:
    from fg_tea.common.resources import data_dir

    out = []
    for kind in BUNDLE_KINDS:
        try:
            out.append((kind, data_dir(kind).resolve()))
        except (FileNotFoundError, OSError):
            continue
    return tuple(out)


def bundled_path(path: str | Path) -> str | None:
    """The path of `path` inside the bundle (``models/ablations/no_epistemic.toml``), or None."""
    try:
        resolved = Path(path).resolve()
    except (OSError, RuntimeError):
        return None
    for kind, folder in _bundle_dirs():
        try:
            rest = resolved.relative_to(folder)
        except ValueError:
            continue
        return (Path(kind) / rest).as_posix()
    return None


def bundled_file(ref: str) -> Path | None:
    """The file a bundle-relative path (as :func:`bundled_path` writes it) names, if it exists."""
    from fg_tea.common.resources import data_dir

    parts = Path(ref).parts
    if len(parts) < 2 or parts[0] not in BUNDLE_KINDS or ".." in parts:
        return None
    try:
        candidate = data_dir(parts[0]).joinpath(*parts[1:])
    except FileNotFoundError:
        return None
    return candidate if candidate.is_file() else None


def describe_file(path: str | Path) -> dict[str, Any]:
    """A portable record of one input file.

    Args:
        path: the file as the program opened it (a resolved bundled path, or the user's path).

    Returns:
        ``{"file", "bundled", "sha256"}``: ``file`` is the bundled name for a bundled file (the
        stem, e.g. ``factorised``), else the path as given; ``bundled`` is the path inside the
        bundle, or None for a user's file; ``sha256`` of the bytes (None if unreadable).
    """
    # Sweeps start thousands of episodes from the same few files: hash each version once.
    return dict(_describe(str(path), _stat_key(path)))


@lru_cache(maxsize=256)
def _describe(path: str, version: tuple | None) -> dict[str, Any]:
    inside = bundled_path(path)
    if inside is not None:
        return {"file": Path(inside).stem, "bundled": inside, "sha256": sha256_file(path)}
    return {"file": str(path), "bundled": None, "sha256": sha256_file(path)}


def portable_ref(path: str | Path | None) -> str | None:
    """How a log names a file: its bundled name when bundled, else the path as given."""
    if path is None:
        return None
    return describe_file(path)["file"]


def program_record(scenario: Any, model: Any) -> dict[str, Any] | None:
    """The log's record of a program model (``episode_start``'s ``program``, docs/design.md §4.8):
    its reference, file (named as :func:`portable_ref` names files), sha256, base model and every
    factor with its scope; None for TOML models."""
    from fg_tea.model.program_file import program_for

    program = program_for(scenario, model)
    if program is None:
        return None
    source = model.program
    file = portable_ref(source.file) if source.spec.endswith(".py") else source.file
    learned = {"learned_from": source.learned_from} if source.learned_from else {}
    return {"spec": source.spec, "file": file, "sha256": source.sha256, **learned,
            "base": source.base,
            "factors": [{"name": f.name, "scope": list(f.scope)} for f in program.factors]}


_CHAINS: dict[str, tuple[list[Path], list[tuple | None]]] = {}


def model_chain(path: str | Path) -> list[Path]:
    """The model file and every file its ``extends`` chain reads, child first.

    The chain is walked as :func:`fg_tea.model.spec.load_model` walks it; a model that loaded has a
    valid chain, so faults here only mean the files changed in between (the walk then stops).
    A chain is walked again only when one of its files changed.
    """
    cached = _CHAINS.get(str(path))
    if cached is not None and [_stat_key(p) for p in cached[0]] == cached[1]:
        return list(cached[0])
    chain = _walk_chain(path)
    _CHAINS[str(path)] = (chain, [_stat_key(p) for p in chain])
    return list(chain)


def _walk_chain(path: str | Path) -> list[Path]:
    from fg_tea.common.inputs import read_toml
    from fg_tea.model.documents import MAX_EXTENDS_DEPTH, extended_file

    chain = [Path(path)]
    current = Path(path)
    while len(chain) <= MAX_EXTENDS_DEPTH:
        try:
            parent = read_toml(current).get("extends")
            if parent is None:
                break
            current = extended_file(current, parent)
        except (ValueError, OSError):
            break
        if any(current.resolve() == c.resolve() for c in chain):
            break
        chain.append(current)
    return chain


def input_files(scenario_source: str | None, model_source: str | None, task_path: str | Path | None,
                world_path: str | Path | None = None,
                camera_path: str | Path | None = None) -> dict[str, Any]:
    """Portable records (name, bundle path, sha256) of every input file of an episode.

    Args:
        scenario_source: ``Scenario.source``; for a house generated from a world distribution
            this is not a file, and the record keeps only what :func:`portable_source` makes of it.
        model_source: ``Model.source``; its ``extends`` chain is recorded too.
        task_path: the task file the task graph was read from.
        world_path: the world distribution the scenario was sampled from, if any.
        camera_path: the camera file of the environment (``fg_tea.env.camera``), if known.
    """
    def one(path) -> dict[str, Any] | None:
        if not path:  # None, or a scenario or model built in code ("" source)
            return None
        p = Path(path)
        if p.is_file():
            return describe_file(p)
        return {"file": portable_source(str(path)), "bundled": None, "sha256": None}

    return {
        "scenario": one(scenario_source),
        "model": ([describe_file(p) for p in model_chain(model_source)]
                  if model_source and Path(model_source).is_file()
                  else [entry] if (entry := one(model_source)) else []),
        "task": one(task_path),
        "world": one(world_path),
        "camera": one(camera_path),
    }


def portable_source(text: str) -> str:
    """A source description with every bundled path in it replaced by its bundle path."""
    for kind, folder in _bundle_dirs():
        text = text.replace(str(folder) + os.sep, kind + "/")
    return text


def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


@lru_cache(maxsize=1)
def versions() -> dict[str, str | None]:
    """fg_tea's, Python's and :data:`LIBRARIES`' versions (None for one not installed)."""
    from fg_tea._version import __version__

    out: dict[str, str | None] = {"fg_tea": __version__, "python": platform.python_version()}
    for dist in LIBRARIES:
        out[dist] = _version(dist)
    return out


def checkout_root() -> Path:
    """The folder above the fg_tea package: the top of the work tree when run from a checkout."""
    return Path(__file__).resolve().parents[2]


@lru_cache(maxsize=1)
def git_state() -> dict[str, Any] | None:
    """``{"commit", "dirty"}`` when fg_tea runs from a git checkout, else None.

    ``dirty`` is true when tracked files differ from the commit (untracked files, such as
    ``runs/``, do not count). Computed once per process.
    """
    root = checkout_root()
    if not (root / ".git").exists():
        return None
    env = {k: v for k, v in os.environ.items() if not k.startswith("GIT_")}
    env["GIT_OPTIONAL_LOCKS"] = "0"  # never write the index while a run only reads it

    def git(*args: str) -> str | None:
        try:
            done = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True,
                                  timeout=10, env=env, check=False)
        except (OSError, subprocess.SubprocessError):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    top = git("rev-parse", "--show-toplevel")
    if top is None or Path(top).resolve() != root:
        return None
    commit = git("rev-parse", "HEAD")
    if commit is None:
        return None
    status = git("status", "--porcelain", "--untracked-files=no")
    return {"commit": commit, "dirty": None if status is None else bool(status)}


def render_parameters(options: Any) -> dict[str, Any] | None:
    """The rendering parameters that shape a video (a ``VideoOptions`` or a mapping), for the log.

    ``workers`` is left out: it changes how fast a video renders, never its frames.
    """
    if options is None:
        return None
    if isinstance(options, Mapping):
        values = dict(options)
    else:
        from dataclasses import asdict, is_dataclass

        if not is_dataclass(options) or isinstance(options, type):
            raise TypeError(f"rendering parameters must be a dataclass or a mapping, "
                            f"got {type(options).__name__}")
        values = asdict(options)
    values.pop("workers", None)
    return values


def without_git(events: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The events with ``episode_start.git`` removed, to compare the logs of two commits."""
    out = []
    for event in events:
        event = dict(event)
        if event.get("event") == "episode_start":
            event.pop("git", None)
        out.append(event)
    return out


def episode_provenance(scenario_source: str | None, model_source: str | None,
                       task_path: str | Path | None, world: str | Path | None = None,
                       render: Any = None, camera: str | Path | None = None) -> dict[str, Any]:
    """The provenance fields of ``episode_start``: inputs, versions, git and rendering."""
    return {"inputs": input_files(scenario_source, model_source, task_path, world, camera),
            "versions": versions(), "git": git_state(),
            "render": render_parameters(render)}


__all__ = ["LIBRARIES", "sha256_file", "bundled_path", "bundled_file", "describe_file",
           "portable_ref", "model_chain", "input_files", "portable_source", "versions",
           "git_state", "render_parameters", "without_git", "episode_provenance"]
