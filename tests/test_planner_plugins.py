"""Planner plug-ins: a planner written outside the package runs through the CLI and sweeps.

Checks that `module:attribute` and entry-point names (group ``fg_tea.planners``) build planners,
that compare's worker processes rebuild them from the spec string, and that every fault (no such
module, no such attribute, not a planner, wrong choose signature) is one line with exit status 2.
"""

from __future__ import annotations

import csv
import json
import textwrap
from pathlib import Path

import numpy as np
import pytest

from fg_tea.cli import main
from fg_tea.model.spec import load_model
from fg_tea.planning import make_planner
from fg_tea.planning import check_planner as check
from fg_tea.planning.plugins import PlannerSpecError, entry_points

#: A planner of one's own: the most probable site of the first object, discounted by earlier
#: misses, nearest first on ties. It builds its candidates with the public types only.
PLANNER_SOURCE = textwrap.dedent('''
    from fg_tea.planning import Candidate, Decision

    BUILT = []


    class MyPlanner:
        name = "mine"

        def __init__(self, rng):
            self.rng = rng
            BUILT.append(self)

        def choose(self, belief, objects, relevance, distances, inspected,
                   excluded_sites=frozenset(), views=None):
            obj = objects[0]
            q = belief.location_map(obj)
            sites = [s for s in belief.sites if s not in excluded_sites]
            score = {s: -q[s] for s in sites}
            candidates = tuple(Candidate(obj, s, distances.from_agent(s), q[s], 0.0,
                                         int(inspected.get(s, 0)), float(relevance[obj]),
                                         score[s], score[s]) for s in sites)
            best = min(candidates, key=lambda c: (c.total, c.distance))
            return Decision(obj, best.viewpoint, best.total, candidates, self.name)


    def make(model):
        return MyPlanner(None)


    NOT_A_PLANNER = 3


    class WrongSignature:
        def choose(self, belief):
            raise AssertionError("never called")
''')


def _write_module(folder: Path, name: str = "mymod") -> Path:
    path = folder / f"{name}.py"
    path.write_text(PLANNER_SOURCE)
    return path


