"""Faults of plug-in planners, exit statuses, and `--out ""`: one line and a documented status.

The plug-ins are in tests/plugin_fault_planners.py. Exit statuses (docs/reference/cli.md): 0 ok,
1 an episode or job failed for a reason that is not the user's input, 2 bad input (a plug-in
planner's fault included).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from fg_tea.cli.main import main

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
MOD = "plugin_fault_planners"


def _one_line(capsys) -> str:
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1, err
    assert "Traceback" not in err[0]
    return err[0]


def _status(argv: list[str]) -> int:
    try:
        return main(argv)
    except SystemExit as exc:  # argparse reports a bad option value itself
        return int(exc.code or 0)


# --------------------------------------------------------------------------- decisions
@pytest.mark.parametrize("planner, fault", [
    ("Outside", "chose (mug, "),
    ("Empty", "a decision with no candidates"),
    ("NaNTotal", "a NaN total"),
    ("NaNCandidate", "a NaN distance"),
    ("NotADecision", "returned a dict, not a fg_tea.planning.Decision"),
    ("RaisesBase", "raised Stop: stopped"),
])
def test_a_bad_decision_in_run_is_one_line_and_status_2(tmp_path, capsys, planner, fault):
    out = tmp_path / "t1"
    status = main(["run", "--no-video", "--out", str(out), "--planner", f"{MOD}:{planner}"])
    line = _one_line(capsys)
    assert status == 2
    assert f"--planner {MOD}:{planner}" in line and fault in line, line
    end = [json.loads(x) for x in (out / "episode.jsonl").read_text().splitlines()][-2]
    assert end["event"] == "episode_end" and end["reason"].startswith("planner_error: ")


def test_the_agent_refuses_a_decision_outside_its_candidates_naming_the_planner():
    import fg_tea as fg
    from plugin_fault_planners import Outside

    agent = fg.Agent(fg.load_scenario("default_apartment"), fg.load_model("factorised_close"),
                     planner=Outside())
    action = agent.next_action()
    assert action is not None and action.verb == "SEARCH"
    with pytest.raises(ValueError, match=r"planner 'Outside' chose \(mug, \w+\), which is not among "
                                         r"its \d+ candidates"):
        agent.decide(action, agent.scenario.start_position)


def test_accept_decision_is_the_one_boundary():
    from fg_tea.planning.base import Candidate, Decision, accept_decision

    c = Candidate("mug", "a", 1.0, 0.5, 0.1, 0, 1.0, 0.2, 0.2)
    tea = Candidate("tea", "a", 1.0, 0.5, 0.1, 0, 1.0, 0.2, 0.2)
    good = Decision("mug", "a", 0.2, (c,), "p")
    assert accept_decision(good, "p", ("a", "b"), ("mug",)) is good
    for bad, text in [(Decision("mug", "b", 0.2, (c,), "p"), "not among its 1 candidates"),
                      (Decision("tea", "a", 0.2, (c, tea), "p"), "object 'tea', which is not one"),
                      (Decision("mug", "a", 0.2, (c,), "p", {"w": float("nan")}), "info 'w' is NaN"),
                      ("mug", "returned a str")]:
        with pytest.raises((TypeError, ValueError), match=f"planner 'p'.*{text}"):
            accept_decision(bad, "p", ("a", "b"), ("mug",))


def test_a_bad_decision_in_compare_is_one_line_and_status_2(tmp_path, capsys):
    status = main(["compare", "--planners", f"{MOD}:Outside", "--env", "fake", "--worlds", "1",
                   "--models", "factorised", "--executor", "serial", "--pages", "0",
                   "--out", str(tmp_path / "c")])
    line = _one_line(capsys)
    assert status == 2
    assert f"planner '{MOD}:Outside'" in line and "which is not among its" in line, line


# --------------------------------------------------------------------------- factories
@pytest.mark.parametrize("spec, fault", [
    ("builtins:exit", "called exit(None)"),
    (f"{MOD}:factory_exits", "called exit(0)"),
    (f"{MOD}:factory_raises_base", "raised Stop: no planner today"),
])
def test_a_factory_that_exits_is_not_success(tmp_path, capsys, spec, fault):
    out = tmp_path / "t1"
    status = main(["run", "--no-video", "--out", str(out), "--planner", spec])
    line = _one_line(capsys)
    assert status == 2
    assert spec in line and fault in line, line
    assert not out.exists()


@pytest.mark.parametrize("planner, fault", [("CheckRaises", "its check() raised RuntimeError: cannot check"),
                                            ("CheckExits", "its check() called exit(3)")])
def test_a_plugin_check_that_fails_is_one_line_and_status_2(tmp_path, capsys, planner, fault):
    out = tmp_path / "t1"
    assert main(["run", "--no-video", "--out", str(out), "--planner", f"{MOD}:{planner}"]) == 2
    line = _one_line(capsys)
    assert f"--planner {MOD}:{planner}" in line and fault in line, line
    assert not out.exists()


def test_a_plugin_check_that_fails_in_compare_is_status_2_before_any_episode(tmp_path, capsys):
    out = tmp_path / "c"
    status = main(["compare", "--planners", f"{MOD}:CheckRaises", "--env", "fake", "--worlds", "1",
                   "--models", "factorised", "--executor", "serial", "--pages", "0", "--out", str(out)])
    line = _one_line(capsys)
    assert status == 2 and "its check() raised RuntimeError: cannot check" in line, line
    assert not (out / "episodes.csv").exists()


def test_compare_with_a_factory_that_exits_is_status_2(tmp_path, capsys):
    status = main(["compare", "--planners", "builtins:exit", "--env", "fake", "--worlds", "1",
                   "--models", "factorised", "--executor", "serial", "--pages", "0",
                   "--out", str(tmp_path / "c")])
    line = _one_line(capsys)
    assert status == 2 and "builtins:exit" in line and "called exit(None)" in line, line


# --------------------------------------------------------------------------- exit statuses
@pytest.mark.parametrize("command", ["run", "compare"])
def test_the_help_states_every_exit_status(capsys, command):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "Exit status: 0 " in text
    for status in ("; 1 ", "; 2 for bad input"):
        assert status in text, (command, status)


def test_a_built_in_planner_that_fails_is_status_1_not_bad_input(tmp_path, capsys, monkeypatch):
    """A fault of fg_tea's own planner is not the user's input."""
    from fg_tea.planning import baselines

    def broken(self, *args, **kwargs):
        raise ArithmeticError("a bug in fg_tea")

    monkeypatch.setattr(baselines.GreedyProbabilityPlanner, "choose", broken)
    status = main(["run", "--no-video", "--out", str(tmp_path / "t1"), "--planner", "greedy"])
    line = _one_line(capsys)
    assert status == 1 and "planner 'greedy' failed: ArithmeticError: a bug in fg_tea" in line, line


# --------------------------------------------------------------------------- process pools
def _subprocess_compare(tmp_path: Path, planner: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(HERE), str(ROOT),
                                                                     os.environ.get("PYTHONPATH")])))
    return subprocess.run([sys.executable, "-m", "fg_tea.cli", "compare", "--planners", planner,
                           "--env", "fake", "--worlds", "1", "--models", "factorised",
                           "--executor", "process", "--workers", "1", "--pages", "0",
                           "--out", str(tmp_path / "c")],
                          capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)


def test_a_plugin_error_in_a_worker_process_is_reported_as_itself(tmp_path):
    done = _subprocess_compare(tmp_path, f"{MOD}:Raises")
    err = [line for line in done.stderr.splitlines() if line.startswith("fg-tea")]
    assert done.returncode == 2, done.stderr
    assert len(err) == 1 and "Traceback" not in done.stderr, done.stderr
    assert "BrokenProcessPool" not in err[0]
    assert f"planner '{MOD}:Raises' failed: RuntimeError: my planner broke" in err[0]


def test_the_planner_fault_crosses_processes():
    import pickle

    from fg_tea.common.errors import PlannerFault

    again = pickle.loads(pickle.dumps(PlannerFault("mine:P", "failed: RuntimeError: x")))
    assert isinstance(again, PlannerFault) and (again.planner, again.what) == ("mine:P",
                                                                              "failed: RuntimeError: x")


def test_an_error_that_cannot_cross_processes_keeps_its_type_and_message(monkeypatch):
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(HERE), str(ROOT),
                                                                   os.environ.get("PYTHONPATH")])))
    from plugin_fault_planners import FakeJob, raise_unpicklable

    from fg_tea.study.executors import SweepError, _process

    with pytest.raises(SweepError, match=r"job j1 failed: Unpicklable: left and right"):
        list(_process(raise_unpicklable, [FakeJob("j1")], 1, None))


def test_the_agent_takes_a_planner_object_without_check():
    """A planner object handed to the Agent directly needs only ``choose`` (as a plug-in named by a
    string does): no ``check`` means no limits, not an AttributeError."""
    import fg_tea as fg
    from fg_tea.planning import make_planner

    class Nearest:
        def choose(self, belief, objects, relevance, distances, inspected, excluded_sites, views=None):
            return make_planner("nearest", model).choose(belief, objects, relevance, distances,
                                                        inspected, excluded_sites, views)

    scenario, model = fg.load_scenario("default_apartment"), fg.load_model("factorised")
    agent = fg.Agent(scenario, model, Nearest())
    assert agent.planner_spec == "Nearest"

