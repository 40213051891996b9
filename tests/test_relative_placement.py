"""Placing an object relative to another in a scenario (``"placement": {"beside": ...}`` or
``{"inside": ...}``, fg_tea/world/relative.py): its site follows the anchor, the house stands it on
the slot next to the anchor or puts it inside, a world distribution keeps the relation, every
fault is one line, and episodes run end to end in the fake house and PyBullet."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from fg_tea.cli.main import main
from fg_tea.env.base import EnvConfig
from fg_tea.env.fake import FakeHouse
from fg_tea.world.distributions import parse_world
from fg_tea.world.relative import nearest_free_slot, slot_offset
from fg_tea.world.scenario import load_scenario, parse_scenario


def _apartment(**placements) -> dict:
    """The default apartment's document with `placements` (object -> {relation: anchor})."""
    doc = json.loads(Path(load_scenario("default_apartment").source).read_text())
    doc["name"] = "relative"
    for obj in doc["objects"]:
        if obj["name"] in placements:
            obj.pop("true_site")
            obj["placement"] = placements[obj["name"]]
    return doc


def _house(doc: dict) -> FakeHouse:
    house = FakeHouse(parse_scenario(doc, "relative.json"), EnvConfig())
    house.reset(0)
    return house


def test_beside_and_inside_follow_the_anchor_and_stand_next_to_it_or_in_it():
    doc = _apartment(mug={"beside": "kettle"}, teabag={"inside": "mug"})
    scenario = parse_scenario(doc, "relative.json")
    assert {o.name: o.true_site for o in scenario.objects} == \
        {"mug": "kitchen_counter", "kettle": "kitchen_counter", "teabag": "kitchen_counter"}
    house = _house(doc)
    at = house.placements()
    assert math.isclose(math.dist(at["mug"][:2], at["kettle"][:2]), 0.16, abs_tol=1e-3)  # one slot apart
    assert at["teabag"][:2] == at["mug"][:2] and at["teabag"][2] > at["mug"][2]
    assert house.truth_report()["contained_in"] == {"teabag": "mug"}


def test_beside_a_chain_takes_the_nearest_free_slot_on_the_far_side():
    house = _house(_apartment(mug={"beside": "kettle"}, teabag={"beside": "mug"}))
    at = house.placements()
    xs = sorted((at[o][0], o) for o in ("kettle", "mug", "teabag"))
    assert [o for _, o in xs] == ["kettle", "mug", "teabag"]  # kettle, then mug, then teabag in a row
    assert math.isclose(xs[2][0] - xs[0][0], 0.32, abs_tol=1e-3)


def test_slots_nearest_the_anchor():
    assert [slot_offset(k) for k in range(5)] == [0, 1, -1, 2, -2]
    assert nearest_free_slot(0, {0}) == 1          # right of the anchor first
    assert nearest_free_slot(1, {0, 1}) == 3       # +2 beside +1 (0 is taken)
    assert nearest_free_slot(2, {0, 1, 2}) == 4    # -2 beside -1


def test_scenarios_without_relations_keep_their_layout():
    """Objects on one site take its slots in scenario order, as before relations existed."""
    doc = _apartment()
    for obj in doc["objects"]:
        obj["true_site"] = "dining_table"
    at = _house(doc).placements()
    assert at["mug"][:2] == tuple(doc["sites"][2]["position"][:2])  # slot 0: the site's point
    assert math.dist(at["kettle"][:2], at["mug"][:2]) == pytest.approx(0.16, abs=1e-3)
    assert math.dist(at["teabag"][:2], at["mug"][:2]) == pytest.approx(0.16, abs=1e-3)
    assert at["kettle"] != at["teabag"]


@pytest.mark.parametrize("placements, extra, fault", [
    ({"mug": {"beside": "spoon"}}, {}, "$.objects[0].placement.beside: object 'spoon' is referenced"),
    ({"mug": {"beside": "mug"}}, {}, "cannot be placed relative to itself"),
    ({"mug": {"beside": "kettle"}, "kettle": {"beside": "mug"}}, {}, "placement cycle mug -> kettle -> mug"),
    ({"teabag": {"inside": "mug"}, "kettle": {"inside": "teabag"}}, {}, "'teabag' is itself inside 'mug'"),
    ({"mug": {"beside": "kettle", "inside": "kettle"}}, {}, "expected exactly one of beside, inside"),
    ({"mug": {}}, {}, "expected exactly one of beside, inside"),
    ({"mug": {"beside": "kettle"}}, {"true_site": "sideboard"}, "disagrees with placement beside 'kettle'"),
    ({}, {"true_site": "attic"}, "$.objects[0].true_site: site 'attic' is referenced but not defined in sites"),
    ({}, {"drop": True}, "$.objects[0].true_site: missing required field"),
])
def test_faults_are_one_line_with_exit_2(tmp_path, capsys, placements, extra, fault):
    doc = _apartment(**placements)
    if extra.get("true_site"):
        doc["objects"][0]["true_site"] = extra["true_site"]
    if extra.get("drop"):
        doc["objects"][0].pop("true_site")
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert fault in err and len(err.splitlines()) == 1 and str(path) in err


def test_a_world_keeps_the_relation_and_refuses_rules_that_would_draw_a_follower(tmp_path):
    path = tmp_path / "relative.json"
    path.write_text(json.dumps(_apartment(mug={"beside": "kettle"}, teabag={"inside": "mug"})))
    world = parse_world({"name": "w", "base_scenario": "relative.json",
                         "placement": {"prior_violation": 0.5}}, tmp_path / "w.json")
    kettle_sites = set()
    for seed in range(20):
        drawn = {o.name: o for o in world.sample(seed).objects}
        kettle_sites.add(drawn["kettle"].true_site)
        assert drawn["mug"].true_site == drawn["teabag"].true_site == drawn["kettle"].true_site
        assert drawn["teabag"].relative_to == ("inside", "mug")
    assert len(kettle_sites) > 1  # the anchor is drawn, and the others follow it
    from fg_tea.common.errors import InputError

    with pytest.raises(InputError, match=r"\$\.placement\.co_location\[0\]\.object: object 'mug' is "
                       "placed beside 'kettle'"):
        parse_world({"name": "w", "base_scenario": "relative.json", "placement": {
            "co_location": [{"object": "mug", "anchor": "kettle", "same_site": 0.5}]}}, tmp_path / "w.json")


@pytest.mark.parametrize("env", ["fake", "pybullet"])
def test_make_tea_runs_end_to_end_with_the_teabag_in_the_mug_beside_the_kettle(tmp_path, capsys, env):
    """The teabag starts inside the mug: carrying the mug carries it, the agent's pick where it saw
    it fails, and a new search finds it where the mug now stands."""
    path = tmp_path / "relative.json"
    path.write_text(json.dumps(_apartment(mug={"beside": "kettle"}, teabag={"inside": "mug"})))
    status = main(["run", str(path), "--env", env, "--no-video", "--out", str(tmp_path / "run")])
    out = capsys.readouterr().out
    assert status == 0, out
    events = [json.loads(line) for line in (tmp_path / "run" / "episode.jsonl").read_text().splitlines()]
    start = events[0]["world"]["placements"]
    assert start["teabag"][:2] == start["mug"][:2]
    failed = [e for e in events if e["event"] == "action_failed"]
    assert [(e["action"], e["reason"]) for e in failed] == [("pick_teabag", "object_not_at_site")]
    assert events[-1]["event"] == "metrics" and events[-1]["success"] is True
