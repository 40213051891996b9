"""Model, task, world and camera files: what `fg-tea validate` accepts, `fg-tea run` runs.

Each case below is a file that was accepted and then crashed a run, was refused by a run, or
silently meant something else (a field read as absent, a model that cannot learn from a look).
Each is now refused by the loader in one line naming the file, the field and the fault. A seeded
mutator then damages the bundled model, task, world and camera files with boundary values, wrong
types, empty and repeated entries, and checks for each damaged file that ``fg-tea validate`` ends
in ``ok`` or in one error line, and that a file validate calls ok also runs: validate ok must mean
run ok.
"""

from __future__ import annotations

import copy
import json
import math
import random
import re
import tomllib
from pathlib import Path

import pytest

from test_input_faults import assert_one_line_error, cli

ROOT = Path(__file__).resolve().parent.parent
FACTORISED = (ROOT / "models" / "factorised.toml").read_text()
RUN_FRAMES = "300"  # a short episode: long enough to give up a search, plan and act


def _model(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def _edit(old: str, new: str) -> str:
    assert old in FACTORISED, old
    return FACTORISED.replace(old, new, 1)


def _refused(path: Path, *words: str, argv: tuple = ()) -> str:
    status, out, err = cli(["validate", *argv, path])
    assert_one_line_error(status, err, str(path), *words)
    return err


# ------------------------------------------------------------------------------ models
def test_give_up_probability_one_is_refused_not_divided_by(tmp_path):
    path = _model(tmp_path, "m", _edit("give_up_probability = 1e-3", "give_up_probability = 1"))
    _refused(path, "$.planning.give_up_probability", "below 1")


def test_a_give_up_probability_below_one_still_runs(tmp_path):
    path = _model(tmp_path, "m", _edit("give_up_probability = 1e-3", "give_up_probability = 0.5"))
    assert cli(["validate", path])[0] == 0
    status, _, err = cli(["run", "--no-video", "--max-frames", RUN_FRAMES, "--model", path,
                          "--out", tmp_path / "out"])
    assert status in (0, 1), err


@pytest.mark.parametrize("category", ["", "  "])
def test_a_relation_category_must_name_something(tmp_path, category):
    text = (ROOT / "models" / "joint.toml").read_text().replace('["teabag", "kettle"]',
                                                                  f'["{category}", "kettle"]')
    path = _model(tmp_path, "j", text)  # extends the bundled factorised model
    _refused(path, "$.relations[1].categories", "empty")


#: Model files that `fg-tea run` with its default scenario and task refused after `validate`
#: called them ok: each lacks something the default task (make_tea) needs from the model.
RUN_REFUSED = {
    "no_fill_transition": ('[transitions.fill]\neffects = [{ state = "{object}.contains_water", '
                           'value = true, success = 0.995 }]\ngoals = [{ state = "{object}.'
                           'contains_water", at_least = 0.90 }]\n', ""),
    "no_state_sensor": ("[sensors.state]", "[sensors.other]"),
    "misspelt_state": ('[{ state = "{object}.served"', '[{ state = "{object}.srved"'),
    "destination_in_fill": ('effects = [{ state = "{object}.contains_water", value = true, '
                            'success = 0.995 }]', 'effects = [{ state = "{destination}.contains_water",'
                            ' value = true, success = 0.995 }]'),
}


@pytest.mark.parametrize("case", sorted(RUN_REFUSED))
def test_validate_model_makes_the_checks_of_a_default_run(tmp_path, case):
    path = _model(tmp_path, case, _edit(*RUN_REFUSED[case]))
    err = _refused(path, "make_tea")
    status, _, run_err = cli(["run", "--no-video", "--max-frames", "50", "--model", path,
                              "--out", tmp_path / "out"])
    assert_one_line_error(status, run_err)  # the run refuses it too: validate told the truth


def test_validate_model_checks_against_the_task_and_scenario_named(tmp_path):
    path = _model(tmp_path, "nofill", _edit(*RUN_REFUSED["no_fill_transition"]))
    status, out, err = cli(["validate", "--task", "find_mug", path])
    assert status == 0 and out.strip().endswith("ok (model)"), err
    status, _, err = cli(["run", "--no-video", "--max-frames", "50", "--task", "find_mug",
                          "--model", path, "--out", tmp_path / "out"])
    assert status in (0, 1), err
    status, _, err = cli(["validate", "--task", "find_mug", "--scenario", "no_such_house", path])
    assert_one_line_error(status, err, "no_such_house")


@pytest.mark.parametrize("old, new, field, words", [
    ("prior_floor = 1e-4", "prior_floor = 1", "$.beliefs.prior_floor", "below 1"),
    ("miss_likelihood = 0.05", "miss_likelihood = 1", "$.detection.miss_likelihood", "below 1"),
    ("false_positive_rate = 1e-4", "false_positive_rate = 1", "$.detection.false_positive_rate",
     "miss_likelihood"),
    ("false_positive_rate = 1e-4", "false_positive_rate = 0.96", "$.detection.false_positive_rate",
     "miss_likelihood"),
    ("give_up_probability = 1e-3", "give_up_probability = 1e-3\nabsent_probability = 1e-300",
     "$.planning.absent_probability", "at least"),
    ("half_pixels = 50", "half_pixels = 1e-320", "$.perception.visibility.half_pixels", "at least 1"),
    ("slope = 3.0", "slope = 1e-320", "$.perception.visibility.slope", "at least"),
])
def test_boundary_values_that_make_the_model_degenerate_are_refused(tmp_path, old, new, field,
                                                                   words):
    path = _model(tmp_path, "m", _edit(old, new))
    _refused(path, field, words)


@pytest.mark.parametrize("value", ["0.5", '"fill"', "[]"])
def test_a_transition_that_is_not_a_table_is_refused_not_skipped(tmp_path, value):
    path = _model(tmp_path, "m", 'extends = "factorised"\nname = "m"\n[transitions]\n'
                  f'wait = {value}\n')
    _refused(path, "$.transitions.wait", "expected a table")


def test_a_visibility_model_without_its_curve_is_refused(tmp_path):
    text = _edit("[perception.visibility]\nhalf_pixels = 50\nslope = 3.0\nmax_probability = 0.95\n",
                 "")
    _refused(_model(tmp_path, "m", text), "$.perception.visibility", "missing")


# ------------------------------------------------------------------------------ cameras
def _camera(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "cam.toml"
    path.write_text(text)
    return path


def test_a_visibility_camera_without_its_curve_is_refused(tmp_path):
    path = _camera(tmp_path, 'name = "c"\n[camera]\ndetector = "visibility"\n')
    _refused(path, "$.camera.visibility", "missing")


def test_a_camera_curve_below_one_pixel_is_refused(tmp_path):
    text = (ROOT / "cameras" / "visibility.toml").read_text().replace("half_pixels = 50",
                                                                      "half_pixels = 1e-320")
    _refused(_camera(tmp_path, text), "$.camera.visibility.half_pixels", "at least 1")


# ------------------------------------------------------------------------------ null
def _json(tmp_path: Path, name: str, data) -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize("field", ["max_retries", "exclude_site", "reinspect"])
def test_null_in_a_task_recovery_field_is_refused(tmp_path, field):
    task = json.loads((ROOT / "scenarios" / "tasks" / "make_tea.json").read_text())
    task["actions"][0]["recovery"][field] = None
    path = _json(tmp_path, "t.json", task)
    _refused(path, f"$.actions[0].recovery.{field}", "null")


def test_null_as_a_world_order_is_refused(tmp_path):
    world = json.loads((ROOT / "scenarios" / "worlds" / "correlated.json").read_text())
    world["placement"]["order"] = None
    _refused(_json(tmp_path, "w.json", world), "$.placement.order", "null")


# ------------------------------------------------------------------------------ mutation
#: The values a mutation writes: the boundaries of every range, tiny and huge numbers, NaN and
#: infinities, the empty string, null (JSON only), a wrong type each way, empty containers.
BOUNDARY = (0, 1, -1, 0.5, 1e-320, 1e300, math.nan, math.inf, -math.inf, "", None, True, "x",
            [], {}, 2)
OPERATIONS = ("value", "value", "value", "delete", "empty", "duplicate", "wrong_type")
SOURCES = tuple(
    [("model", p) for p in sorted(ROOT.glob("models/*.toml"))]
    + [("task", p) for p in sorted(ROOT.glob("scenarios/tasks/*.json"))]
    + [("world", p) for p in sorted(ROOT.glob("scenarios/worlds/*.json"))]
    + [("camera", p) for p in sorted(ROOT.glob("cameras/*.toml"))])


def _read(path: Path) -> dict:
    return tomllib.loads(path.read_text()) if path.suffix == ".toml" else json.loads(path.read_text())


def _paths(doc, base: tuple = ()) -> list[tuple]:
    """Every key path of `doc` (containers and leaves), in document order."""
    out = []
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    for key, value in items:
        out.append(base + (key,))
        out.extend(_paths(value, base + (key,)))
    return out


def _wrong_type(value):
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, (int, float)):
        return str(value)
    if isinstance(value, str):
        return 1
    if isinstance(value, list):
        return {"0": value[0]} if value else {}
    if isinstance(value, dict):
        return list(value.values())
    return "x"


def mutate(doc: dict, rng: random.Random, toml: bool) -> tuple[dict, str]:
    """One seeded mutation of `doc`; returns the new document and what was done."""
    doc = copy.deepcopy(doc)
    paths = _paths(doc)
    path = paths[rng.randrange(len(paths))]
    parent = doc
    for key in path[:-1]:
        parent = parent[key]
    key, value = path[-1], parent[path[-1]]
    operation = rng.choice(OPERATIONS)
    if operation == "delete":
        del parent[key]
    elif operation == "empty" and isinstance(value, (list, dict)):
        parent[key] = type(value)()
    elif operation == "duplicate" and isinstance(value, list) and value:
        value.append(copy.deepcopy(value[rng.randrange(len(value))]))
    elif operation == "duplicate" and isinstance(parent, list):
        parent.append(copy.deepcopy(value))
    elif operation == "wrong_type":
        parent[key] = _wrong_type(value)
    else:
        operation = "value"
        choices = [b for b in BOUNDARY if not (toml and b is None)]
        parent[key] = rng.choice(choices)
    return doc, f"{operation} at {'.'.join(map(str, path))}" + (
        f" = {parent[key]!r}" if operation != "delete" and key in (parent if isinstance(parent, dict)
                                                                   else range(len(parent))) else "")


def _toml_key(key: str) -> str:
    return key if re.fullmatch(r"[A-Za-z0-9_-]+", key) else json.dumps(key)


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) \
            else repr(value)
    if isinstance(value, (int, str)):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items()) + "}"