def _rows(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_compare_runs_a_planner_from_a_file_outside_the_package(tmp_path, monkeypatch):
    work = tmp_path / "work"
    work.mkdir()
    _write_module(work)
    monkeypatch.chdir(work)  # importable only from the current directory, as a user would run it
    out = tmp_path / "cmp"
    status = main(["compare", "--planners", "greedy", "mymod:MyPlanner", "--env", "fake",
                   "--worlds", "2", "--models", "factorised", "--out", str(out), "--workers", "2"])
    assert status == 0
    rows = _rows(out / "episodes.csv")
    mine = [r for r in rows if r["planner"] == "mymod:MyPlanner"]
    greedy = [r for r in rows if r["planner"] == "greedy"]
    assert len(mine) == 2 and len(greedy) == 2
    assert all(r["success"] == "True" and r["reason"] == "complete" for r in mine)
    assert {r["world_seed"] for r in mine} == {"0", "1"}
    assert all(int(r["inspections"]) >= 1 for r in mine)
    assert "mymod:MyPlanner" in (out / "summary.md").read_text()


def test_run_takes_a_module_attribute_planner_and_logs_its_spec(tmp_path, monkeypatch):
    _write_module(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    out = tmp_path / "run"
    assert main(["run", "--planner", "mymod:make", "--no-video", "--out", str(out)]) == 0
    events = [json.loads(line) for line in (out / "episode.jsonl").read_text().splitlines()]
    assert events[0]["planner"] == "mymod:make"
    decisions = [e for e in events if e["event"] == "decision"]
    assert decisions and all(d["planner"] == "mine" for d in decisions)
    assert events[-1]["event"] == "metrics" and events[-1]["success"]


def test_factory_receives_the_seeded_generator(tmp_path, monkeypatch):
    _write_module(tmp_path, "mymod_rng")
    monkeypatch.syspath_prepend(str(tmp_path))
    model = load_model("factorised")
    rng = np.random.default_rng(7)
    planner = make_planner("mymod_rng:MyPlanner", model, rng)
    assert planner.rng is rng and planner.name == "mine"


@pytest.mark.parametrize("spec, fault", [
    ("nosuchmod_xyz:Planner", "no module named 'nosuchmod_xyz'"),
    ("mymod_err:Missing", "has no attribute 'Missing'"),
    ("mymod_err:NOT_A_PLANNER", "is a int, not a planner"),
    ("mymod_err:WrongSignature", "does not satisfy the Planner protocol"),
    ("astar", "unknown planner 'astar'"),
    ("mymod_err:", "expected module:attribute"),
    ("my-mod:X", "is not a module name"),
])
def test_bad_planner_specs_are_one_line_and_status_2(tmp_path, monkeypatch, capsys, spec, fault):
    _write_module(tmp_path, "mymod_err")
    monkeypatch.chdir(tmp_path)
    for argv in (["compare", "--planners", "efe", spec, "--env", "fake", "--worlds", "1",
                  "--out", str(tmp_path / "out")],
                 ["run", "--planner", spec, "--no-video", "--out", str(tmp_path / "out")]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("fg-tea: error: ") and fault in err, err
    assert not (tmp_path / "out").exists()
    with pytest.raises(PlannerSpecError, match="planner"):
        check(spec)


def _fake_distribution(site: Path, planner_name: str = "spiral") -> None:
    """An installed package as importlib.metadata sees it: a module and a .dist-info folder."""
    package = site / "myplug"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text(PLANNER_SOURCE)
    info = site / "myplug-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: myplug\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[fg_tea.planners]\n{planner_name} = myplug:MyPlanner\n"
                                           "greedy = myplug:WrongSignature\n")


def test_an_installed_package_registers_a_planner_by_entry_point(tmp_path, monkeypatch):
    site = tmp_path / "site"
    _fake_distribution(site)
    monkeypatch.syspath_prepend(str(site))
    assert "spiral" in entry_points()
    check("spiral")
    planner = make_planner("spiral", load_model("factorised"), np.random.default_rng(0))
    assert type(planner).__module__ == "myplug" and planner.name == "mine"
    # A built-in name wins over an entry point of the same name.
    assert type(make_planner("greedy", load_model("factorised"))).__name__ == "GreedyProbabilityPlanner"
    out = tmp_path / "cmp"
    assert main(["compare", "--planners", "spiral", "--env", "fake", "--worlds", "2",
                 "--models", "factorised", "--out", str(out), "--workers", "2"]) == 0
    rows = _rows(out / "episodes.csv")
    assert [r["planner"] for r in rows] == ["spiral", "spiral"]
    assert all(r["success"] == "True" for r in rows)


def test_a_planner_that_returns_no_decision_is_named(tmp_path, monkeypatch):
    (tmp_path / "badplan.py").write_text(textwrap.dedent('''
        class Lazy:
            name = "lazy"
            def choose(self, belief, objects, relevance, distances, inspected,
                       excluded_sites=frozenset(), views=None):
                return ("mug", "sideboard")
    '''))
    monkeypatch.syspath_prepend(str(tmp_path))
    from fg_tea.env.fake import FakeHouse
    from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
    from fg_tea.world.scenario import load_scenario

    s, m = load_scenario("default_apartment"), load_model("factorised")
    runner = EpisodeRunner(s, m, FakeHouse(s, env_config_for(m)), RunConfig(planner="badplan:Lazy"))
    from fg_tea.common.errors import PlannerFault

    with pytest.raises(PlannerFault, match="planner 'badplan:Lazy' returned a tuple") as fault:
        runner.run()
    assert isinstance(fault.value.__cause__, TypeError)
    assert runner.done and runner.events[-2]["reason"].startswith("planner_error: failed: TypeError")


@pytest.mark.parametrize("body, status, message", [
    ("raise KeyboardInterrupt\n", 130, "fg-tea: interrupted"),
    ("import sys\nsys.exit(0)\n", 2, "importing 'exits_{n}' called exit(0); a planner module must not exit"),
])
def test_a_plugin_that_interrupts_or_exits_at_import_is_one_line(tmp_path, monkeypatch, capsys, body,
                                                                  status, message):
    """Both used to end in a traceback (the interrupt) or exit 0 with no log (the exit)."""
    n = status
    (tmp_path / f"exits_{n}.py").write_text(body)
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    from fg_tea.cli.main import main

    try:
        done = main(["run", "--planner", f"exits_{n}:P", "--no-video", "--out", str(tmp_path / "out")])
    except SystemExit as exc:  # argparse reports a bad option value itself
        done = exc.code
    assert done == status
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message.format(n=n) in err[0]
    assert not (tmp_path / "out").exists()
