"""An action's alternative methods (fg_tea/tasks/methods.py): when recovery has nothing left, the
first alternative takes the action's place (same id and dependencies, a fresh retry count), an
``alternative_method`` event records the switch (explorer and video captions too), and the task
goes on; faults in ``alternatives`` are one line each."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fg_tea.cli.main import main
from fg_tea.episode.log import read_log
from fg_tea.world.scenario import load_scenario

HOB = {"verb": "WAIT", "description": "Heat the kettle on the hob instead"}


def _task(tmp_path: Path, alternatives: list | None = None) -> str:
    """heat_water (its only USE is boiling the kettle) with `alternatives` for boil_kettle."""
    tasks = Path(load_scenario("default_apartment").source).parent / "tasks"
    doc = json.loads((tasks / "heat_water.json").read_text())
    for action in doc["actions"]:
        if action["id"] == "boil_kettle" and alternatives is not None:
            action["alternatives"] = alternatives
    path = tmp_path / "task.json"
    path.write_text(json.dumps(doc))
    return str(path)


def _run(tmp_path: Path, task: str, env: str) -> tuple[int, list[dict]]:
    out = tmp_path / f"run-{env}"
    status = main(["run", "--task", task, "--env", env, "--no-video", "--out", str(out),
                   "--failure-rate", "USE=1"])  # the kettle's switch never works
    return status, read_log(out / "episode.jsonl", strict=True)


@pytest.mark.parametrize("env", ["fake", "pybullet"])
def test_a_kettle_that_never_boils_is_heated_on_the_hob(tmp_path, capsys, env):
    status, events = _run(tmp_path, _task(tmp_path, [HOB]), env)
    assert status == 0, capsys.readouterr().out
    switch = [e for e in events if e["event"] == "alternative_method"]
    assert len(switch) == 1
    assert switch[0]["action"] == "boil_kettle" and switch[0]["method"] == 1 and switch[0]["remaining"] == 0
    assert switch[0]["before"]["verb"] == "USE" and switch[0]["after"] == {
        "verb": "WAIT", "object": "kettle", "transition": "boil"}
    done = [e for e in events if e["event"] == "action" and e["action"] == "boil_kettle"]
    assert [e["verb"] for e in done] == ["WAIT"]
    assert events[-1]["success"] is True and events[-2]["world_truth"]["states"]["mug.water_hot"] is True


def test_without_an_alternative_the_same_episode_ends_stuck(tmp_path, capsys):
    status, events = _run(tmp_path, _task(tmp_path), "fake")
    assert status == 1 and events[-1]["reason"].startswith("stuck: boil_kettle failed")
    assert not any(e["event"] == "alternative_method" for e in events)


def test_the_switch_is_captioned_in_the_explorer_and_the_video(tmp_path, capsys):
    from fg_tea.render.explore import caption
    from fg_tea.render.video import VideoOptions, plan_frames

    _, events = _run(tmp_path, _task(tmp_path, [HOB]), "fake")
    switch = next(e for e in events if e["event"] == "alternative_method")
    assert caption(switch) == "another way to boil_kettle: Heat the kettle on the hob instead"
    plan = plan_frames(events, VideoOptions())
    shown = {(o.phase, o.caption) for o in (plan.overlays[f.overlay] for f in plan.frames)}
    assert ("ALTERNATIVE", "boil_kettle another way: Heat the kettle on the hob instead") in shown


@pytest.mark.parametrize("alternatives, fault", [
    ([{"id": "other"}], "$.actions[7].alternatives[0].id: an alternative cannot change 'id'"),
    ([{"depends_on": []}], "alternatives[0].depends_on: an alternative cannot change 'depends_on'"),
    ([{}], "$.actions[7].alternatives[0]: expected an object with the action fields to change"),
    ([{"verb": "BOIL"}], "$.actions[7].alternatives[0].verb: unknown verb 'BOIL'"),
    ([{"object": "spoon"}], "$.actions[7].alternatives[0].object: object 'spoon' is not an object"),
])
def test_faults_in_alternatives_are_one_line_with_exit_2(tmp_path, capsys, alternatives, fault):
    task = _task(tmp_path, alternatives)
    assert main(["validate", task]) == 2
    err = capsys.readouterr().err.strip()
    assert fault in err and len(err.splitlines()) == 1 and task in err
