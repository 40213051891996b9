"""A model program marks a transition learnable (``Program.learnable_transition``): ``fg-tea learn``
counts its effects' eq. (61) terms from the program's episodes (rule 5, docs/design.md §12.5) and the
learned program applies eq. (63)'s success; the lifelong sweep does the same in memory (§12.4)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import fg_tea as fg
from fg_tea.cli.main import main
from fg_tea.study.households import HouseholdSpec, _episode, run_household

HERE = Path(__file__).resolve().parent
CHECKER = HERE.parent / "experiments" / "models" / "factorised_check_kettle.toml"
PROGRAM = f'''import fg_tea as fg
base = {str(CHECKER)!r}


def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))
    m.learnable_transition({{name!r}})
    return m
'''
#: A world whose kettle heats in 20 % of boils (environment only, never shown to the agent).
WEAK_BOIL = (("boil", 0.2),)


def _program(tmp_path: Path, name: str = "boil") -> Path:
    path = tmp_path / "kettle.py"
    path.write_text(PROGRAM.format(name=name))
    return path


def _boil_success(events) -> list[float]:
    return [eff["success"] for e in events if e.get("event") == "action"
            and (e.get("parameters") or {}).get("transition") == "boil"
            for eff in e["transition"]["effects"]]


@pytest.mark.slow  # fake-house episodes: over 1.5 s
def test_learn_writes_a_programs_learned_boil_success_and_the_learned_program_applies_it(tmp_path, capsys):
    program = _program(tmp_path)
    model = fg.load_model(str(program))
    declared = model.transitions["boil"].effects[0].success
    world = fg.load_world("independent")
    spec = HouseholdSpec("independent", False, str(program), 0, 1, effect_success=WEAK_BOIL)
    logs = []
    for k in range(6):
        path = tmp_path / f"episode{k}.jsonl"
        _episode(spec, model, world.sample(100 + k), 100 + k, path)
        logs.append(str(path))
    out = tmp_path / "learned.py"
    assert main(["learn", "--base", str(program), *logs, "--out", str(out)]) == 0
    told = capsys.readouterr().out
    assert "boil.effect0" in told and "likelihood term" in told, told
    learned = fg.load_model(str(out))
    success = learned.transitions["boil"].effects[0].success
    assert success < declared - 0.05, (success, declared)  # the world's boils fail often
    assert learned.declared_transitions["boil"].effects[0].success == declared
    assert learned.transitions["pour"] == model.transitions["pour"]  # not marked: untouched
    events = [json.loads(line) for line in open(logs[0])]
    assert set(_boil_success(events)) == {declared}  # the program's own episodes used the declared
    again = _episode(spec, learned, world.sample(200), 200)[0]
    assert _boil_success(again) and all(s == pytest.approx(success, abs=1e-9)  # a run uses the learned
                                        for s in _boil_success(again))
    # learning on from the learned program with no new logs keeps the same terms (they add up)
    out2 = tmp_path / "learned2.py"
    assert main(["learn", "--base", str(out), "--scenario", events[0]["scenario_file"], "--out", str(out2)]) == 0
    assert fg.load_model(str(out2)).transitions["boil"].effects[0].success == pytest.approx(success, abs=1e-12)


@pytest.mark.slow  # fake-house episodes: over 1.5 s
def test_the_lifelong_learned_arm_of_a_program_applies_its_learned_boil_success(tmp_path):
    program = _program(tmp_path)
    declared = fg.load_model(str(program)).transitions["boil"].effects[0].success
    spec = HouseholdSpec("independent", False, str(program), 0, 4, effect_success=WEAK_BOIL,
                         log_dir=str(tmp_path / "logs"))
    run_household(spec)
    used = []
    for k in range(1, 5):
        (log,) = (tmp_path / "logs").glob(f"*/learned/household0/episode{k:02d}.jsonl")
        used.append(_boil_success([json.loads(line) for line in open(log)]))
    assert set(used[0]) == {declared}  # the first episode knows nothing yet
    later = [s for u in used[1:] for s in u]
    assert later and min(later) < declared - 0.05, used


def test_an_unknown_learnable_transition_is_refused_in_one_line(tmp_path, capsys):
    program = _program(tmp_path, "boill")
    status = main(["beliefs", "--model", str(program)])
    err = capsys.readouterr().err.strip()
    assert status == 2 and len(err.splitlines()) == 1, err
    assert "kettle.py" in err and "'boill'" in err and "unknown transition" in err and "boil" in err


def test_a_learned_files_bad_transition_terms_are_one_line(tmp_path, capsys):
    program = _program(tmp_path)
    learned = tmp_path / "learned.py"
    sha = __import__("hashlib").sha256(program.read_bytes()).hexdigest()
    head = ("from fg_tea.model.program_learned import learned_model\n"
            f"learned_from = {sha!r}\n"
            "transition_strength = 5.0\n")
    tail = f"base, model = learned_model({str(program)!r}, learned_from, {{}}, 5.0, here=__file__)\n"
    for terms, fault in (('{"boill.effect0": {"state": "{object}.water_hot", "terms": [[1, 0, 0]]}}',
                          "no transition 'boill'"),
                         ('{"boil.effect0": {"state": "{object}.cold", "terms": [[1, 0, 0]]}}', "counted for state"),
                         ('{"boil.effect0": {"state": "{object}.water_hot", "terms": [[-1, 0, 0]]}}',
                          "expected <transition>.effect<k>")):
        learned.write_text(head + f"transition_terms = {terms}\n" + tail)
        status = main(["beliefs", "--model", str(learned)])
        err = capsys.readouterr().err.strip()
        assert status == 2 and len(err.splitlines()) == 1 and fault in err and "learned.py" in err, err


def test_compare_lifelong_passes_learn_transitions_on_and_refuses_it_without_lifelong(tmp_path, monkeypatch,
                                                                                        capsys):
    import fg_tea.study.households as households

    seen = []
    monkeypatch.setattr(households, "run_lifelong", lambda specs, workers=1: seen.extend(specs) or [])
    monkeypatch.setattr(households, "write_outputs", lambda *a, **k: {n: n for n in (
        "episodes", "curves", "summary", "plot", "focus_plot")})
    for flags, wanted in (([], False), (["--learn-transitions"], True)):
        seen.clear()
        assert main(["compare", "--lifelong", "2", "--worlds", "1", "--world", "independent", "--models",
                     "factorised", "--env", "fake", "--executor", "serial", "--out", str(tmp_path / "o"),
                     *flags]) == 0
        assert [s.learn_transitions for s in seen] == [wanted]  # off by default: earlier results keep meaning
    capsys.readouterr()
    status = main(["compare", "--worlds", "1", "--learn-transitions", "--out", str(tmp_path / "p")])
    err = capsys.readouterr().err.strip()
    assert status == 2 and len(err.splitlines()) == 1 and "--learn-transitions" in err and "--lifelong" in err


def test_compare_lifelong_refuses_a_program_marking_an_unknown_transition_before_any_episode(tmp_path, capsys):
    program = _program(tmp_path, "boill")
    status = main(["compare", "--lifelong", "2", "--worlds", "1", "--world", "independent", "--models",
                   str(program), "--env", "fake", "--executor", "serial", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert status == 2 and len(err.splitlines()) == 1 and "'boill'" in err, err
    assert not (tmp_path / "o" / "episodes.csv").exists()


def test_a_learnable_transition_on_a_direct_form_base_is_refused_in_one_line(tmp_path, capsys):
    path = tmp_path / "direct.py"
    path.write_text(PROGRAM.replace(repr(str(CHECKER)), repr(str(HERE.parent / "models" / "ablations"
                                                                 / "direct_effects.toml"))).format(name="boil"))
    status = main(["beliefs", "--model", str(path)])
    err = capsys.readouterr().err.strip()
    assert status == 2 and len(err.splitlines()) == 1 and "direct form" in err and "'boil'" in err, err