def to_toml(doc: dict) -> str:
    """`doc` as TOML: one line per top-level key, every table inline."""
    return "".join(f"{_toml_key(k)} = {_toml_value(v)}\n" for k, v in doc.items())


def test_the_toml_writer_round_trips_every_bundled_toml_file():
    for _, path in SOURCES:
        if path.suffix == ".toml":
            assert tomllib.loads(to_toml(_read(path))) == _read(path), path


def _run_with(kind: str, path: Path, data, out: Path) -> tuple[int, str]:
    """Run a short headless episode that reads `path` as `fg-tea run` (or, for a world, one job
    of `fg-tea compare`) would; return (exit status, error text)."""
    head = ["run", "--no-video", "--max-frames", RUN_FRAMES, "--out", out]
    if kind == "model":
        status, _, err = cli(head + ["--model", path])
    elif kind == "camera":
        status, _, err = cli(head + ["--camera", path])
    elif kind == "task":
        from fg_tea.cli.validate import _scenario_for_task

        status, _, err = cli(head + [_scenario_for_task(data), "--task", path])
    else:
        from fg_tea.common.errors import InputError
        from fg_tea.study.sweep import Job, check_jobs, run_job

        job = Job(world=str(path), world_seed=0, model="factorised", planner="greedy", env="fake",
                  max_frames=int(RUN_FRAMES), max_steps=60, gtsam_check=False)
        try:
            check_jobs([job])
            run_job(job)
        except InputError as exc:
            return 2, f"fg-tea: error: {exc}"
        return 0, ""
    return status, err


