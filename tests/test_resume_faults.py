"""`compare --resume` on a damaged episodes.csv, rooms that are not rooms of the house, and
`--out ""`: one line and status 2, or the damage is repaired and said so."""

from __future__ import annotations

import csv
import json

import pytest

from fg_tea.cli.main import main
from fg_tea.common.resources import resolve_scenario

COMPARE = ["compare", "--planners", "greedy", "--env", "fake", "--worlds", "2", "--models",
           "factorised", "--executor", "serial", "--pages", "0"]


def _status(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:  # argparse reports a bad option value itself
        return int(exc.code or 0)


def _one_line(capsys) -> str:
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1, err
    assert "Traceback" not in err[0]
    return err[0]


# --------------------------------------------------------------------------- resume
def test_a_csv_that_is_not_utf8_is_one_line_and_status_2(tmp_path, capsys):
    out = tmp_path / "c"
    assert main(COMPARE + ["--out", str(out)]) == 0
    with (out / "episodes.csv").open("ab") as fh:
        fh.write(b"\xff\xfe not text\n")
    capsys.readouterr()
    assert main(COMPARE + ["--out", str(out)]) == 2
    line = _one_line(capsys)
    assert str(out / "episodes.csv") in line and "line 4" in line and "not UTF-8" in line, line


def test_rows_without_results_are_not_finished_episodes(tmp_path, capsys):
    out = tmp_path / "c"
    assert main(COMPARE + ["--out", str(out)]) == 0
    path = out / "episodes.csv"
    rows = list(csv.reader(path.open(newline="")))
    header, first = rows[0], dict(zip(rows[0], rows[1]))
    for row in rows[1:]:  # every cell but the key: NaN
        row[:] = [c if h == "key" else "nan" for h, c in zip(header, row)]
    with path.open("w", newline="") as fh:
        csv.writer(fh, lineterminator="\n").writerows(rows)
    capsys.readouterr()
    assert main(COMPARE + ["--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "2 rows of" in err and "no finished episode" in err and "run again" in err, err
    again = {r["key"]: r for r in csv.DictReader(path.open(newline=""))}
    assert len(again) == 2
    assert {r["success"] for r in again.values()} <= {"True", "False"}
    assert again[first["key"]]["total_distance"] == first["total_distance"]  # the same episode
    assert "nan" not in (out / "summary.md").read_text()


# --------------------------------------------------------------------------- rooms
def _scenario(tmp_path, edit) -> str:
    doc = json.loads(resolve_scenario("default_apartment").read_text())
    edit(doc)
    path = tmp_path / "house.json"
    path.write_text(json.dumps(doc))
    return str(path)


def _set_room(name, room):
    def edit(doc):
        next(s for s in doc["sites"] if s["name"] == name)["room"] = room
    return edit


@pytest.mark.parametrize("room, fault", [
    ("garage", "room 'garage' names no room of the house: the site stands in the room of "
               "'pantry_shelf' (named 'kitchen')"),
    ("study", "room 'study' is not the room the site stands in: the site stands in the room of "),
    ("", "a room name must not be empty"),
    ("   ", "a room name must not be empty"),
])
def test_a_site_in_no_room_of_the_house_is_refused(tmp_path, capsys, room, fault):
    path = _scenario(tmp_path, _set_room("kitchen_counter", room))
    assert main(["validate", path]) == 2
    line = _one_line(capsys)
    assert path in line and "$.sites[0].room" in line and fault in line, line


def test_a_room_named_two_ways_or_a_name_for_two_rooms_is_refused(tmp_path, capsys):
    def two_ways(doc):  # no room vantage to say which name the kitchen has
        doc["room_vantages"] = []
        _set_room("kitchen_counter", "galley")(doc)

    assert main(["validate", _scenario(tmp_path, two_ways)]) == 2
    line = _one_line(capsys)
    assert "$.sites[1].room: room 'kitchen' and room 'galley' are one walled room" in line, line

    def one_name(doc):  # the dining room's sites named as the living room's
        doc["room_vantages"] = []
        _set_room("dining_table", "living_room")(doc)
        _set_room("sideboard", "living_room")(doc)

    assert main(["validate", _scenario(tmp_path, one_name)]) == 2
    line = _one_line(capsys)
    assert "$.sites[2].room: room 'living_room' names two walled rooms: site 'coffee_table'" in line, line


def test_run_refuses_it_too(tmp_path, capsys):
    path = _scenario(tmp_path, _set_room("kitchen_counter", "garage"))
    assert main(["run", path, "--no-video", "--out", str(tmp_path / "t1")]) == 2
    assert "names no room of the house" in _one_line(capsys)
    assert not (tmp_path / "t1").exists()


def test_a_house_without_walls_names_its_rooms_freely():
    from houses import make_scenario

    s = make_scenario([("a", "kitchen", (0, 0), {"mug": 1.0}), ("b", "dining", (1, 0), {"mug": 1.0})],
                      [("mug", "mug", "a")])
    assert s.rooms == ("kitchen", "dining")


def test_every_bundled_scenario_passes():
    from fg_tea.common.resources import bundled_names
    from fg_tea.world.scenario import load_scenario

    for name in bundled_names("scenarios"):
        assert load_scenario(name).rooms


# --------------------------------------------------------------------------- --out ""
@pytest.mark.parametrize("argv", [
    ["run", "--no-video", "--max-frames", "1"],
    ["preview"],
    ["render", "episode.jsonl"],
    COMPARE[:-2] + ["--worlds", "1"],
    ["house", "--rooms", "3"],
    ["learn", "episode.jsonl"],
    ["explore", "episode.jsonl"],
])
def test_an_empty_out_is_refused_by_every_command(tmp_path, monkeypatch, capsys, argv):
    monkeypatch.chdir(tmp_path)
    assert _status(argv + ["--out", ""]) == 2
    line = _one_line(capsys)
    assert "--out" in line and "empty" in line, line
    assert not (tmp_path / "runs").exists()
