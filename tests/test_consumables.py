"""Consumables (fg_tea/world/consumables.py, fg_tea/tasks/consumables.py): a scenario object with a
count of uses, taken one by each successful action of its verb in the environment's truth; with
none left the action fails ``used_up`` in the fake and the PyBullet house alike. The agent learns it
from that failure only, and the task's substitutes take the object's place (a ``substitute`` event
with cause ``used_up``, captioned in the explorer and the video), or the episode ends stuck,
honestly, after one try. A bad count in the scenario is one line and exit 2."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

from fg_tea.cli.main import main
from fg_tea.env.fake import FakeHouse
from fg_tea.episode.log import read_log
from fg_tea.world.interface import ActionRequest
from fg_tea.world.scenario import load_scenario, parse_scenario

ROOT = Path(__file__).resolve().parent.parent
SCENARIO = ROOT / "scenarios" / "tea_box_apartment.json"
TASK = ROOT / "scenarios" / "tasks" / "make_tea_from_box.json"
FETCHED = ["search_teabag", "pick_teabag", "carry_teabag", "insert_teabag", "steep_tea"]


def _scenario(tmp_path: Path, box: object = None, tin: object = None) -> str:
    """The bundled tea-box apartment with the box's (and the tin's) consumable set as given."""
    doc = json.loads(SCENARIO.read_text())
    for obj in doc["objects"]:
        for name, value in (("teabag_box", box), ("tea_tin", tin)):
            if obj["name"] == name and value is not None:
                obj["consumable"] = value
    path = tmp_path / "tea_box.json"
    path.write_text(json.dumps(doc))
    return str(path)


def _task(tmp_path: Path, substitutes: bool) -> str:
    doc = json.loads(TASK.read_text())
    if not substitutes:
        del doc["substitutes"]
    path = tmp_path / "task.json"
    path.write_text(json.dumps(doc))
    return str(path)


def _run(tmp_path: Path, scenario: str, task: str, env: str = "fake") -> tuple[int, list[dict]]:
    out = tmp_path / f"run-{env}"
    status = main(["run", scenario, "--task", task, "--env", env, "--no-video", "--out", str(out)])
    return status, read_log(out / "episode.jsonl", strict=True)  # strict: every event checked


def _house(env: str, scenario):
    if env == "fake":
        return FakeHouse(scenario)
    from fg_tea.env.house import PyBulletHouse

    return PyBulletHouse(scenario)


@pytest.mark.parametrize("env", ["fake", "pybullet"])
def test_each_use_takes_one_and_an_empty_box_fails_without_changing_the_truth(tmp_path, env):
    house = _house(env, load_scenario(_scenario(tmp_path, box={"uses": 1, "verb": "PICK"})))
    try:
        house.reset(0)
        assert house.truth_report()["uses_left"] == {"tea_tin": 3, "teabag_box": 1}
        assert house.execute(ActionRequest("PICK", "teabag_box", "pantry_shelf")).ok
        assert house.truth_report()["uses_left"]["teabag_box"] == 0
        assert house.execute(ActionRequest("PLACE", "teabag_box", "pantry_shelf")).ok  # PLACE takes none
        before = house.truth_report()
        failed = house.execute(ActionRequest("PICK", "teabag_box", "pantry_shelf"))
        assert (failed.ok, failed.reason) == (False, "used_up")
        assert house.truth_report() == before  # nothing held, nothing moved, nothing taken
        assert house.execute(ActionRequest("PICK", "tea_tin", "sideboard")).ok
        assert house.truth_report()["uses_left"] == {"tea_tin": 2, "teabag_box": 0}
    finally:
        house.close()


def test_a_scenario_without_consumables_reports_no_uses():
    house = FakeHouse(load_scenario("default_apartment"))
    house.reset(0)
    assert "uses_left" not in house.truth_report()  # the logs of such episodes stay as they were


@pytest.mark.parametrize("env", ["fake", "pybullet"])
def test_the_empty_box_is_replaced_by_the_tea_tin_and_the_tea_is_made(tmp_path, capsys, env):
    status, events = _run(tmp_path, str(SCENARIO), str(TASK), env)
    assert status == 0, capsys.readouterr().out
    kinds = [e["event"] for e in events]
    switch = events[kinds.index("substitute")]
    failed = events[kinds.index("substitute") + 1]
    assert (failed["event"], failed["action"], failed["reason"]) == ("action_failed", "pick_teabag", "used_up")
    assert failed["request"]["object"] == "teabag_box" and failed["retry"] is True
    assert (switch["object"], switch["substitute"], switch["cause"], switch["remaining"]) == (
        "teabag_box", "tea_tin", "used_up", [])
    assert switch["retargeted"] == FETCHED and switch["reopened"] == ["search_teabag", "pick_teabag"]
    assert switch["graph"]["search_teabag"] == "pending" and switch["graph"]["pick_teabag"] == "pending"
    assert kinds.count("action_failed") == 1 and "give_up" not in kinds  # no retry of the empty box
    after = kinds.index("substitute")
    assert any(e["event"] == "confirm_search" and e["object"] == "tea_tin" for e in events[after:])
    acted = {e["action"]: e["parameters"] for e in events if e["event"] == "action"}
    assert acted["pick_teabag"]["object"] == "tea_tin" and acted["steep_tea"]["object"] == "tea_tin"
    assert "stuck" not in kinds and events[-1]["success"] is True
    truth = events[-2]["world_truth"]
    assert truth["states"]["mug.tea_brewed"] is True and truth["uses_left"] == {"tea_tin": 2, "teabag_box": 0}


def test_a_box_with_a_teabag_left_is_used_without_a_switch(tmp_path, capsys):
    status, events = _run(tmp_path, _scenario(tmp_path, box={"uses": 1, "verb": "PICK"}), str(TASK))
    assert status == 0 and events[-1]["success"] is True
    assert not any(e["event"] in ("substitute", "action_failed") for e in events)
    assert events[-2]["world_truth"]["uses_left"] == {"tea_tin": 3, "teabag_box": 0}


def test_without_a_substitute_the_episode_ends_stuck_after_one_try(tmp_path, capsys):
    status, events = _run(tmp_path, str(SCENARIO), _task(tmp_path, substitutes=False))
    assert status == 1
    assert events[-1]["reason"] == ("stuck: pick_teabag failed 1 times: used_up (teabag_box is used up and no "
                                    "substitute is left for it)")
    assert [e["reason"] for e in events if e["event"] == "action_failed"] == ["used_up"]
    assert not any(e["event"] == "substitute" for e in events)


def test_when_the_substitute_is_used_up_too_the_episode_ends_stuck(tmp_path, capsys):
    status, events = _run(tmp_path, _scenario(tmp_path, tin={"uses": 0, "verb": "PICK"}), str(TASK))
    assert status == 1
    failed = [(e["request"]["object"], e["reason"]) for e in events if e["event"] == "action_failed"]
    assert failed == [("teabag_box", "used_up"), ("tea_tin", "used_up")]
    assert [e["substitute"] for e in events if e["event"] == "substitute"] == ["tea_tin"]
    assert events[-1]["reason"].endswith("used_up (tea_tin is used up and no substitute is left for it)")


def test_the_switch_is_captioned_in_the_explorer_and_the_video(tmp_path, capsys):
    from fg_tea.render.explore import caption
    from fg_tea.render.video import VideoOptions, plan_frames

    _, events = _run(tmp_path, str(SCENARIO), str(TASK))
    switch = next(e for e in events if e["event"] == "substitute")
    assert caption(switch) == ("substitute: the tea_tin stands in for the used-up teabag_box "
                               "(5 actions retargeted, 2 reopened)")
    plan = plan_frames(events, VideoOptions())
    shown = [plan.overlays[f.overlay] for f in plan.frames]
    held = [o for o in shown if o.caption == "teabag_box used up: the tea_tin stands in for it"]
    assert held and held[0].phase == "SUBSTITUTE" and held[0].focus_object == "tea_tin"


def test_the_agent_side_never_reads_the_count():
    """The count is hidden truth: no agent-side module reads an object's consumable or uses."""
    readers = []
    for folder in ("tasks", "agent", "beliefs", "planning", "model"):
        for path in sorted((ROOT / "fg_tea" / folder).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Attribute) and node.attr in ("consumable", "uses_left", "uses"):
                    readers.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert readers == []