def _validate_then_run(kind: str, source: Path, doc, folder: Path) -> tuple[str, str | None]:
    """Write `doc` as a file of `source`'s kind in `folder`, validate it and, if validate calls it
    ok, run it. Returns ("refused" or "ran", the fault found or None)."""
    folder.mkdir()
    path = folder / source.name
    path.write_text(to_toml(doc) if source.suffix == ".toml" else json.dumps(doc))
    try:
        status, _, err = cli(["validate", path])
        if status != 0:
            assert_one_line_error(status, err)
            return "refused", None
        status, err = _run_with(kind, path, doc, folder / "out")
    except Exception as exc:  # a traceback (or a second line): the fault this test hunts
        return "ran", f"{type(exc).__name__}: {exc}"
    return "ran", None if status in (0, 1) else f"validate ok, run refused it: {err.strip()}"


def _check_mutations(tmp_path: Path, cases: int, seed: int) -> dict:
    rng = random.Random(seed)
    counts = {"refused": 0, "ran": 0}
    faults = []
    for n in range(cases):
        kind, source = SOURCES[n % len(SOURCES)]
        doc, what = mutate(_read(source), rng, source.suffix == ".toml")
        outcome, fault = _validate_then_run(kind, source, doc, tmp_path / f"case{n}")
        counts[outcome] += 1
        if fault is not None:
            faults.append(f"{source.relative_to(ROOT)}: {what}: {fault}")
    assert not faults, "\n".join(faults[:20]) + f"\n({len(faults)} of {cases} cases)"
    return counts


