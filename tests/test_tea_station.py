"""The tea-station task: the mug, the kettle and the teabag brought to the preparation site in the
original demonstration's final relations (mug and kettle on the site, the teabag inside the mug),
and nothing boiled or brewed, end to end in the fake house and in PyBullet."""

from __future__ import annotations

import subprocess
import sys

import pytest

from fg_tea.episode.log import read_log


@pytest.mark.parametrize("env", ["fake", "pybullet"])
def test_the_station_is_prepared_without_brewing(tmp_path, env):
    done = subprocess.run([sys.executable, "-m", "fg_tea.cli", "run", "--task", "tea_station", "--env", env,
                           "--no-video", "--out", str(tmp_path)], capture_output=True, text=True, timeout=600,
                          stdin=subprocess.DEVNULL)
    assert done.returncode == 0, done.stderr
    events = read_log(tmp_path / "episode.jsonl")
    end = next(e for e in events if e["event"] == "episode_end")
    assert end["reason"] == "complete"
    truth = end["world_truth"]
    site = events[0]["parameters"]["run"]["preparation_site"] or truth["sites"]["mug"]
    assert truth["sites"]["mug"] == truth["sites"]["kettle"] == site
    assert truth["contained_in"] == {"teabag": "mug"} and truth["held"] is None
    assert not any(truth["states"].values())  # nothing filled, boiled, poured or brewed
    verbs = {e.get("verb") for e in events if e["event"] == "action"}
    assert {"PICK", "PLACE", "INSERT"} <= verbs and not verbs & {"FILL", "POUR", "WAIT"}, verbs
