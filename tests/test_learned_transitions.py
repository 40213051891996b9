"""Learned transitions (docs/design.md §12.5, eqs. 61-63): counts from logs, the learned model
file, the environment's true effect success, and the experiment script."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from fg_tea.common.errors import InputError
from fg_tea.model import learned_transitions as lt
from fg_tea.model.learning import Learning, Source
from fg_tea.study.learn import counts_from_events, learn
from fg_tea.study.transition_counts import transition_terms

ROOT = Path(__file__).resolve().parents[1]
CHECK_MODEL = ROOT / "experiments" / "models" / "factorised_check_kettle.toml"
BOIL = {"state": "kettle.water_hot", "value": True, "success": 0.995, "requires": ["kettle.contains_water"]}


def _log(*body: dict, hot: float = 0.0, water: float = 1.0) -> list[dict]:
    start = {"event": "episode_start", "sites": [{"name": "counter", "room": "kitchen", "position": [0, 0]}],
             "categories": {}, "belief": {"states": {"kettle.contains_water": water, "kettle.water_hot": hot}}}
    return [start, *body]


def _boil(ok: bool = True) -> dict:
    return {"event": "action", "action": "boil_kettle", "parameters": {"transition": "boil"},
            "outcome": {"ok": ok, "reason": "" if ok else "injected_failure"},
            "transition": {"form": "full", "effects": [BOIL]} if ok else None}


def _read(state: str, value: bool, sens: float = 0.9, spec: float = 0.8) -> dict:
    return {"event": "state_reading", "state": state, "value": value, "sensitivity": sens, "specificity": spec}


def test_counts_from_a_hand_made_log_equal_the_hand_computed_mixture():
    # The kettle surely holds water and is surely cold, so the boil is one trial. A reading
    # "not hot" with sensitivity 0.9 and specificity 0.8 has probability 1 - 0.9 = 0.1 if the
    # boil succeeded (theta) and 0.8 if it failed (1 - theta): eq. 61 is
    # 0.1 theta + 0.8 (1 - theta), held as terms (s, f, log weight) with the largest weight 1:
    # (0, 1, 0) and (1, 0, ln(0.1 / 0.8) = ln 0.125 = -2.0794415416798357).
    events = _log(_boil(), _read("kettle.water_hot", False))
    terms = counts_from_events(events).transitions["boil.effect0"]
    assert terms == ((0.0, 1.0, 0.0), (1.0, 0.0, round(math.log(0.125), 12)))
    # Eq. 58 under a flat prior Beta(1, 1) (p0 = 0.5, S_t = 2): the weights are
    # 0.1 B(2, 1) : 0.8 B(1, 2) = 1 : 8, the terms' means 2/3 and 1/3, so
    # (1/9)(2/3) + (8/9)(1/3) = 10/27; the same as integrating theta (0.8 - 0.7 theta) over
    # (0.8 - 0.7 theta): (0.4 - 0.7/3) / (0.8 - 0.35) = 10/27.
    assert lt.posterior_mean(0.5, 2.0, terms) == pytest.approx(10 / 27, abs=1e-12)
    s, f = lt.expected_counts(0.5, 2.0, terms)
    assert (s, f) == (pytest.approx(1 / 9), pytest.approx(8 / 9))
    lo, hi = lt.interval(0.5, 2.0, terms)
    assert 0.0 < lo < 10 / 27 < hi < 1.0


def test_a_certain_reading_gives_one_beta_count():
    # A perfect sensor: "hot" after the boil is one success, eq. 63 = (S p0 + 1) / (S + 1).
    events = _log(_boil(), _read("kettle.water_hot", True, 1.0, 1.0))
    terms = transition_terms(events)["boil.effect0"]
    assert terms == ((1.0, 0.0, 0.0),)
    assert lt.posterior_mean(0.995, 5.0, terms) == pytest.approx((5 * 0.995 + 1) / 6)


@pytest.mark.parametrize("body", [
    (_boil(),),                                               # nothing read after the boil
    (_read("kettle.contains_water", True), _boil()),          # read only before it
    (_boil(ok=False), _read("kettle.water_hot", False)),      # the boil was reported failed
])
def test_nothing_observed_after_an_action_adds_nothing(body):
    events = _log(*body, water=0.7)
    assert transition_terms(events) == {}
    assert counts_from_events(events).transitions == {}


def test_a_kettle_already_hot_is_no_trial():
    # Already hot: success and failure give the same state, theta does not enter (eq. 27).
    assert transition_terms(_log(_boil(), _read("kettle.water_hot", True), hot=1.0)) == {}


def test_learning_the_same_log_twice_is_refused():
    events = _log(_boil(), _read("kettle.water_hot", False))
    src = Source("a.jsonl", "a" * 64)
    once = learn([(events, src)])
    with pytest.raises(InputError, match="already counted"):
        learn([(events, src)], once)
    twice = learn([(events, Source("b.jsonl", "b" * 64))], once)  # another episode: the mixtures multiply
    assert twice.counts.transitions["boil.effect0"] == lt.combine(once.counts.transitions["boil.effect0"],
                                                                  once.counts.transitions["boil.effect0"])


def test_a_log_without_start_state_beliefs_is_refused_in_one_line():
    events = _log(_boil(), _read("kettle.water_hot", False))
    del events[0]["belief"]
    with pytest.raises(InputError, match="belief.states"):
        transition_terms(events, "x.jsonl")


def _episode(tmp_path: Path, seed: int, boil: float):
    from fg_tea.env.fake import FakeHouse
    from fg_tea.episode.log import EventLog
    from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
    from fg_tea.model.spec import load_model
    from fg_tea.world.scenario import load_scenario

    scenario, model = load_scenario("default_apartment"), load_model(CHECK_MODEL)
    env = FakeHouse(scenario, env_config_for(model, effect_success={"boil": boil}))
    path = tmp_path / f"episode{seed}.jsonl"
    log = EventLog(path)
    try:
        runner = EpisodeRunner(scenario, model, env, RunConfig(seed=seed), log)
        runner.run()
    finally:
        log.close()
    return path, runner.events, env


def test_the_learned_model_loads_and_changes_the_boil_the_belief_uses(tmp_path):
    from fg_tea.beliefs.engine import BeliefEngine
    from fg_tea.model.spec import Effect, load_model
    from fg_tea.study.learn import learn_files
    from fg_tea.world.scenario import load_scenario

    path, events, _ = _episode(tmp_path, 0, 0.0)  # the kettle never heats: readings say "cold"
    assert any(e["event"] == "state_reading" and e["state"] == "kettle.water_hot" for e in events)
    out, learning = learn_files([path], CHECK_MODEL, tmp_path / "learned.toml")
    terms = learning.counts.transitions["boil.effect0"]
    text = out.read_text()
    assert "[learning.transitions.boil.effect0]" in text and 'state = "{object}.water_hot"' in text
    learned = load_model(out)
    success = learned.transition("boil").effects[0].success
    assert success == pytest.approx(lt.posterior_mean(0.995, 5.0, terms))
    assert success < 0.9  # cold readings pulled it down from 0.995
    beliefs = []
    for model in (load_model(CHECK_MODEL), learned):
        engine = BeliefEngine(load_scenario("default_apartment"), model)
        engine.observe_state("kettle.contains_water", True, model.sensor("state"))
        e = model.transition("boil").effects[0]
        engine.apply_effects([Effect("kettle.water_hot", True, e.success, ("kettle.contains_water",))])
        beliefs.append(engine.state("kettle.water_hot"))
    assert beliefs[1] < beliefs[0] - 0.05
    with pytest.raises(InputError, match="already counted"):
        learn_files([path], out, tmp_path / "again.toml")


def test_the_environment_heats_with_the_true_probability_and_default_logs_do_not_name_it(tmp_path):
    from fg_tea.env.base import EnvConfig
    from fg_tea.env.fake import FakeHouse
    from fg_tea.world.scenario import load_scenario

    _, events, env = _episode(tmp_path, 1, 0.0)
    assert env.truth_report()["states"].get("kettle.water_hot") is not True
    assert events[0]["parameters"]["env"]["effect_success"] == {"boil": 0.0}
    with pytest.raises(ValueError, match="effect_success"):
        FakeHouse(load_scenario("default_apartment"), EnvConfig(effect_success={"brew": 0.5}))
    assert "effect_success" not in __import__("fg_tea.episode.runner", fromlist=["_env_params"])._env_params(
        EnvConfig())


def test_the_experiment_script_runs_small(tmp_path):
    import importlib.util

    script = ROOT / "experiments" / "learned_transitions.py"
    spec = importlib.util.spec_from_file_location("learned_transitions", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = tmp_path / "out"
    assert module.main(["--episodes", "2", "--discovery", "0", "--confirmation", "1", "--models",
                        str(CHECK_MODEL), "--out", str(out)]) == 0
    summary = (out / "summary.md").read_text()
    assert "## discovery" in summary and "## confirmation" in summary and "learned minus hand-set" in summary
    assert (out / "seeds.json").is_file()
    rows = (out / "episodes.csv").read_text().splitlines()
    assert len(rows) == 1 + 2 * 2 * 2  # header + 2 households x 2 arms x 2 episodes


@pytest.mark.parametrize("on", [True, False])
def test_the_lifelong_sweep_applies_learned_transitions_only_when_asked(tmp_path, on):
    import json

    from fg_tea.study.households import HouseholdSpec, run_household

    spec = HouseholdSpec("default_apartment", True, str(CHECK_MODEL), 0, 3, log_dir=str(tmp_path),
                         learn_transitions=on, effect_success=(("boil", 0.0),))
    rows = run_household(spec)
    last = next(r for r in rows if r["arm"] == "learned" and r["episode"] == 3)
    assert "boil.effect0" in last["_learning"].counts.transitions  # counted either way
    log = next(tmp_path.glob("*/learned/household0/episode03.jsonl"))
    boils = [e for e in map(json.loads, log.read_text().splitlines())
             if e.get("event") == "action" and (e.get("parameters") or {}).get("transition") == "boil"]
    used = boils[0]["parameters"]["effects"][0]["success"]
    assert (used < 0.9) if on else (used == 0.995)


def test_the_lifelong_script_takes_learned_transitions_and_true_effect_success():
    import importlib.util

    spec = importlib.util.spec_from_file_location("lifelong", ROOT / "experiments" / "lifelong.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    args = module.build_parser().parse_args(["--scenario", "default_apartment", "--households", "1",
                                             "--learn-transitions", "--effect-success", "boil", "0.6"])
    (household,) = [s for s in module._specs(args) if s.model == "factorised"]
    assert household.learn_transitions and household.effect_success == (("boil", 0.6),)
    bad = module.build_parser().parse_args(["--scenario", "default_apartment", "--effect-success", "brew", "1"])
    with pytest.raises(InputError, match="--effect-success"):
        module._specs(bad)
