"""Repeated and out-of-range settings are errors, never a silent last-wins (docs/design.md §11):
one line naming the option, exit 2, before any episode."""

from __future__ import annotations

import pytest

from fg_tea.cli.main import main


@pytest.mark.parametrize("argv,fault", [
    (["run", "--no-video", "--planner", "lookahead:depth=2,depth=3"], "depth is given twice"),
    (["run", "--no-video", "--failure-rate", "FILL=0.3", "--failure-rate", "FILL=0.5"],
     "FILL is given twice"),
    (["run", "--no-video", "--solver", "numpy", "--backend", "gtsam"], "name the same setting"),
    (["run", "--no-video", "--backend", "gtsam", "--solver=numpy"], "name the same setting"),
    (["run", "--no-video", "--planner", "pouct:99999999999999999999"], "an integer from 1 to"),
    (["compare", "--env", "fake", "--worlds", "1000000000000"], "expected an integer from 1 to"),
])
def test_a_repeated_or_out_of_range_setting_is_one_line_and_exit_2(argv, fault, tmp_path, capsys):
    with pytest.raises(SystemExit) as ended:
        status = main([*argv, "--out", str(tmp_path / "out")])
        raise SystemExit(status)
    err = capsys.readouterr().err.strip().splitlines()
    assert ended.value.code == 2 and len(err) == 1 and fault in err[0], err
    assert not (tmp_path / "out").exists()


def test_the_alias_alone_still_works_with_its_note(tmp_path, capsys):
    assert main(["compare", "--backend", "serial", "--env", "fake", "--worlds", "1", "--planners",
                 "nearest", "--models", "factorised", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().err.splitlines()[-1] == "fg-tea: note: --backend is deprecated; use --executor"


PLUGIN = '''
class ReturnsNone:
    name = "none"
    def choose(self, belief, objects, relevance, distances, inspected, excluded_sites=frozenset(),
               views=None):
        return None
class Raises(ReturnsNone):
    def choose(self, *args, **kwargs):
        raise RuntimeError("boom")
class Exits(ReturnsNone):
    def choose(self, *args, **kwargs):
        raise SystemExit(0)
class Elsewhere(ReturnsNone):
    def choose(self, belief, objects, *args, **kwargs):
        from fg_tea.planning import Candidate, Decision
        c = Candidate(objects[0], "nowhere", 1.0, 0.5, 0.0, 0, 1.0, 0.0, 0.0)
        return Decision(objects[0], "nowhere", 0.0, (c,), "elsewhere")
'''


@pytest.mark.parametrize("plugin,what", [("ReturnsNone", "returned a NoneType"), ("Raises", "boom"),
                                         ("Exits", "SystemExit"), ("Elsewhere", "viewpoint 'nowhere'")])
def test_a_plugin_fault_in_run_is_one_line_and_the_log_says_why(plugin, what, tmp_path, capsys,
                                                               monkeypatch):
    import json
    import sys

    (tmp_path / "faulty.py").write_text(PLUGIN)
    monkeypatch.syspath_prepend(str(tmp_path))
    sys.modules.pop("faulty", None)
    out = tmp_path / "out"
    assert main(["run", "--no-video", "--planner", f"faulty:{plugin}", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"--planner faulty:{plugin}" in err[0] and what in err[0], err
    events = [json.loads(line) for line in (out / "episode.jsonl").read_text().splitlines()]
    end = next(e for e in events if e["event"] == "episode_end")
    assert end["reason"].startswith("planner_error: ") and what in end["reason"]
    assert events[-1]["event"] == "metrics"


def test_learn_refuses_an_empty_model_name(tmp_path, capsys):
    from fg_tea.episode.run import run_episode
    from fg_tea.model.spec import load_model
    from fg_tea.world.scenario import load_scenario

    log = tmp_path / "e.jsonl"
    run_episode(load_scenario("default_apartment"), load_model("factorised"), env="fake", log=log)
    assert main(["learn", str(log), "--name", " ", "--out", str(tmp_path / "m.toml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--name: a model name must not be empty" in err[0]
    assert not (tmp_path / "m.toml").exists()
