"""`compare --lifelong` with a model program learns its learnable tables between episodes
(docs/design.md §12.4, §12.6), and checks a plug-in planner before any episode as compare does."""

from __future__ import annotations

import pytest
import csv
import sys
from pathlib import Path

from fg_tea.cli.main import main

HERE = Path(__file__).resolve().parent
PROGRAM = '''import fg_tea as fg
base = "factorised"


def model(scenario):
    return fg.program_from_model(scenario, fg.load_model(base))
'''


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_a_program_learns_its_tables_between_a_households_episodes(tmp_path, capsys):
    program = tmp_path / "prog.py"
    program.write_text(PROGRAM)
    out = tmp_path / "ll"
    status = main(["compare", "--lifelong", "3", "--worlds", "2", "--world", "independent", "--models", str(program),
                   "--env", "fake", "--planners", "efe", "--executor", "serial", "--out", str(out)])
    assert status == 0, capsys.readouterr().err
    rows = list(csv.DictReader((out / "episodes.csv").open()))
    arms = {r["arm"] for r in rows}
    assert arms == {"hand-set", "learned"}  # no learned-correlations arm for a program
    prior = {(r["arm"], r["household"], r["episode"]): float(r["prior_true_focus"]) for r in rows}
    for r in rows:
        if r["arm"] == "learned":
            assert int(r["learned_logs"]) == int(r["episode"]) - 1
    assert all(prior[("learned", h, "1")] == prior[("hand-set", h, "1")] for h in ("0", "1"))
    later = [(prior[("learned", h, e)], prior[("hand-set", h, e)]) for h in ("0", "1") for e in ("2", "3")]
    assert any(a != b for a, b in later), later  # the learned tables moved the start belief


def test_a_plugin_check_that_fails_in_a_lifelong_sweep_is_status_2_before_any_episode(tmp_path, capsys,
                                                                                        monkeypatch):
    monkeypatch.syspath_prepend(str(HERE))
    sys.modules.pop("plugin_fault_planners", None)
    out = tmp_path / "ll"
    status = main(["compare", "--lifelong", "2", "--worlds", "1", "--planners", "plugin_fault_planners:CheckRaises",
                   "--env", "fake", "--models", "factorised", "--executor", "serial", "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and "its check() raised RuntimeError: cannot check" in err[0], err
    assert not (out / "episodes.csv").exists()


def test_the_lifelong_experiment_checks_a_plugin_planner_before_any_episode(tmp_path):
    import subprocess

    out = tmp_path / "ll"
    env = {**__import__("os").environ, "PYTHONPATH": str(HERE)}
    done = subprocess.run([sys.executable, str(HERE.parent / "experiments" / "lifelong.py"), "--planner",
                           "plugin_fault_planners:CheckRaises", "--households", "1", "--episodes", "2",
                           "--models", "factorised", "--out", str(out)], capture_output=True, text=True,
                          timeout=600, stdin=subprocess.DEVNULL, env=env)
    err = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(err) == 1 and "its check() raised RuntimeError: cannot check" in err[0], err
    assert not (out / "episodes.csv").exists()
