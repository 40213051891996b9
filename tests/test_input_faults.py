"""Hostile input: every bad file, flag and output place ends in one line and exit status 2.

Each reproduction of a fault found by a hostile-user trial is one parametrised case below; a seeded
mutator then fuzzes the bundled scenario, model, task and world files and the flags of `run`, and
every case must end with exit 0, or exit 2 and exactly one ``fg-tea: error:`` line — never a
traceback, never a hang (each case runs under an alarm).
"""

from __future__ import annotations

import contextlib
import copy
import errno
import io
import json
import os
import pickle
import random
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from fg_tea.cli import main
from fg_tea.common.errors import InputError
from houses import set_at

ROOT = Path(__file__).resolve().parent.parent
SCENARIO = json.loads((ROOT / "scenarios" / "default_apartment.json").read_text())
WORLD = json.loads((ROOT / "scenarios" / "worlds" / "correlated.json").read_text())
TASK = json.loads((ROOT / "scenarios" / "tasks" / "make_tea.json").read_text())
FACTORISED = (ROOT / "models" / "factorised.toml").read_text()
# A hang guard, not a speed test: the alarm only turns a CLI call that never returns into a failure
# instead of a stuck suite. Ten minutes per call, so a loaded 2-core machine never trips it; timing
# belongs in experiments/ (benchmarks), and no test here asserts how long anything took.
CASE_SECONDS = 600


class _Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise _Timeout(f"CLI call still running after {CASE_SECONDS} s: a hang")