@pytest.mark.parametrize("consumable, fault", [
    ({"uses": -1, "verb": "PICK"}, "consumable.uses: a count of uses must be a non-negative integer, got -1"),
    ({"uses": 1.5, "verb": "PICK"}, "consumable.uses: expected an integer, got float 1.5"),
    ({"uses": "two", "verb": "PICK"}, "consumable.uses: expected an integer, got str"),
    ({"uses": True, "verb": "PICK"}, "consumable.uses: expected an integer, got bool"),
    ({"verb": "PICK"}, "consumable.uses"),
    ({"uses": 1, "verb": "NAVIGATE"}, "consumable.verb: must be one of PICK, PLACE, INSERT"),
    ({"uses": 1, "verb": "PICK", "count": 2}, "consumable.count: unknown field"),
])
def test_a_bad_consumable_is_one_line_naming_file_and_field_with_exit_2(tmp_path, capsys, consumable, fault):
    scenario = _scenario(tmp_path, box=consumable)
    assert main(["validate", scenario]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and scenario in err and "$.objects[2]." + fault in err, err


def test_fg_tea_run_refuses_a_negative_count_in_one_line(tmp_path, capsys):
    scenario = _scenario(tmp_path, box={"uses": -3, "verb": "PICK"})
    assert main(["run", scenario, "--task", str(TASK), "--env", "fake", "--no-video",
                 "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "$.objects[2].consumable.uses" in err and scenario in err
    assert "non-negative integer, got -3" in err


def test_the_parsed_scenario_holds_the_count():
    doc = json.loads(SCENARIO.read_text())
    box = parse_scenario(doc, "x").object("teabag_box").consumable
    assert box is not None and (box.uses, box.verb) == (0, "PICK")


def test_a_world_over_the_scenario_keeps_the_count(tmp_path, capsys):
    """A world distribution draws where objects stand; the box's count of uses is the base
    scenario's, so a world episode with it switches to the tin just the same."""
    from fg_tea.world.distributions import parse_world

    doc = {"name": "tea_box_worlds", "base_scenario": str(SCENARIO),
           "placement": {"order": ["kettle", "teabag_box", "tea_tin", "mug"], "prior_violation": 0.0}}
    world = parse_world(doc, tmp_path / "w.json").sample(3)
    box = world.object("teabag_box").consumable
    assert box is not None and (box.uses, box.verb) == (0, "PICK")
    from fg_tea.episode.run import run_episode
    from fg_tea.model.spec import load_model

    events = run_episode(world, load_model("factorised"), task=str(TASK), env="fake").events
    assert [e["cause"] for e in events if e["event"] == "substitute"] == ["used_up"]
    assert events[-1]["success"] is True
