"""One log reader for every command that reads logs (docs/design.md §9): guarded like every input.

A bare NaN (fg_tea never writes one), nesting too deep to parse, a FIFO and an endless device are
one line and exit 2 for ``render`` and ``learn``, never a hang, a MemoryError or a
RecursionError; ``Infinity`` (an unreachable site's distance) is read back; a partial last line
(a crash mid-write) ends a tolerant read and fails a strict one.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys

import pytest

from fg_tea.common.errors import InputError
from fg_tea.episode.log import read_log

START = '{"event":"episode_start","seq":0}'


def _cli(*args: str, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fg_tea.cli", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=300, stdin=subprocess.DEVNULL)


@pytest.mark.parametrize("body,fault", [
    (START + '\n{"event":"observation","x":NaN}\n', "a bare NaN"),
    (START + "\n" + '{"event":"x","y":' + "[" * 100_000 + "]" * 100_000 + "}\n", "nested too deeply"),
])
@pytest.mark.parametrize("command", ["render", "learn", "explore"])
def test_a_bad_log_is_one_line_for_render_learn_and_explore(command, body, fault, tmp_path):
    log = tmp_path / "bad.jsonl"
    log.write_text(body)
    argv = [command, str(log), "--out", str(tmp_path / ("v.mp4" if command == "render" else "m.toml"))]
    proc = _cli(*argv, cwd=tmp_path)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and fault in lines[0], proc.stderr[-500:]


@pytest.mark.parametrize("make", ["fifo", "zero"])
def test_learn_refuses_a_fifo_and_an_endless_device_without_hanging(make, tmp_path):
    node = tmp_path / "log.jsonl"
    if make == "fifo":
        os.mkfifo(node)
    else:
        try:
            os.mknod(node, 0o20666, os.makedev(1, 5))  # the numbers of /dev/zero, made here
        except PermissionError:
            pytest.skip("making a character device needs root")
    proc = _cli("learn", str(node), "--out", str(tmp_path / "m.toml"), cwd=tmp_path)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr[-500:]


def test_infinity_reads_back_and_a_partial_last_line_is_tolerated_only_when_not_strict(tmp_path):
    log = tmp_path / "l.jsonl"
    log.write_text(START + '\n{"event":"action","seq":1,"distance":Infinity}\n{"event":"act')
    events = read_log(log)
    assert len(events) == 2 and math.isinf(events[1]["distance"])
    with pytest.raises(InputError, match="line 3: not a JSON line"):
        read_log(log, strict=True)
    log.write_text(START + '\n{"event":"act\n{"event":"action","seq":1}\n')
    with pytest.raises(InputError, match="line 2"):  # only the last line may be partial
        read_log(log)