def cli(argv, seconds: int = CASE_SECONDS) -> tuple[int, str, str]:
    """Run ``fg-tea argv`` in-process; return (exit status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(seconds)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                status = main([str(a) for a in argv])
            except SystemExit as exc:  # argparse usage errors
                status = exc.code
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    return status, out.getvalue(), err.getvalue()


def assert_one_line_error(status, stderr, *words):
    assert status == 2, stderr
    lines = stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("fg-tea: error: "), stderr
    assert "Traceback" not in stderr
    for word in words:
        assert word in lines[0], (word, lines[0])


def _scenario(edit):
    data = copy.deepcopy(SCENARIO)
    edit(data)
    return data


def _world(edit):
    data = copy.deepcopy(WORLD)
    data["base_scenario"] = str(ROOT / "scenarios" / "default_apartment.json")
    edit(data)
    return data


# ------------------------------------------------------------------------------ file faults
def _bytes(content: bytes, suffix=".json"):
    def make(tmp):
        path = tmp / f"bad{suffix}"
        path.write_bytes(content)
        return path
    return make


def _json(data, name="bad.json"):
    def make(tmp):
        path = tmp / name
        path.write_text(json.dumps(data))
        return path
    return make


def _text(text, name="bad.toml"):
    def make(tmp):
        path = tmp / name
        path.write_text(text)
        return path
    return make


def _directory(tmp):
    (tmp / "folder.json").mkdir()
    return tmp / "folder.json"


def _symlink_loop(tmp):
    os.symlink(tmp / "b.json", tmp / "a.json")
    os.symlink(tmp / "a.json", tmp / "b.json")
    return tmp / "a.json"


def _fifo(tmp):
    os.mkfifo(tmp / "pipe.json")
    return tmp / "pipe.json"


def _extends_chain(tmp):
    n = 1500
    for i in range(n):
        parent = f"chain{i + 1}" if i < n - 1 else "factorised"
        (tmp / f"chain{i}.toml").write_text(f'extends = "{parent}"\nname = "c{i}"\n')
    return tmp / "chain0.toml"


def _inherited_fault(tmp):
    (tmp / "parent.toml").write_text(FACTORISED.replace("[planning]", "[planning]\nbogus_weight = 1"))
    (tmp / "child.toml").write_text('extends = "parent"\nname = "child"\n')
    return tmp / "child.toml"


def _many_states(data):
    data["objects"][2]["state_priors"].update({f"s{i}": 0.5 for i in range(25)})




def _duplicate_site_name(tmp):
    path = tmp / "dup.json"
    text = json.dumps(SCENARIO)
    first = '"name": "kitchen_counter"'
    assert text.count(first) == 1
    path.write_text(text.replace(first, first + ', "name": "pantry_shelf"'))
    return path


MODEL_HEAD = 'extends = "factorised"\nname = "m"\n'

FILE_FAULTS = [
    # (id, maker, words expected in the one line)
    ("non-utf8 json", _bytes(b'{"name": "caf\xe9"}'), ("not UTF-8",)),
    ("non-utf8 toml", _bytes(b'name = "caf\xe9"\n', ".toml"), ("not UTF-8",)),
    ("directory", _directory, ("is a directory",)),
    ("symlink loop", _symlink_loop, ("symbolic links",)),
    ("fifo", _fifo, ("not a regular file",)),
    ("deep json", _bytes(b"[" * 5000 + b"]" * 5000), ("nested",)),
    ("deep toml", _bytes(b"x = " + b"[" * 5000 + b"]" * 5000 + b"\n", ".toml"), ("nested",)),
    ("huge integer", _bytes(b'{"schema_version": ' + b"9" * 5000 + b"}"), ("4300 digits",)),
    ("extends empty", _text('extends = ""\nname = "x"\n'), ("$.extends", "does not name")),
    ("extends dot", _text('extends = "."\nname = "x"\n'), ("$.extends",)),
    ("extends dotdot", _text('extends = ".."\nname = "x"\n'), ("$.extends",)),
    ("extends root", _text('extends = "/"\nname = "x"\n'), ("$.extends",)),
    ("extends long name", _text(f'extends = "{"x" * 5000}"\nname = "x"\n'), ("$.extends", "too long")),
    ("extends chain", _extends_chain, ("$.extends", "longer than")),
    ("lone surrogate", _json(_scenario(lambda d: d["sites"][0].__setitem__("room", "\ud800"))),
     ("$.sites[0].room", "surrogate")),
    ("nan yaw", _json(_scenario(set_at(["start_pose", "yaw_deg"], float("nan")))),
     ("$.start_pose.yaw_deg", "finite")),
    ("infinite affordance", _json(_scenario(set_at(["sites", 0, "affordances", "mug"], float("inf")))),
     ("$.sites[0].affordances.mug", "finite")),
    ("1e308 affordance", _json(_scenario(set_at(["sites", 0, "affordances", "mug"], 1e308))),
     ("$.sites[0].affordances.mug", "out of range")),
    ("1e308 wall", _json(_scenario(set_at(["house", "walls", 0, "to"], [1e308, 0]))),
     ("$.house.walls[0].to[0]", "out of range")),
    ("1e5 coordinate", _json(_scenario(set_at(["start_pose", "position"], [1e5, 3.4]))),
     ("$.start_pose.position[0]", "out of range")),
    ("nan model weight", _text(MODEL_HEAD + "[planning]\ndistance_weight = nan\n"),
     ("$.planning.distance_weight", "finite")),
    ("too many states", _json(_scenario(_many_states)), ("$.objects", "at most 20")),
    ("no objects", _json(_scenario(set_at(["objects"], []))), ("$.objects", "at least one object")),
    ("misspelt model key", _text(MODEL_HEAD + '[beliefs]\nstrcture = "joint"\n'),
     ("$.beliefs.strcture", "did you mean 'structure'")),
    ("misspelt model table", _text(MODEL_HEAD + "[planing]\ninformation_weight = 0\n"),
     ("$.planing", "did you mean 'planning'")),
    ("misspelt scenario key", _json(_scenario(set_at(["sites", 0, "capacty"], 1))),
     ("$.sites[0].capacty", "did you mean 'capacity'")),
    ("misspelt top-level key", _json(_scenario(set_at(["preparaton_site"], "sideboard"))),
     ("$.preparaton_site", "did you mean 'preparation_site'")),
    ("misspelt world key", _json(_world(set_at(["placement", "prior_violaton"], 0.2)), "w.json"),
     ("$.placement.prior_violaton", "did you mean 'prior_violation'")),
    ("vantage in furniture", _json(_scenario(set_at(["sites", 0, "vantage_position"], [2.0, 0.35, 0.0]))),
     ("$.sites[0].vantage_position", "not on free floor")),
    ("vantage in a wall", _json(_scenario(set_at(["sites", 1, "vantage_position"], [1.0, 4.0, 0.0]))),
     ("$.sites[1].vantage_position", "not on free floor")),
    ("vantage off the floor", _json(_scenario(set_at(["sites", 1, "vantage_position"], [-3.0, 2.8, 0.0]))),
     ("$.sites[1].vantage_position",)),
    ("vantage unreachable", _json(_scenario(lambda d: d["house"]["walls"][6].pop("doorways"))),
     ("$.sites[7].vantage_position", "not reachable from the start")),
    ("lone surrogate in a site name", _json(_scenario(lambda d: d["sites"][0].__setitem__("name", "k\ud800"))),
     ("$.sites[0].name", "surrogate")),
    ("vantage far from site", _json(_scenario(set_at(["sites", 0, "vantage_position"], [2.0, 4.8, 0.0]))),
     ("$.sites[0].vantage_position", "at most 4 m")),
    ("surface below floor", _json(_scenario(set_at(["sites", 0, "position"], [2.0, 0.35, -1.0]))),
     ("$.sites[0].position", "below the floor")),
    ("nan size", _json(_scenario(set_at(["house", "furniture", 0, "size"], [float("nan"), 1, 1]))),
     ("$.house.furniture[0].size[0]", "finite")),
    ("zero size", _json(_scenario(set_at(["house", "furniture", 0, "size"], [0, 1, 1]))),
     ("$.house.furniture[0].size", "positive")),
    ("duplicate order", _json(_world(set_at(["placement", "order"], ["kettle", "kettle", "mug"])), "w.json"),
     ("$.placement.order[1]", "twice")),
    ("self anchor", _json(_world(lambda d: d["placement"]["co_location"][0].__setitem__("anchor", "teabag")),
                          "w.json"), ("$.placement.co_location[0].anchor", "own anchor")),
    ("duplicate co_location", _json(_world(lambda d: d["placement"]["co_location"].append(
        dict(d["placement"]["co_location"][0]))), "w.json"), ("$.placement.co_location[1]", "already")),
    ("inherited fault", _inherited_fault, ("parent.toml", "$.planning.bogus_weight", "unknown field")),
    # Duplicate JSON keys: JSON keeps the last value silently (TOML refuses them itself).
    ("duplicate top-level key", _bytes(b'{"schema_version": 2, "name": "a", "name": "b"}'),
     ("$.name", "duplicate key")),
    ("duplicate nested key", _duplicate_site_name, ("$.sites[0].name", "duplicate key")),
    # Scenario geometry (docs/design.md §8.1: a site is the top of its furniture).
    ("colour above 1", _json(_scenario(set_at(["house", "furniture", 0, "color"], [1.2, 0.5, 0.5, 1]))),
     ("$.house.furniture[0].color[0]", "outside [0, 1]")),
    ("negative colour", _json(_scenario(set_at(["house", "furniture", 1, "color"], [0.5, -0.1, 0.5]))),
     ("$.house.furniture[1].color[1]", "outside [0, 1]")),
    ("100 m box", _json(_scenario(set_at(["house", "furniture", 0, "size"], [2.6, 0.6, 100]))),
     ("$.house.furniture[0].size", "taller than the walls")),
    ("surface below its furniture top", _json(_scenario(set_at(["sites", 0, "position"], [2.0, 0.35, 0.5]))),
     ("$.sites[0].position", "furniture 'counter'", "0.92")),
    ("surface above its furniture top", _json(_scenario(set_at(["sites", 1, "position"], [0.35, 2.8, 1.5]))),
     ("$.sites[1].position", "furniture 'pantry_shelf'")),
    ("furniture off the floor", _json(_scenario(set_at(["house", "furniture", 0, "center"], [2.0, -0.1]))),
     ("$.house.furniture[0]", "outside the floor")),
    ("overlapping furniture", _json(_scenario(set_at(["house", "furniture", 4, "center"], [2.5, 0.9]))),
     ("$.house.furniture[4]", "overlaps furniture 'counter'")),
    # Model faults that `run` refused (or crashed on) but validate passed.
    ("requires a state twice", _text(MODEL_HEAD + '[transitions.boil]\neffects = [{ state = '
                                     '"{object}.water_hot", value = true, success = 0.9, requires = '
                                     '["{object}.contains_water", "{object}.contains_water"] }]\n'),
     ("$.transitions.boil.effects[0].requires[1]", "twice")),
    ("sets a state twice", _text(MODEL_HEAD + '[transitions.fill]\neffects = [{ state = '
                                 '"{object}.contains_water", value = true, success = 0.9 }, { state = '
                                 '"{object}.contains_water", value = false, success = 0.9 }]\n'),
     ("$.transitions.fill.effects[1].state", "twice")),
    ("empty state name", _text(MODEL_HEAD + '[transitions.fill]\neffects = [{ state = "", value = true, '
                               'success = 0.9 }]\n'), ("$.transitions.fill.effects[0].state", "empty")),
    ("state without object", _text(MODEL_HEAD + '[transitions.fill]\neffects = [{ state = "{object}.", '
                                   'value = true, success = 0.9 }]\n'),
     ("$.transitions.fill.effects[0].state", "object.state")),
    ("unknown role", _text(MODEL_HEAD + '[transitions.fill]\neffects = [{ state = "{nobody}.contains_water", '
                           'value = true, success = 0.9 }]\n'),
     ("$.transitions.fill.effects[0].state", "unknown role {nobody}")),
    ("unknown role in a goal", _text(MODEL_HEAD + '[transitions.fill]\ngoals = [{ state = "{nobody}.x", '
                                     'at_least = 0.9 }]\n'), ("$.transitions.fill.goals[0].state", "{nobody}")),
    ("empty model name", _text('extends = "factorised"\nname = " "\n'), ("$.name", "empty")),
]



@pytest.mark.parametrize("make,words", [f[1:] for f in FILE_FAULTS], ids=[f[0] for f in FILE_FAULTS])
def test_bad_file_is_one_line_with_exit_2(tmp_path, make, words):
    path = make(tmp_path)
    status, _, err = cli(["validate", path])
    assert_one_line_error(status, err, *words)


def _set_affordances(obj, affordances):
    return set_at(["objects", obj, "affordances"], affordances)


def _task(edit):
    data = copy.deepcopy(TASK)
    edit(data)
    return data


# (id, scenario edit, task edit, model text or None, words): `validate TASK --scenario S --model M`
# makes every check `run` makes before its first step (docs/design.md §7.5 affordances).
TASK_FAULTS = [
    ("object affordance no verb knows", _set_affordances(1, ["graspable", "fillable", "pourable",
                                                             "heatable", "levitating"]),
     lambda t: None, None, ("$.actions[8].object", "'kettle'", "'levitating'")),
    ("misspelt fixed affordance", _set_affordances(1, ["graspabel", "fillable", "pourable", "heatable"]),
     lambda t: None, None, ("$.actions[8].object", "'graspabel'", "did you mean 'graspable'")),
    ("misspelt object affordance", _set_affordances(1, ["graspable", "fillable", "pourable", "heatible"]),
     lambda t: None, None, ("$.actions[11].requires_affordance", "boil_kettle", "'heatable'")),
    ("requires an affordance no object has", lambda d: None,
     set_at(["actions", 11, "requires_affordance"], "boilable"), None,
     ("$.actions[11].requires_affordance", "boil_kettle", "'boilable'")),
    ("requires an affordance its object lacks", lambda d: None,
     set_at(["actions", 17, "requires_affordance"], "heatable"), None,
     ("$.actions[17].requires_affordance", "serve_tea", "'mug'", "'heatable'")),
    ("scenario the navigator refuses", lambda d: d["house"]["walls"][6].pop("doorways"), lambda t: None,
     None, ("$.sites[7].vantage_position", "not reachable from the start")),
    ("a filled-in state required twice", lambda d: None, lambda t: None,
     MODEL_HEAD + '[transitions.boil]\neffects = [{ state = "{object}.water_hot", value = true, '
     'success = 0.9, requires = ["{object}.contains_water", "kettle.contains_water"] }]\n',
     ("$.actions[11].transition", "'kettle.contains_water'", "twice")),
]


@pytest.mark.parametrize("scenario_edit,task_edit,model,words", [f[1:] for f in TASK_FAULTS],
                         ids=[f[0] for f in TASK_FAULTS])
def test_task_fault_against_its_scenario_is_one_line(tmp_path, scenario_edit, task_edit, model, words):
    scenario, task = tmp_path / "s.json", tmp_path / "tasks" / "t.json"
    task.parent.mkdir()
    scenario.write_text(json.dumps(_scenario(scenario_edit)))
    task.write_text(json.dumps(_task(task_edit)))
    argv = ["validate", task, "--scenario", scenario]
    if model is not None:
        (tmp_path / "m.toml").write_text(model)
        argv += ["--model", tmp_path / "m.toml"]
    status, _, err = cli(argv)
    assert_one_line_error(status, err, *words)


def test_furniture_that_touches_is_accepted(tmp_path):
    path = tmp_path / "touch.json"
    path.write_text(json.dumps(_scenario(lambda d: d["house"]["furniture"].append(
        {"name": "stool", "center": [9.0, 0.2], "size": [0.6, 0.3, 0.4]}))))  # x 8.7-9.3: touches side_table
    status, _, err = cli(["validate", path])
    assert status == 0, err


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_every_bundled_task_validates_against_every_bundled_scenario_holding_its_objects():
    from fg_tea.common.resources import bundled
    from fg_tea.world.scenario import load_scenario

    checked = 0
    for task_path in sorted(ROOT.glob("scenarios/tasks/*.json")):
        task = json.loads(task_path.read_text())
        names = {a.get(k) for a in task["actions"] for k in ("object", "destination")} - {None}
        for scenario_path in bundled("scenarios", ".json"):
            if names <= set(load_scenario(scenario_path).object_names):
                status, _, err = cli(["validate", task_path, "--scenario", scenario_path])
                assert status == 0, (task_path.name, scenario_path.name, err)
                checked += 1
    assert checked >= 3


@pytest.mark.parametrize("seed", [1, 3, 7, 12])
def test_generated_houses_validate(tmp_path, seed):
    out = tmp_path / f"h{seed}.json"
    status, _, err = cli(["house", "--rooms", "10", "--seed", seed, "--out", out])
    assert status == 0, err
    status, _, err = cli(["validate", out])
    assert status == 0, err


@pytest.mark.parametrize("name", ["bare.json", "task_elsewhere.json"])
def test_world_and_task_files_are_recognised_by_content(tmp_path, name):
    world = tmp_path / "bare.json"
    world.write_text(json.dumps(_world(lambda d: None)))
    task = tmp_path / "task_elsewhere.json"
    task.write_text(json.dumps(TASK))
    status, out, err = cli(["validate", tmp_path / name])
    assert status == 0, err
    assert out.strip().endswith("ok (world)" if name == "bare.json" else "ok (task)")


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_every_bundled_file_validates():
    files = sorted(ROOT.glob("scenarios/*.json")) + sorted(ROOT.glob("scenarios/tasks/*.json")) + \
        sorted(ROOT.glob("scenarios/worlds/*.json")) + sorted(ROOT.glob("models/**/*.toml"))
    status, out, err = cli(["validate", *files])
    assert status == 0, err
    assert out.count(": ok") == len(files)


VISIBILITY_MODEL = MODEL_HEAD + textwrap.dedent("""
    [perception]
    detector = "visibility"
    [perception.visibility]
    half_pixels = 40
    max_probability = 0.97
    [perception.visibility.categories.mug]
    half_pixels = 30
    [perception.visibility.categories.teabag]
    slope = 1.5
    [viewpoints]
    room_glances = true
