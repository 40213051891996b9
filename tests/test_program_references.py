"""Model programs named as ``module:attr`` or entry points, in every command that takes a model;
their faults named by the program first; what ``fg-tea list`` and ``dir(fg)`` show of them; and a
learnable table over a state the scenario does not declare, refused (docs/design.md §4.8, §12.6).
"""

from __future__ import annotations

import csv
import importlib.metadata
import os
import subprocess
import sys
from pathlib import Path

import pytest

import fg_tea as fg
from fg_tea.common import resources
from fg_tea.common.errors import InputError
from test_input_faults import assert_one_line_error, cli

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = "fgt_refs_pkg"

MODULE = '''\
import fg_tea as fg
base = "{base}"

def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))

    @m.factor("teabag")
    def never_on_the_study_shelf(teabag):
        return 0.0 if teabag.name == "study_shelf" else 1.0
    return m
'''


@pytest.fixture()
def package(tmp_path, monkeypatch):
    """A package on sys.path (and PYTHONPATH, for worker processes) with a factorised and a joint
    model program: ``fgt_refs_pkg.models:model`` and ``fgt_refs_pkg.joint:model``."""
    folder = tmp_path / "site" / PACKAGE
    folder.mkdir(parents=True)
    (folder / "__init__.py").write_text("")
    (folder / "models.py").write_text(MODULE.format(base="factorised"))
    (folder / "joint.py").write_text(MODULE.format(base="joint"))
    monkeypatch.syspath_prepend(str(folder.parent))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(folder.parent), os.environ.get("PYTHONPATH", "")]))
    for name in [m for m in sys.modules if m == PACKAGE or m.startswith(PACKAGE + ".")]:
        monkeypatch.delitem(sys.modules, name)
    yield folder.parent
    for name in [m for m in sys.modules if m == PACKAGE or m.startswith(PACKAGE + ".")]:
        del sys.modules[name]


def _models(path: Path) -> list[str]:
    with path.open(newline="") as fh:
        return sorted(row["model"] for row in csv.DictReader(fh))


def test_check_jobs_takes_a_module_attribute_model(package):
    from fg_tea.study.sweep import check_jobs, plan_sweep

    check_jobs(plan_sweep(["correlated"], 1, ["factorised", f"{PACKAGE}.models:model"], ["nearest"], env="fake"))
    with pytest.raises(InputError, match="unknown model 'no_such_model'"):
        check_jobs(plan_sweep(["correlated"], 1, ["no_such_model"], ["nearest"], env="fake"))


def test_compare_runs_a_module_attribute_model(package, tmp_path):
    ref = f"{PACKAGE}.models:model"
    status, _, err = cli(["compare", "--worlds", "2", "--models", "factorised", ref, "--planners", "nearest",
                          "--env", "fake", "--executor", "serial", "--out", tmp_path / "out"])
    assert status == 0, err
    assert _models(tmp_path / "out" / "episodes.csv") == ["factorised", "factorised", ref, ref]


def test_compare_lifelong_runs_a_module_attribute_model(package, tmp_path):
    ref = f"{PACKAGE}.models:model"
    status, out, err = cli(["compare", "--lifelong", "2", "--worlds", "1", "--models", "factorised", ref,
                            "--planners", "nearest", "--env", "fake", "--executor", "serial",
                            "--out", tmp_path / "life"])
    assert status == 0, err
    assert set(_models(tmp_path / "life" / "episodes.csv")) == {"factorised", ref}


def test_compare_runs_an_entry_point_model(package, tmp_path, monkeypatch):
    point = importlib.metadata.EntryPoint("refs_tidy", f"{PACKAGE}.models:model", resources.MODEL_ENTRY_POINT_GROUP)
    monkeypatch.setattr(resources, "model_entry_points", lambda: {"refs_tidy": point})
    status, _, err = cli(["compare", "--worlds", "1", "--models", "factorised", "refs_tidy", "--planners",
                          "nearest", "--env", "fake", "--executor", "serial", "--out", tmp_path / "ep"])
    assert status == 0, err
    assert _models(tmp_path / "ep" / "episodes.csv") == ["factorised", "refs_tidy"]


