"""Generated houses: valid, buildable, solvable, deterministic; worlds with a fresh house each."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

from fg_tea.cli import main
from fg_tea.env.base import EnvConfig
from fg_tea.env.fake import FakeHouse
from fg_tea.env.house import PyBulletHouse
from fg_tea.world.navigation import Navigator
from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
from fg_tea.common.errors import InputError
from fg_tea.world.housegen import CATEGORIES, generate_house, house_json
from fg_tea.model.spec import load_model
from fg_tea.world.scenario import load_scenario, parse_scenario
from fg_tea.world.distributions import load_world, parse_world

ROOT = Path(__file__).resolve().parent.parent
#: One seed per room count (seeds chosen as 7 * rooms + 1, not searched for).
SAMPLE = [(rooms, 7 * rooms + 1) for rooms in range(3, 11)]


def check_house(doc: dict, rooms: int) -> None:
    """Everything the generator promises about one house, on the parsed scenario."""
    scenario = parse_scenario(doc, "<test>")
    assert scenario.sites[0].room == "kitchen" and len(scenario.rooms) == rooms
    per_room = Counter(s.room for s in scenario.sites)
    assert all(3 <= n <= 5 for n in per_room.values()), per_room
    for site in scenario.sites:
        assert 0.45 <= site.position[2] <= 1.05
        assert 1.0 - 1e-6 <= math.dist(site.position[:2], site.vantage) <= 1.3 + 1e-6
    for category in CATEGORIES:
        assert any(s.affordances[category] > 0 for s in scenario.sites)
    kettle = max(scenario.sites, key=lambda s: s.affordances["kettle"])
    assert kettle.room == "kitchen"  # kettles live on kitchen counters
    glances = Counter(v.room for v in scenario.room_vantages)
    assert set(glances) == set(scenario.rooms) and all(1 <= n <= 2 for n in glances.values())
    nav = Navigator(scenario, EnvConfig())  # raises InputError for a bad site vantage or start
    for v in scenario.room_vantages:
        assert nav.grid.is_free(v.position) and nav.reachable[nav.grid.cell(v.position)], v
    assert len({o.semantic_id for o in scenario.objects}) == len(scenario.objects)
    prep = scenario.site(scenario.preparation_site)
    assert prep.furniture and prep.furniture.endswith("table") and prep.room in ("kitchen", "dining")


@pytest.mark.parametrize("rooms,seed", SAMPLE)
def test_generated_houses_build_and_finish_an_episode(rooms, seed):
    doc = generate_house(rooms, seed)
    check_house(doc, rooms)
    scenario = parse_scenario(doc, "<test>")
    house = PyBulletHouse(scenario, EnvConfig())
    try:
        house.reset(0)
    finally:
        house.close()
    model = load_model("factorised")
    env = FakeHouse(scenario, env_config_for(model))
    runner = EpisodeRunner(scenario, model, env, RunConfig(seed=seed))
    runner.run()
    metrics = runner.metrics()
    assert metrics["success"], metrics["reason"]


def test_house_validate_run_commands(tmp_path, capsys):
    """fg-tea house --rooms 6 --seed 3 --out h.json && fg-tea validate h.json && fg-tea run h.json
    --model joint --no-video, in the PyBullet house."""
    house = tmp_path / "h.json"
    assert main(["house", "--rooms", "6", "--seed", "3", "--out", str(house)]) == 0
    assert main(["validate", str(house)]) == 0
    out = tmp_path / "run"
    assert main(["run", str(house), "--model", "joint", "--no-video", "--out", str(out)]) == 0
    events = [json.loads(line) for line in (out / "episode.jsonl").read_text().splitlines()]
    metrics = next(e for e in events if e["event"] == "metrics")
    assert metrics["success"] and metrics["reason"] == "complete", metrics
    assert any(e["event"] == "observation" and e["viewpoint_kind"] == "room" for e in events)


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_more_seeds_validate():
    for rooms in range(3, 11):
        for seed in (100, 101):
            check_house(generate_house(rooms, seed), rooms)


def test_milk_and_sugar_join_the_house():
    doc = generate_house(3, 5, ("mug", "kettle", "teabag", "milk", "sugar"))
    plain = generate_house(3, 5)
    assert doc["house"] == plain["house"] and doc["sites"] == plain["sites"]  # objects do not move walls
    scenario = parse_scenario(doc, "<test>")
    assert [o.category for o in scenario.objects] == list(CATEGORIES)
    assert scenario.object("milk").asset == "milk" and not scenario.object("sugar").state_priors
    model = load_model("factorised")
    runner = EpisodeRunner(scenario, model, FakeHouse(scenario, env_config_for(model)), RunConfig(seed=0))
    runner.run()
    assert runner.metrics()["success"]


def test_same_seed_same_bytes_and_seeds_differ(tmp_path):
    text = house_json(generate_house(5, 3))
    assert house_json(generate_house(5, 3)) == text
    assert house_json(generate_house(5, 4)) != text
    assert generate_house(5, 4)["house"] != generate_house(5, 3)["house"]
    for name in ("a.json", "b.json"):
        assert main(["house", "--rooms", "5", "--seed", "3", "--out", str(tmp_path / name)]) == 0
    assert (tmp_path / "a.json").read_text() == (tmp_path / "b.json").read_text() == text


@pytest.mark.parametrize("stem,rooms", [("generated_small", 3), ("generated_medium", 6), ("generated_large", 10)])
def test_shipped_houses_are_what_the_command_writes(stem, rooms):
    path = ROOT / "scenarios" / f"{stem}.json"
    assert f"fg-tea house --rooms {rooms} --seed 0 --name {stem}" in json.loads(path.read_text())["description"]
    assert path.read_text() == house_json(generate_house(rooms, 0, name=stem))
    assert len(load_scenario(path).objects) == 3


@pytest.mark.parametrize("args,words", [
    (["--rooms", "2"], "--rooms"), (["--rooms", "11"], "--rooms"), (["--seed", "-1"], "--seed"),
    (["--objects", "mug,kettle,spoon"], "'spoon'"), (["--objects", "mug,kettle"], "teabag"),
    (["--sites-per-room", "0"], "--sites-per-room"),
])
def test_cli_bad_input_exits_2_with_one_line(tmp_path, capsys, args, words):
    argv = ["house", "--rooms", "3", "--out", str(tmp_path / "h.json")] + args
    try:
        status = main(argv)
    except SystemExit as exc:  # a flag's range is argparse's to report
        status = exc.code
    assert status == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err and not (tmp_path / "h.json").exists()


def test_cli_unwritable_out_exits_2(tmp_path, capsys):
    assert main(["house", "--rooms", "3", "--out", str(tmp_path)]) == 2
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["house", "--rooms", "3", "--out", str(blocker / "h.json")]) == 2
    assert capsys.readouterr().err.count("\n") == 2


def test_generated_world_draws_a_house_per_world_seed():
    world = load_world("generated_small")
    assert world.sample(4) == world.sample(4)
    houses = {w.house for w in map(world.sample, range(5))}
    assert len(houses) == 5
    assert world.house_columns(4) == {"house_seed": 4, "house_rooms": 3,
                                      "house_sites": len(world.sample(4).sites),
                                      "house_room_vantages": len(world.sample(4).room_vantages)}
    assert world.sample(4).house == parse_scenario(generate_house(3, 4), "<x>").house
    data = json.loads((ROOT / "scenarios/worlds/generated_small.json").read_text())
    data["generate"]["rooms"] = [3, 6]
    ranged = parse_world(data, "w.json")
    assert {ranged.generate.draw(s)[0] for s in range(40)} == {3, 4, 5, 6}
    water = [world.sample(s).object("kettle").hidden_state_truth["contains_water"] for s in range(40)]
    assert 0 < sum(water) < 40  # drawn from its prior


def test_a_floor_plan_whose_room_cannot_be_furnished_is_replaced_by_the_next_plan():
    # 6 rooms, seed 80: the first floor plan's kitchen cannot hold its furniture in any of its
    # draws, so the generator falls back to the seed's second plan instead of failing the world.
    from fg_tea.world import housegen

    first, why = housegen._attempt_house(6, 80, 0, housegen.check_arguments(6, 80, housegen.DEFAULT_OBJECTS), None)
    assert first is None and "could not be furnished" in why
    doc = generate_house(6, 80)
    scenario = parse_scenario(doc, "<x>")
    assert len(scenario.sites) > 0 and doc == generate_house(6, 80)


@pytest.mark.parametrize("edit,path", [
    (lambda d: d.__setitem__("base_scenario", "default_apartment"), "$.generate"),
    (lambda d: d["generate"].__setitem__("rooms", [2, 4]), "$.generate.rooms"),
    (lambda d: d["generate"].__setitem__("rooms", [5, 4]), "$.generate.rooms"),
    (lambda d: d["generate"].__setitem__("objects", ["mug", "kettle", "tea"]), "$.generate.objects"),
    (lambda d: d["states"].__setitem__("milk.cold", "prior"), "$.states.milk.cold"),
])
def test_bad_generate_fields_name_the_field(edit, path):
    data = json.loads((ROOT / "scenarios/worlds/generated_small.json").read_text())
    edit(data)
    with pytest.raises(InputError) as info:
        parse_world(data, "w.json")
    assert info.value.path == path


def test_the_generator_does_not_import_the_simulator():
    code = "import sys, fg_tea.world.housegen, fg_tea.world.distributions; print('pybullet' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize("stem,rooms,seed", [("small_6", 3, 1), ("small_8", 4, 2), ("small_12", 6, 2), ("small_12b", 6, 3),
                                            ("small_16", 8, 2)])
def test_small_houses_keep_the_first_sites_of_each_room(stem, rooms, seed, tmp_path):
    from fg_tea.world.scenario import keep_sites

    full = generate_house(rooms, seed, name=stem)
    doc = keep_sites(full, 2)
    path = ROOT / "scenarios" / f"{stem}.json"
    assert path.read_text() == house_json(doc), "the bundled house is what the command writes"
    assert main(["house", "--rooms", str(rooms), "--seed", str(seed), "--sites-per-room", "2",
                 "--name", stem, "--out", str(tmp_path / "h.json")]) == 0
    assert (tmp_path / "h.json").read_text() == path.read_text()
    by_room = Counter(s["room"] for s in doc["sites"])
    assert set(by_room) == {s["room"] for s in full["sites"]} and set(by_room.values()) == {2}
    kept = [s["name"] for s in doc["sites"]]
    assert doc["preparation_site"] in kept and doc["house"] == full["house"]  # the furniture stays
    for room in by_room:  # the first of each room, the preparation site among them
        first = [s["name"] for s in full["sites"] if s["room"] == room]
        assert [n for n in kept if n in first] == [n for n in first if n in kept]
    assert all(o["true_site"] in kept for o in doc["objects"])
    scenario = parse_scenario(doc)
    assert len(scenario.sites) == 2 * rooms and f"{2 * rooms} semantic sites" in doc["description"]
    with pytest.raises(ValueError, match="1 or more"):
        keep_sites(full, 0)