""")


def test_free_form_name_tables_and_new_keys_are_accepted(tmp_path):
    model = tmp_path / "vis.toml"
    model.write_text(VISIBILITY_MODEL)
    scenario = tmp_path / "rv.json"
    scenario.write_text(json.dumps(_scenario(set_at(["room_vantages"], [
        {"name": "kitchen_glance", "room": SCENARIO["sites"][0]["room"], "position": [2.0, 1.6]}]))))
    status, out, err = cli(["validate", model, scenario])
    assert status == 0, err
    model.write_text(VISIBILITY_MODEL.replace("slope = 1.5", "slop = 1.5"))
    status, _, err = cli(["validate", model])
    assert_one_line_error(status, err, "$.perception.visibility.categories.teabag.slop", "'slope'")


def test_task_fault_names_the_task_file(tmp_path):
    task = copy.deepcopy(TASK)
    task["actions"][0]["dependson"] = []
    path = tmp_path / "t.json"
    path.write_text(json.dumps(task))
    status, _, err = cli(["validate", path])
    assert_one_line_error(status, err, "$.actions[0].dependson", "did you mean 'depends_on'")


# ------------------------------------------------------------------------------ flag faults
BAD_FLAGS = [
    ["run", "--seed", "-1"],
    ["compare", "--first-seed", "-1"],
    ["run", "--fps", "-30"], ["run", "--fps", "0"],
    ["run", "--inset-scale", "0"], ["run", "--inset-scale", "-1"], ["run", "--inset-scale", "5"],
    ["run", "--inset-scale", "nan"],
    ["run", "--max-frames", "0"], ["run", "--max-frames", "-5"],
    ["run", "--min-visible-pixels", "-1"],
    ["run", "--hold", "-1"], ["run", "--hold", "inf"],
    ["run", "--third-person-hfov", "0"], ["run", "--third-person-hfov", "180"],
    ["run", "--wall-cutaway", "-1"], ["run", "--workers", "-3"], ["render", "x.jsonl", "--workers", "-3"],
    ["run", "--failure-rate", "SEARCH=1.0"], ["run", "--failure-rate", "INSPECT=1.0"],
    ["run", "--failure-rate", "FILL=2"], ["run", "--failure-rate", "FLY=0.5"],
    ["run", "--width", "100000"],
    ["run", "generated_medium", "--planner", "optimal"],  # 27 sites: the exact planner refuses
]


@pytest.mark.parametrize("argv", BAD_FLAGS, ids=[" ".join(a) for a in BAD_FLAGS])
def test_bad_flag_is_one_line_with_exit_2(argv, tmp_path):
    status, _, err = cli([*argv, "--out", tmp_path / "out"] if argv[0] == "run" else argv)
    assert_one_line_error(status, err)


def test_inset_that_does_not_fit_the_frame(tmp_path):
    status, _, err = cli(["run", "--width", "1920", "--height", "64", "--inset-scale", "0.5",
                          "--out", tmp_path / "o"])
    assert_one_line_error(status, err, "--inset-scale")


# ------------------------------------------------------------------------------ output places
@pytest.fixture
def a_file(tmp_path):
    path = tmp_path / "plain"
    path.write_text("x")
    return path


@pytest.fixture(scope="module")
def short_log(tmp_path_factory):
    out = tmp_path_factory.mktemp("short")
    status, _, err = cli(["run", "--no-video", "--max-frames", "300", "--out", out])
    assert status in (0, 1), err
    return out / "episode.jsonl"


@pytest.mark.parametrize("command", ["run", "compare", "render", "preview"])
@pytest.mark.parametrize("where", ["existing file", "under a file", "/dev/null", "/proc"])
def test_unwritable_out_is_one_line(command, where, a_file, short_log):
    target = {"existing file": a_file, "under a file": a_file / "sub", "/dev/null": Path("/dev/null"),
              "/proc": Path("/proc/fg-tea-test")}[where]
    if command in ("render", "preview"):  # these write a file: an existing folder is the fault
        target = {"existing file": a_file.parent, "under a file": a_file / "x.mp4",
                  "/dev/null": target, "/proc": Path("/proc/x.mp4")}[where]
    argv = {"run": ["run", "--no-video", "--max-frames", "5"], "compare": ["compare", "--quick"],
            "render": ["render", short_log], "preview": ["preview"]}[command]
    status, _, err = cli([*argv, "--out", target])
    assert_one_line_error(status, err, "--out")


def test_scenario_name_cannot_escape_the_output_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "s.json"
    path.write_text(json.dumps(_scenario(set_at(["name"], "../../escaped"))))
    status, _, err = cli(["run", path, "--no-video", "--max-frames", "5"])
    assert status in (0, 1), err
    written = [p for p in tmp_path.rglob("episode.jsonl")]
    assert len(written) == 1 and (tmp_path / "runs") in written[0].parents


def test_rerun_replaces_every_output_of_the_run(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "episode.mp4").write_bytes(b"old video")
    (out / "timings.json").write_text("{}")
    (out / ".episode.mp4.tmp999999999.mp4").write_bytes(b"left by a killed writer")
    status, _, err = cli(["run", "--no-video", "--max-frames", "5", "--out", out])
    assert status in (0, 1), err
    assert not (out / "episode.mp4").exists()
    assert json.loads((out / "timings.json").read_text())["episode_s"] >= 0


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_compare_rerun_leaves_no_report_of_the_earlier_sweep(tmp_path):
    out = tmp_path / "c"
    base = ["compare", "--env", "fake", "--backend", "serial", "--worlds", "2", "--models",
            "factorised", "--out", out]
    status, _, err = cli([*base, "--planners", "nearest", "optimal"])
    assert status == 0, err
    assert (out / "ratio_to_optimal.png").exists() and "optimal" in (out / "summary.md").read_text()
    status, _, err = cli([*base, "--planners", "nearest", "--no-resume"])
    assert status == 0, err
    assert not (out / "ratio_to_optimal.png").exists()
    assert "optimal" not in (out / "summary.md").read_text()
    assert "optimal" not in (out / "episodes.csv").read_text()


# ------------------------------------------------------------------------------ faults of the machine
def test_disk_full_while_logging_is_one_line_and_leaves_whole_lines(tmp_path, monkeypatch):
    import fg_tea.episode.log as log

    real = log._write
    calls = {"n": 0}

    def write(fd, data):
        calls["n"] += 1
        if calls["n"] < 4:
            return real(fd, data)
        real(fd, data[: len(data) // 2])  # half a line reaches the disk, then it is full
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(tmp_path / "out" / "episode.jsonl"))

    monkeypatch.setattr(log, "_write", write)
    status, _, err = cli(["run", "--no-video", "--max-frames", "2000", "--out", tmp_path / "out"])
    assert_one_line_error(status, err, "No space left on device")
    text = (tmp_path / "out" / "episode.jsonl").read_text()
    assert text.endswith("\n") and len(text.splitlines()) == 3
    assert all(json.loads(line) for line in text.splitlines())


def test_disk_full_while_writing_timings_is_one_line(tmp_path, monkeypatch):
    import fg_tea.cli.run as cli_module

    def full(path, text):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(cli_module, "atomic_write_text", full)
    status, _, err = cli(["run", "--no-video", "--max-frames", "50", "--out", tmp_path / "out"])
    assert_one_line_error(status, err, "timings.json", "No space left on device")


def test_broken_pipe_ends_quietly(monkeypatch):
    class Closed(io.StringIO):
        def write(self, text):
            raise BrokenPipeError(errno.EPIPE, "Broken pipe")

    err = io.StringIO()
    monkeypatch.setattr(sys, "stdout", Closed())
    with contextlib.redirect_stderr(err):
        status = main(["validate", str(ROOT / "models" / "factorised.toml")])
    assert status == 141 and err.getvalue() == ""


def test_input_error_survives_pickling():
    exc = pickle.loads(pickle.dumps(InputError("f.json", "$.a", "bad")))
    assert (exc.file, exc.path, exc.fault, str(exc)) == ("f.json", "$.a", "bad", "f.json: $.a: bad")


def test_ray_address_with_nothing_listening_is_one_line_not_a_hang(tmp_path):
    pytest.importorskip("ray")
    status, _, err = cli(["compare", "--executor", "ray", "--address", "127.0.0.1:1", "--quick",
                          "--worlds", "1", "--out", tmp_path])
    assert_one_line_error(status, err, "--address")


def test_stale_render_folders_are_removed(tmp_path):
    from fg_tea.render.video import remove_stale_render_dirs

    dead, mine = tmp_path / ".render-999999999-abc", tmp_path / f".render-{os.getpid()}-def"
    dead.mkdir(), mine.mkdir()
    remove_stale_render_dirs(tmp_path)
    assert not dead.exists() and mine.exists()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux only")
@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_pool_workers_die_with_a_killed_parent(tmp_path):
    script = textwrap.dedent("""
        import os, sys, time
        from concurrent.futures import ProcessPoolExecutor
        from fg_tea.common.process import die_with_parent
        if __name__ == "__main__":
            pool = ProcessPoolExecutor(1, initializer=die_with_parent, initargs=(os.getpid(),))
            print(pool.submit(os.getpid).result(), flush=True)
            time.sleep(60)
    """)
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True,
                              cwd=ROOT)
    worker = int(parent.stdout.readline())
    parent.kill()
    parent.wait()
    for _ in range(1200):  # up to a minute, a hang guard for a loaded machine: a dead worker leaves at once
        try:
            os.kill(worker, 0)
        except ProcessLookupError:
            return
        time.sleep(0.05)
    os.kill(worker, signal.SIGKILL)
    pytest.fail("the pool worker outlived its killed parent")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux only")
@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_killed_compare_leaves_no_pool_workers(tmp_path):
    """kill -9 of `fg-tea compare` once its pool runs: its workers and resource tracker go too."""
    parent = subprocess.Popen([sys.executable, "-m", "fg_tea.cli", "compare", "--env", "fake",
                               "--worlds", "400", "--models", "factorised", "--planners", "efe",
                               "--workers", "2", "--out", str(tmp_path / "c")], cwd=ROOT,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    children: set[int] = set()
    deadline = time.monotonic() + 600  # a hang guard (a loaded machine is slow to start a pool)
    try:
        while time.monotonic() < deadline:  # until the pool is up and an episode is written
            children = {int(p) for p in subprocess.run(
                ["ps", "-o", "pid=", "--ppid", str(parent.pid)], capture_output=True,
                text=True).stdout.split()}
            csv = tmp_path / "c" / "episodes.csv"
            if len(children) >= 3 and csv.exists() and len(csv.read_text().splitlines()) > 2:
                break
            time.sleep(0.2)
        else:
            pytest.fail(f"compare did not start its pool in time (children {children})")
    finally:
        parent.kill()
        parent.wait()
    left = set(children)
    for _ in range(1200):  # up to a minute, a hang guard (as above)
        for pid in list(left):
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                left.discard(pid)
        if not left:
            return
        time.sleep(0.05)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    pytest.fail(f"processes {sorted(left)} outlived the killed compare")


# ------------------------------------------------------------------------------ fuzz
NASTY = [None, "", "x", "\ud800", -1, 0, 1, 2.5, -1e9, 1e308, float("nan"), float("inf"), True, [], {},
         [1, 2], {"a": 1}, "../../x", "kitchen_counter", "mug", "prior"]


def _paths(node, base=()):
    yield base
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, base + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, base + (i,))


def mutate_json(data, rng: random.Random):
    """One random structural mutation of a JSON document (a copy)."""
    data = copy.deepcopy(data)
    paths = [p for p in _paths(data) if p]
    path = rng.choice(paths)
    parent = data
    for key in path[:-1]:
        parent = parent[key]
    key = path[-1]
    kind = rng.randrange(5)
    if kind == 0:
        parent[key] = rng.choice(NASTY)
    elif kind == 1 and isinstance(parent, dict):
        value = parent.pop(key)
        if rng.random() < 0.5:  # a misspelling
            i = rng.randrange(len(key)) if key else 0
            parent[key[:i] + key[i + 1:] + "x"] = value
    elif kind == 1:
        parent.pop(key)
    elif kind == 2 and isinstance(parent, list):
        parent.append(copy.deepcopy(parent[key]))
    elif kind == 3 and isinstance(parent[key], (int, float)) and not isinstance(parent[key], bool):
        parent[key] = parent[key] * rng.choice([-1, 0, 1e6, 1e-6, 10])
    else:
        parent[key] = rng.choice(NASTY)
    return data


def _toml_value(rng):
    return rng.choice(['"x"', "-1", "0", "1e308", "nan", "inf", "true", "[]", "{}", '""', "2.5", '"joint"'])


def mutate_toml(text: str, rng: random.Random) -> str:
    lines = text.splitlines()
    i = rng.randrange(len(lines))
    kind = rng.randrange(4)
    line = lines[i]
    if kind == 0:
        del lines[i]
    elif kind == 1 and "=" in line:
        key, _, _ = line.partition("=")
        lines[i] = f"{key}= {_toml_value(rng)}"
    elif kind == 2 and "=" in line:
        key, _, value = line.partition("=")
        j = rng.randrange(max(len(key.strip()), 1))
        k = key.strip()
        lines[i] = f"{k[:j] + k[j + 1:]}x ={value}"
    else:
        lines.insert(i, f"{rng.choice(['[planning]', '[beliefs]', 'extends', 'name', 'zz'])} = {_toml_value(rng)}")
    return "\n".join(lines) + "\n"


def _fuzz_cases(n_json: int, n_toml: int, seed: int = 20240601):
    rng = random.Random(seed)
    documents = [("scenario", SCENARIO), ("task", TASK), ("world", _world(lambda d: None))]
    for i in range(n_json):
        kind, doc = documents[i % len(documents)]
        yield kind, "json", mutate_json(doc, rng)
    for i in range(n_toml):
        yield "model", "toml", mutate_toml(FACTORISED, rng)
    for i in range(n_json // 10):  # raw text damage
        raw = json.dumps(SCENARIO)
        cut = rng.randrange(len(raw))
        yield "scenario", "bytes", raw[:cut].encode() + bytes([rng.randrange(256)]) + raw[cut + 1:].encode()


@pytest.mark.slow
def test_fuzzed_files_end_in_ok_or_one_line(tmp_path):
    """Seeded mutations of every bundled file kind: exit 0, or exit 2 with one error line."""
    counts = {0: 0, 2: 0}
    for n, (kind, form, content) in enumerate(_fuzz_cases(n_json=240, n_toml=120)):
        folder = tmp_path / f"case{n}"
        folder.mkdir()
        path = folder / f"{kind}.{'toml' if form == 'toml' else 'json'}"
        if form == "json":
            path.write_text(json.dumps(content))
        elif form == "toml":
            path.write_text(content)
        else:
            path.write_bytes(content)
        status, _, err = cli(["validate", path])
        assert status in (0, 2), (kind, content, err)
        if status == 2:
            assert_one_line_error(status, err)
        else:
            assert err == "", err
        counts[status] += 1
    assert counts[2] > counts[0] > 0, counts  # most mutations are faults, some are harmless


def test_fuzzed_run_flags_end_in_ok_or_one_line(tmp_path):
    rng = random.Random(7)
    values = ["-1", "0", "1", "3", "nan", "inf", "1e308", "abc", "", "99999999999999999999"]
    flags = ["--seed", "--min-visible-pixels", "--max-frames", "--failure-rate", "--planner",
             "--preparation-site", "--backend", "--fps", "--hold", "--inset-scale"]
    for n in range(12):
        argv = ["run", "--no-video", "--out", tmp_path / f"r{n}"]
        for _ in range(2):
            flag = rng.choice(flags)
            value = rng.choice(values + (["FILL=0.5", "SEARCH=1", "PICK=-1"] if flag == "--failure-rate"
                                         else ["efe", "nearest"] if flag == "--planner" else []))
            argv += [flag, value]
        if "--max-frames" not in argv:
            argv += ["--max-frames", "50"]
        status, _, err = cli(argv)
        assert status in (0, 1, 2), (argv, err)
        if status == 2:
            assert_one_line_error(status, err)
        else:
            assert "Traceback" not in err


VALID = {"--width": ["640"] * 3, "--height": ["360"] * 3, "--fps": ["24"] * 3,
         "--inset-scale": ["0.25"] * 3, "--third-person-hfov": ["70"] * 3,
         "--wall-cutaway": ["0.5"] * 3, "--scene-scale": ["0.5"] * 3, "--view": ["first"] * 3,
         "--world": ["correlated"] * 3, "--models": ["joint"] * 3, "--planners": ["greedy"] * 3,
         "--backend": ["serial"] * 3, "--worlds": ["2"] * 3, "--first-seed": ["5"] * 3,
         "--workers": ["1"] * 3}


def test_fuzzed_compare_and_preview_flags_end_in_ok_or_one_line(tmp_path):
    rng = random.Random(11)
    values = ["-1", "0", "1", "2", "nan", "inf", "1e308", "abc", "", "99999999999999999999",
              "correlated", "factorised", "efe", "serial"]
    compare_flags = ["--worlds", "--first-seed", "--workers", "--world", "--models", "--planners",
                     "--backend"]
    seen = []
    preview_flags = ["--width", "--height", "--fps", "--inset-scale", "--third-person-hfov",
                     "--wall-cutaway", "--scene-scale", "--view"]
    for n in range(14):
        if n % 2 == 0:
            argv = ["compare", "--env", "fake", "--backend", "serial", "--worlds", "1",
                    "--models", "factorised", "--planners", "nearest", "--out", tmp_path / f"c{n}"]
            flags = compare_flags
        else:
            argv, flags = ["preview", "--out", tmp_path / f"p{n}.png"], preview_flags
        flag = rng.choice(flags)
        argv += [flag, rng.choice(values + VALID.get(flag, []))]
        if argv[0] == "compare" and argv[-2] == "--worlds" and argv[-1].isdigit():
            argv[-1] = str(min(int(argv[-1]), 2))  # keep the run short
        status, _, err = cli(argv)
        assert status in (0, 1, 2), (argv, err)
        seen.append(status)
        if status == 2:
            assert_one_line_error(status, err)
        else:
            assert "Traceback" not in err, (argv, err)
    assert 2 in seen and (0 in seen or 1 in seen), seen  # faults and clean runs both occur