@pytest.mark.slow  # a subprocess sweep: the full suite runs it, the quick loop does not
def test_compare_at_scale_runs_a_module_attribute_model(package, tmp_path):
    ref = f"{PACKAGE}.joint:model"
    done = subprocess.run([sys.executable, "experiments/compare_at_scale.py", "--table", "houses", "--sizes",
                           "small", "--tasks", "make_tea", "--worlds", "1", "--env", "fake", "--planners",
                           "nearest", "--executor", "serial", "--timing-worlds", "0",
                           "--models", "factorised", ref, "--out", str(tmp_path / "cas")],
                          capture_output=True, text=True, stdin=subprocess.DEVNULL, cwd=ROOT, timeout=600)
    assert done.returncode == 0, done.stderr
    assert _models(tmp_path / "cas" / "houses" / "episodes.csv") == ["factorised", ref]


IMPOSSIBLE = '''\
import fg_tea as fg
base = "factorised"

def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))
    m.table("teabag", {"kitchen_counter": 1.0}, name="only counter")
    m.table("teabag", {"study_shelf": 1.0}, name="only study")
    return m
'''


@pytest.mark.parametrize("command", ["beliefs", "validate", "run"])
def test_a_program_fault_names_the_program_first(command, tmp_path):
    path = tmp_path / "impossible.py"
    path.write_text(IMPOSSIBLE)
    argv = {"beliefs": ["beliefs", "--model", path], "validate": ["validate", path],
            "run": ["run", "--model", path, "--env", "fake", "--out", tmp_path / "r"]}[command]
    status, _, err = cli(argv)
    assert_one_line_error(status, err, "multiply to zero everywhere")
    assert err.startswith(f"fg-tea: error: {path}: "), err
    assert ".json" not in err and "$.objects" not in err


def test_list_names_entry_point_models(monkeypatch):
    status, out, _ = cli(["list", "models"])
    assert status == 0 and "entry points of group" not in out  # none installed
    point = importlib.metadata.EntryPoint("refs_tidy", f"{PACKAGE}.models:model", resources.MODEL_ENTRY_POINT_GROUP)
    monkeypatch.setattr(resources, "model_entry_points", lambda: {"refs_tidy": point})
    status, out, _ = cli(["list", "models"])
    assert status == 0
    assert f"entry points of group {resources.MODEL_ENTRY_POINT_GROUP}" in out
    assert any(line.split() == ["refs_tidy", f"{PACKAGE}.models:model"] for line in out.splitlines()), out
    status, out, _ = cli(["list", "scenarios"])
    assert status == 0 and "refs_tidy" not in out


def test_dir_shows_the_public_api_only():
    names = dir(fg)
    assert set(fg.__all__) <= set(names)
    for stray in ("Any", "importlib", "annotations", "TYPE_CHECKING", "_API", "_RENAMED", "_register_gym_id"):
        assert stray not in names, stray


UNDECLARED = '''\
import fg_tea as fg
base = "factorised"

def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))
    m.state("mug.dirty")
    m.table("mug.dirty", [0.6, 0.4], name="dirty prior", learnable=True)

    @m.factor("mug.dirty", "mug")
    def near_the_counter_when_dirty(dirty, mug):
        return 5.0 if dirty and mug.name == "kitchen_counter" else 1.0
    return m
'''


def test_a_learnable_table_over_an_undeclared_state_is_refused(tmp_path):
    """docs/design.md §12.6: no episode reads a state the scenario does not declare."""
    path = tmp_path / "dirty.py"
    path.write_text(UNDECLARED)
    status, _, err = cli(["learn", "--base", path, "--scenario", "default_apartment", "--out", tmp_path / "l.py"])
    assert_one_line_error(status, err, str(path), "factor 'dirty prior'", "'mug.dirty'",
                          "state the scenario does not declare")
    assert not (tmp_path / "l.py").exists()
    from fg_tea.study.program_learning import count_tables, declared_states

    scenario = fg.load_scenario("default_apartment")
    program = fg.model_program(scenario, fg.load_model(path))
    assert "mug.dirty" not in declared_states(scenario) and "mug.served" in declared_states(scenario)
    with pytest.raises(InputError, match="does not declare"):
        count_tables(program, [], declared_states(scenario))


def test_compare_lifelong_refuses_it_before_any_episode(tmp_path):
    path = tmp_path / "dirty.py"
    path.write_text(UNDECLARED)
    out = tmp_path / "life"
    status, _, err = cli(["compare", "--lifelong", "2", "--worlds", "1", "--models", "factorised", path,
                          "--planners", "nearest", "--env", "fake", "--executor", "serial", "--out", out])
    assert_one_line_error(status, err, str(path), "factor 'dirty prior'", "state the scenario does not declare")
    assert not out.exists()
