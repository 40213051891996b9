"""Outputs never replace what is not a regular file (docs/design.md §9, "Outputs").

Every command that writes is pointed at a FIFO and at a character device that the test makes
itself (never a system one). Each must refuse before any work with one line and status 2, and
leave the node as it was. (An atomic write renames a temporary file over its target: without the
check, ``fg-tea house --out /dev/null`` run as root replaced the system's /dev/null.)
"""

from __future__ import annotations

import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _fifo(path: Path) -> Path:
    os.mkfifo(path)
    return path


def _chardev(path: Path) -> Path:
    try:
        os.mknod(path, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # the numbers of /dev/null
    except PermissionError:
        pytest.skip("making a character device needs root (CAP_MKNOD)")
    return path


NODES = {"fifo": (_fifo, stat.S_ISFIFO), "chardev": (_chardev, stat.S_ISCHR)}


def _log(tmp: Path) -> Path:
    """A finished episode log (the fake house: a second)."""
    from fg_tea.episode.log import EventLog
    from fg_tea.episode.run import run_episode
    from fg_tea.model.spec import load_model
    from fg_tea.world.scenario import load_scenario

    path = tmp / "episode.jsonl"
    if not path.exists():
        run_episode(load_scenario("default_apartment"), load_model("factorised_close"), env="fake", log=path)
    assert EventLog  # the log is written event by event by run_episode
    return path


#: command -> (argv with NODE standing for the node's path, where the node goes: "file:NAME" is
#: the output file itself, a bare name is a file the command writes inside its output folder OUT).
COMMANDS = {
    "run --out DIR (its log)": (["run", "--no-video", "--out", "OUT"], "episode.jsonl"),
    "run --out DIR (its timings)": (["run", "--no-video", "--out", "OUT"], "timings.json"),
    "render --out": (["render", "LOG", "--out", "NODE"], "file:v.mp4"),
    "preview --out": (["preview", "--out", "NODE"], "file:p.png"),
    "preview --out (its floor plan)": (["preview", "--out", "OUT/p.png"], "p_plan.png"),
    "compare --out DIR (its CSV)": (["compare", "--quick", "--env", "fake", "--worlds", "1",
                                     "--out", "OUT"], "episodes.csv"),
    "compare --out DIR (its summary)": (["compare", "--quick", "--env", "fake", "--worlds", "1",
                                         "--out", "OUT"], "summary.md"),
    "house --out": (["house", "--rooms", "3", "--out", "NODE"], "file:h.json"),
    "learn --out": (["learn", "LOG", "--out", "NODE"], "file:learned.toml"),
    "explore --out": (["explore", "LOG", "--out", "NODE"], "file:e.html"),
}


@pytest.mark.parametrize("kind", sorted(NODES))
@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_an_output_that_is_a_node_is_refused_and_left_intact(command, kind, tmp_path):
    make, is_kind = NODES[kind]
    argv, where = COMMANDS[command]
    out = tmp_path / "out"
    out.mkdir()
    node = make(tmp_path / where[5:] if where.startswith("file:") else out / where)
    log = _log(tmp_path) if "LOG" in argv else None
    args = [str(node) if a == "NODE" else str(log) if a == "LOG" else a.replace("OUT", str(out))
            for a in argv]
    proc = subprocess.run([sys.executable, "-m", "fg_tea.cli", *args], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert proc.returncode == 2, (proc.returncode, proc.stderr[-2000:])
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and str(node.name) in lines[0] and "not a regular file" in lines[0], lines
    assert is_kind(os.stat(node).st_mode), "the node must be left as it was"
    if not where.startswith("file:"):  # refused before any work: nothing else was written into the folder
        assert sorted(p.name for p in out.iterdir()) == [node.name]


def test_atomic_writes_refuse_a_node_themselves(tmp_path):
    from fg_tea.common.errors import InputError
    from fg_tea.common.files import atomic_write_text

    fifo = _fifo(tmp_path / "f")
    with pytest.raises(InputError, match="is a FIFO, not a regular file"):
        atomic_write_text(fifo, "x")
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)


def test_the_table_covers_every_output_option_of_every_command():
    """A new command with an output option cannot be forgotten here."""
    import argparse

    from fg_tea.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    writers = {name for name, p in sub.choices.items()
               if any(a.dest in ("out", "log_out", "video", "json") for a in p._actions)}
    covered = {argv[0] for argv, _ in COMMANDS.values()}
    assert writers <= covered, f"add {sorted(writers - covered)} to COMMANDS"


@pytest.mark.parametrize("argv", [["run", "--no-video", "--out"], ["preview", "--out"],
                                  ["compare", "--quick", "--env", "fake", "--out"],
                                  ["house", "--rooms", "3", "--out"]])
def test_an_out_path_beyond_path_max_is_one_short_line(argv, tmp_path, capsys):
    """The whole path used to be echoed (5,000 characters and more)."""
    from fg_tea.cli.main import main

    long = str(tmp_path / ("a" * 300) / ("b" * 5000))
    try:
        status = main([*argv, long + (".png" if argv[0] in ("preview",) else "")])
    except SystemExit as exc:
        status = exc.code
    assert status == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and len(err[0]) < 400 and "characters)" in err[0], err


def test_preview_on_a_full_disk_is_one_line_naming_the_file(tmp_path, capsys, monkeypatch):
    """OpenCV's imwrite printed libpng's message and a misleading "No such file or directory"; the
    PNG is now encoded in memory and written from Python, so ENOSPC is one line."""
    import errno
    import pathlib

    from fg_tea.cli.main import main

    def full(self, data):
        raise OSError(errno.ENOSPC, "No space left on device", str(self))

    monkeypatch.setattr(pathlib.Path, "write_bytes", full)
    out = tmp_path / "p.png"
    assert main(["preview", "--out", str(out)]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and "No space left on device" in err[0] and "p.png" in err[0], err
    assert not out.exists() and not list(tmp_path.glob("*.tmp*"))