def test_mutated_files_validate_in_one_line_and_run_when_valid(tmp_path):
    """Seeded mutations of every bundled model, task, world and camera file (a quick sample)."""
    counts = _check_mutations(tmp_path, cases=40, seed=1)
    assert counts["refused"] > 0 and counts["ran"] > 0, counts  # the mutator reaches both ends


@pytest.mark.slow
@pytest.mark.parametrize("seed", [2, 3])
def test_many_mutated_files_validate_in_one_line_and_run_when_valid(tmp_path, seed):
    counts = _check_mutations(tmp_path, cases=150, seed=seed)
    assert counts["refused"] > 0 and counts["ran"] > 0, counts


#: One file of each family for the boundary sweep (the milk-and-sugar and larger generated
#: variants repeat the same fields in longer episodes).
BOUNDARY_FILES = ("factorised.toml", "joint.toml", "joint_derived.toml", "visibility.toml",
                  "threshold.toml", "no_site_association.toml", "make_tea.json", "find_three.json",
                  "find_mug.json", "correlated.json", "generated_small.json",
                  "contrary_household.json", "independent.json")


def _boundary_cases():
    """Every number of one file of each family set to each of 0, 1 and 1e-320 (the boundaries the
    random mutator reaches only now and then; -1 and the rest are refused by type and range)."""
    for kind, source in SOURCES:
        if source.name not in BOUNDARY_FILES:
            continue
        doc = _read(source)
        for path in _paths(doc):
            parent = doc
            for key in path[:-1]:
                parent = parent[key]
            value = parent[path[-1]]
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                for new in (0, 1, 1e-320):
                    yield kind, source, path, new


def _check_boundaries(tmp_path: Path, cases) -> None:
    faults = []
    for n, (kind, source, path, new) in enumerate(cases):
        doc = _read(source)
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        parent[path[-1]] = new
        _, fault = _validate_then_run(kind, source, doc, tmp_path / f"case{n}")
        if fault is not None:
            faults.append(f"{source.relative_to(ROOT)}: {'.'.join(map(str, path))} = {new!r}: {fault}")
    assert not faults, "\n".join(faults[:20]) + f"\n({len(faults)} faults)"


#: The settings of the default model (its tables other than transitions and sensors).
SETTINGS = ("beliefs", "detection", "perception", "planning", "recovery")


@pytest.mark.slow
def test_the_default_model_settings_at_their_boundaries(tmp_path):
    """The quick form: every number of models/factorised.toml's settings at 0, 1 and 1e-320."""
    cases = [c for c in _boundary_cases() if c[1].name == "factorised.toml" and c[2][0] in SETTINGS]
    assert len(cases) > 30
    _check_boundaries(tmp_path, cases)


@pytest.mark.slow
def test_every_number_of_every_bundled_file_at_its_boundaries(tmp_path):
    _check_boundaries(tmp_path, _boundary_cases())
