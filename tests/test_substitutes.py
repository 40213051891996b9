"""A task's substitutes (fg_tea/tasks/substitutes.py): when the search for an object is given up,
another object that serves the same role is searched and the actions that named the first act on
it; the switch is a ``substitute`` event in the log, a caption in the explorer and the video; the
task file's faults are one line each."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fg_tea.cli.main import main
from fg_tea.episode.log import read_log
from fg_tea.world.scenario import load_scenario


def _files(tmp_path: Path, substitutes: dict | None = {"teabag": ["tea_tin"]}) -> dict[str, str]:
    """The default apartment with the teabag on the study shelf (a site its prior ranks low) and a
    tea tin on the pantry shelf; make_tea with `substitutes`; a model that gives a search up after
    five looks."""
    doc = json.loads(Path(load_scenario("default_apartment").source).read_text())
    doc["name"] = "spare_tea"
    for site in doc["sites"]:
        site["affordances"]["tea_tin"] = {"pantry_shelf": 0.5, "kitchen_counter": 0.3}.get(site["name"], 0.02)
    for obj in doc["objects"]:
        if obj["name"] == "teabag":
            obj["true_site"] = "study_shelf"
    doc["objects"].append({"name": "tea_tin", "category": "tea_tin", "true_site": "pantry_shelf",
                           "semantic_id": 9004, "asset": "teabag", "affordances": ["graspable", "steepable"],
                           "state_priors": {"steeped": 0.02}, "hidden_state_truth": {"steeped": False}})
    task = json.loads((Path(load_scenario("default_apartment").source).parent / "tasks" / "make_tea.json")
                      .read_text())
    task["name"] = "make_tea_or_tin"
    if substitutes is not None:
        task["substitutes"] = substitutes
    paths = {"scenario": tmp_path / "spare_tea.json", "task": tmp_path / "task.json",
             "model": tmp_path / "impatient.toml"}
    paths["scenario"].write_text(json.dumps(doc))
    paths["task"].write_text(json.dumps(task))
    paths["model"].write_text('extends = "factorised"\nname = "impatient"\n[planning]\n'
                              "max_inspections_per_object = 5\n")
    return {k: str(v) for k, v in paths.items()}


def _run(tmp_path: Path, files: dict, env: str) -> tuple[int, list[dict]]:
    out = tmp_path / f"run-{env}"
    status = main(["run", files["scenario"], "--model", files["model"], "--task", files["task"],
                   "--env", env, "--no-video", "--out", str(out)])
    return status, read_log(out / "episode.jsonl", strict=True)  # strict: every event checked


@pytest.mark.parametrize("env", ["fake", "pybullet"])
def test_a_given_up_teabag_is_replaced_by_the_tea_tin_and_the_tea_is_made(tmp_path, capsys, env):
    status, events = _run(tmp_path, _files(tmp_path), env)
    assert status == 0, capsys.readouterr().out
    kinds = [e["event"] for e in events]
    given_up = kinds.index("give_up")
    assert events[given_up]["object"] == "teabag" and kinds[given_up + 1] == "substitute"
    switch = events[given_up + 1]
    assert (switch["object"], switch["substitute"], switch["remaining"]) == ("teabag", "tea_tin", [])
    assert switch["retargeted"] == ["search_teabag", "pick_teabag", "carry_teabag", "insert_teabag",
                                    "steep_tea"]
    acted = {e["action"]: e["parameters"] for e in events if e["event"] == "action"}
    assert acted["pick_teabag"]["object"] == "tea_tin"
    assert acted["steep_tea"]["object"] == "tea_tin" and acted["steep_tea"]["destination"] == "mug"
    assert any(e["event"] == "confirm_search" and e["object"] == "tea_tin" for e in events)
    assert "stuck" not in kinds and events[-1]["success"] is True
    assert events[-2]["world_truth"]["states"]["mug.tea_brewed"] is True


def test_without_substitutes_the_same_episode_ends_not_found(tmp_path, capsys):
    status, events = _run(tmp_path, _files(tmp_path, substitutes=None), "fake")
    assert status == 1
    assert events[-1]["reason"].startswith("not_found: teabag")
    assert not any(e["event"] == "substitute" for e in events)


def test_the_switch_is_captioned_in_the_explorer_and_the_video(tmp_path, capsys):
    from fg_tea.render.explore import caption
    from fg_tea.render.video import VideoOptions, plan_frames

    _, events = _run(tmp_path, _files(tmp_path), "fake")
    switch = next(e for e in events if e["event"] == "substitute")
    assert caption(switch) == "substitute: the tea_tin stands in for the teabag (5 actions retargeted)"
    plan = plan_frames(events, VideoOptions())
    shown = [plan.overlays[f.overlay] for f in plan.frames]
    held = [o for o in shown if o.caption == "teabag given up: the tea_tin stands in for it"]
    assert held and held[0].phase == "SUBSTITUTE" and held[0].focus_object == "tea_tin"


@pytest.mark.parametrize("substitutes, fault", [
    ({"teabag": ["spoon"]}, "$.substitutes.teabag[0]: object 'spoon' is referenced but not defined"),
    ({"teabag": ["teabag"]}, "object 'teabag' is the object itself"),
    ({"teabag": ["mug"]}, "object 'mug' is already acted on by this task"),
    ({"teabag": ["tea_tin", "tea_tin"]}, "$.substitutes.teabag[1]: object 'tea_tin' is listed twice"),
    ({"teabag": []}, "$.substitutes.teabag: expected a list of at least one object name"),
    ({"tea_tin": ["teabag"]}, "$.substitutes.tea_tin: object 'tea_tin' is not an object this task acts on"),
    ({"mug": ["tea_tin"]}, "object 'tea_tin' does not afford container, fillable"),
])
def test_faults_in_substitutes_are_one_line_with_exit_2(tmp_path, capsys, substitutes, fault):
    files = _files(tmp_path, substitutes)
    assert main(["validate", files["task"], "--scenario", files["scenario"]]) == 2
    err = capsys.readouterr().err.strip()
    assert fault in err and len(err.splitlines()) == 1 and files["task"] in err
