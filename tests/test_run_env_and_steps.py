"""`fg-tea run --env fake` runs without a simulator; `--movement-step` and `--turn-step` set how far
the agent moves and turns in a frame, and the log records them (docs/guide/commands.md)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from fg_tea.cli.main import build_parser
from fg_tea.env.base import EnvConfig
from fg_tea.episode.log import read_log


def _run(tmp_path: Path, name: str, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fg_tea.cli", "run", "--env", "fake", "--no-video",
                           "--out", str(tmp_path / name), *extra], capture_output=True, text=True,
                          timeout=600, stdin=subprocess.DEVNULL)


def _env(folder: Path) -> tuple[dict, list[dict]]:
    events = read_log(folder / "episode.jsonl")
    return events[0]["parameters"]["env"], events


def test_defaults_are_the_environment_config_defaults():
    args = build_parser().parse_args(["run"])
    assert args.env == "pybullet"
    assert args.movement_step == EnvConfig.movement_step and args.turn_step == EnvConfig.turn_step_deg


def test_a_fake_run_logs_its_steps_and_a_longer_step_takes_fewer_frames(tmp_path):
    plain = _run(tmp_path, "plain")
    assert plain.returncode == 0, plain.stderr
    fast = _run(tmp_path, "fast", "--movement-step", "0.036", "--turn-step", "5")
    assert fast.returncode == 0, fast.stderr
    (env_plain, ev_plain), (env_fast, ev_fast) = _env(tmp_path / "plain"), _env(tmp_path / "fast")
    assert (env_plain["movement_step"], env_plain["turn_step_deg"]) == (0.018, 2.5)
    assert (env_fast["movement_step"], env_fast["turn_step_deg"]) == (0.036, 5.0)
    end_plain, end_fast = (next(e for e in ev if e["event"] == "episode_end") for ev in (ev_plain, ev_fast))
    assert end_plain["reason"] == end_fast["reason"] == "complete"
    assert end_fast["frame"] < end_plain["frame"]
    assert "no simulator" in subprocess.run([sys.executable, "-m", "fg_tea.cli", "run", "--help"],
                                            capture_output=True, text=True, timeout=120).stdout


def test_a_step_out_of_range_is_one_line(tmp_path):
    for flag, value in (("--movement-step", "0"), ("--turn-step", "-1"), ("--env", "mujoco")):
        done = _run(tmp_path, "bad", flag, value)
        assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
        assert flag in done.stderr
