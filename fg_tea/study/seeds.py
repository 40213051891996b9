"""Episode seeds and the one scheme a sweep table holds (docs/design.md §11, "Episode seeds").

The episode seed (the camera's draws, injected failures, the random planner) of world seed w is by
default drawn from a stream of its own per world distribution (:func:`episode_seed`); the scheme
``world`` uses w itself, as every table did before. A sweep CSV holds one scheme:
:func:`check_resumable` refuses to add episodes of the other before anything is written.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path
from typing import Iterable, Protocol, Sequence

from fg_tea.common.errors import InputError
from fg_tea.study.rows import read_rows


class _Seeded(Protocol):
    """What the checks read of a sweep job (:class:`fg_tea.study.sweep.Job`)."""

    @property
    def world(self) -> str: ...

    @property
    def world_seed(self) -> int: ...

    @property
    def seed(self) -> int | None: ...

    @property
    def key(self) -> str: ...


EPISODE_SEEDS = ("independent", "world")
EPISODE_SEEDS_HELP = ("episode seed (detector noise, injected failures) of world seed w: its own "
                      "stream per world distribution (independent, the default; docs/design.md "
                      "§11), or w itself (world: the scheme of the tables committed before "
                      "independent was the default; w then draws the same noise in every house, "
                      "from the numbers that placed its objects)")


def add_episode_seed_argument(parser: argparse.ArgumentParser) -> None:
    """``--episode-seeds {independent,world}``; None when not given (:func:`episode_seed_scheme`
    reads it), so that a mode it does not apply to can refuse it."""
    parser.add_argument("--episode-seeds", choices=EPISODE_SEEDS, default=None, help=EPISODE_SEEDS_HELP)


def episode_seed_scheme(args: argparse.Namespace) -> str:
    """The ``--episode-seeds`` scheme of parsed arguments: the one given, else independent."""
    return args.episode_seeds or "independent"


def recorded_argv(argv: Sequence[str], args: argparse.Namespace) -> list[str]:
    """A command's arguments as recorded beside its results: `argv` with the ``--episode-seeds``
    scheme written out when it was left to the default, whatever the default becomes."""
    given = list(argv)
    return given if args.episode_seeds is not None else given + ["--episode-seeds", episode_seed_scheme(args)]


def episode_seed(world: str, world_seed: int) -> int:
    """An episode seed from its own stream, independent of the world seed's (docs/design.md §11).

    Drawn from ``numpy.random.SeedSequence([world_seed, crc32(name)])``, where name is the world
    distribution's name (a file's stem): the same world and seed give the same episode seed on
    every machine, and world seed w of two distributions gives unrelated detector draws.
    """
    import zlib

    import numpy as np

    name = Path(str(world)).stem.encode("utf-8")
    state = np.random.SeedSequence([int(world_seed), zlib.crc32(name)]).generate_state(1)
    return int(state[0] >> 1)  # 31 bits


_SEED_PART = re.compile(r"\|seed=(\d+)")


def check_episode_seeds(jobs: Sequence[_Seeded], keys: Iterable[str], path: str | Path) -> None:
    """Refuse to add a job to a CSV that holds the same episode under another episode seed
    (another ``--episode-seeds`` scheme): the table would mix two sets of detector draws.

    Raises:
        InputError: naming the file, the world seed and both episode seeds.
    """
    held: dict[str, int] = {}
    for key in keys:
        if m := _SEED_PART.search(key):
            held.setdefault(_SEED_PART.sub("", key, count=1), int(m.group(1)))
    for job in jobs if held else ():
        seed = held.get(_SEED_PART.sub("", job.key, count=1))
        if seed is not None and seed != job.seed:
            raise InputError(path, "seed", f"world seed {job.world_seed} of {job.world} ran here with "
                             f"episode seed {seed}, and this run gives it {job.seed}: the file was run "
                             "with the other --episode-seeds scheme (one scheme per table)")


def check_resumable(jobs: Sequence[_Seeded], csv_path: str | Path, resume: bool = True) -> None:
    """:func:`check_episode_seeds` against the rows already in `csv_path` (nothing to check when
    it is not a regular file or the run does not resume); a command calls it before it writes
    anything.

    Raises:
        InputError: the CSV is not a sweep CSV, or holds these jobs under other episode seeds.
    """
    path = Path(csv_path)
    if resume and path.is_file():  # a FIFO or device is never read here (refused where written)
        check_episode_seeds(jobs, (str(r["key"]) for r in read_rows(path)), path)


__all__ = ["EPISODE_SEEDS", "EPISODE_SEEDS_HELP", "add_episode_seed_argument", "check_episode_seeds",
           "check_resumable", "episode_seed", "episode_seed_scheme", "recorded_argv"]
