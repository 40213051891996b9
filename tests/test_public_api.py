"""The public Python API: labelled beliefs, name-based queries, reset, stepping and the README.

Checks that the belief names its sites, objects and states; that a location marginal reads as a
site -> probability mapping; that ``joint``/``entropy`` take object and state names and name the
valid ones otherwise; that the first step writes only the prior; that ``reset(seed)`` gives the
events of a fresh runner; that every event kind written is documented (docs/design.md §9); and
that the README's Python example runs as it stands.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from fg_tea.beliefs.engine import BeliefEngine, UnknownVariableError
from fg_tea.env.fake import FakeHouse
from fg_tea.episode.log import EVENT_KINDS, MERGED_KINDS
from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
from fg_tea.model.spec import load_model
from fg_tea.world.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def joint_belief():
    return BeliefEngine(load_scenario("default_apartment"), load_model("joint"))


def test_belief_names_sites_objects_and_states(joint_belief):
    b = joint_belief
    scenario = load_scenario("default_apartment")
    assert b.sites == scenario.site_names and b.objects == scenario.object_names
    assert "kettle.contains_water" in b.state_names and list(b.state_names) == sorted(b.state_names)
    assert b.variables[:len(b.objects)] == tuple(f"L[{o}]" for o in b.objects)
    assert b.variables[len(b.objects):] == b.state_names
    q = b.location_map("mug")
    assert list(q) == list(b.sites)
    np.testing.assert_allclose(list(q.values()), b.location("mug"), rtol=0, atol=0)
    assert b.location_maps()["kettle"] == b.location_map("kettle")


def test_queries_take_object_and_state_names(joint_belief):
    b = joint_belief
    assert b.entropy("mug") == b.entropy("L[mug]")
    np.testing.assert_array_equal(b.joint(["mug", "kettle"]), b.joint(["L[mug]", "L[kettle]"]))
    np.testing.assert_array_equal(b.joint(["kettle", "mug"]), b.joint(["mug", "kettle"]).T)
    p = b.state("kettle.contains_water")
    np.testing.assert_allclose(b.marginal("kettle.contains_water"), [1 - p, p])
    pair = b.joint(["kettle.contains_water", "kettle.water_hot"])
    assert pair.shape == (2, 2) and pair.sum() == pytest.approx(1.0)
    np.testing.assert_array_equal(b.location("L[mug]"), b.location("mug"))


@pytest.mark.parametrize("call", [
    lambda b: b.entropy("cup"),
    lambda b: b.joint(["mug", "L[cup]"]),
    lambda b: b.marginal("kettle.boiling"),
    lambda b: b.location("cup"),
    lambda b: b.state("cup.full"),
])
def test_unknown_names_are_a_key_error_naming_the_valid_ones(joint_belief, call):
    with pytest.raises(KeyError) as exc:
        call(joint_belief)
    assert isinstance(exc.value, UnknownVariableError)
    message = str(exc.value)
    assert not message.startswith(("'", '"'))  # the message itself, not a quoted repr
    assert "mug" in message or "kettle.contains_water" in message


def test_joint_of_locations_and_states_together_is_refused(joint_belief):
    with pytest.raises(ValueError, match="independent blocks"):
        joint_belief.joint(["mug", "kettle.contains_water"])
    with pytest.raises(TypeError, match="list of variable names"):
        joint_belief.joint("mug")


def _runner(seed: int = 3, **config) -> EpisodeRunner:
    s, m = load_scenario("default_apartment"), load_model("joint")
    return EpisodeRunner(s, m, FakeHouse(s, env_config_for(m)), RunConfig(seed=seed, **config))


def _episode(runner: EpisodeRunner) -> list[dict]:
    runner.run()
    return runner.events


def test_first_step_is_the_prior_and_every_step_ends_with_a_belief():
    runner = _runner()
    prior = runner.agent.belief.location_map("mug")
    first = runner.step()
    assert [e["event"] for e in first] == ["episode_start"]
    assert first[0]["belief"]["locations"]["mug"] == pytest.approx(list(prior.values()))
    assert runner.agent.last_decision is None and runner.agent.belief.location_map("mug") == prior
    while not runner.done:
        events = runner.step()
        kinds = [e["event"] for e in events]
        if kinds[-1] == "metrics":
            assert kinds[-2:] == ["episode_end", "metrics"]
        else:
            assert kinds[-1] == "belief" and kinds.count("belief") == 1
            assert kinds.count("decision") <= 1 and kinds.count("observation") <= 1
    assert runner.step() == []


def test_reset_with_a_seed_gives_the_events_of_a_fresh_runner():
    fresh = _episode(_runner(seed=5, planner="random"))
    runner = _runner(seed=0, planner="random")
    _episode(runner)
    start = runner.reset(seed=5)
    assert start["event"] == "episode_start" and start["seed"] == 5 and runner.events == [start]
    assert not runner.done and runner.agent.last_decision is None
    assert _episode(runner) == fresh
    runner.reset()  # the same seed again
    assert _episode(runner) == fresh
    other = _runner(seed=6, planner="random")
    assert _episode(other) != fresh


def _design_section_9() -> str:
    text = (ROOT / "docs" / "design.md").read_text()
    start = text.index("## 9. The log")
    return text[start:text.index("\n## 10.", start)]


def test_every_event_kind_is_documented():
    section = _design_section_9()
    table = {m.group(1) for m in re.finditer(r"^\| `(\w+)` \|", section, re.M)}
    assert table == set(EVENT_KINDS)
    for kind in MERGED_KINDS:
        assert f"`{kind}`" in section
    # Every kind the code can write is one of them: scan the literals the agent and runner write.
    written = set()
    for path in (ROOT / "fg_tea").rglob("*.py"):
        written |= set(re.findall(r'"event": "(\w+)"', path.read_text()))
    assert written <= set(EVENT_KINDS) | set(MERGED_KINDS), written - set(EVENT_KINDS) - set(MERGED_KINDS)
    documented = (ROOT / "docs" / "log-format.md").read_text()
    for kind in EVENT_KINDS:
        assert f"`{kind}`" in documented, kind


def test_event_kinds_seen_in_episodes_are_the_documented_ones():
    seen: set[str] = set()
    s = load_scenario("default_apartment")
    for model_name, rates in (("joint", {}), ("factorised", {"FILL": 0.5, "PLACE": 0.5, "PICK": 0.3})):
        m = load_model(model_name)
        for seed in range(3):
            env = FakeHouse(s, env_config_for(m, failure_rates=rates))
            runner = EpisodeRunner(s, m, env, RunConfig(seed=seed))
            runner.run()
            seen |= {e["event"] for e in runner.events}
    assert seen <= set(EVENT_KINDS)
    assert {"episode_start", "activate", "decision", "observation", "confirm_search",
            "state_reading", "action", "belief", "episode_end", "metrics",
            "action_failed"} <= seen


def _readme_python_examples() -> list[str]:
    text = (ROOT / "README.md").read_text()
    section = text[text.index("## Python API"):]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert len(blocks) >= 2, "the stepping example and the made-up-observations example"
    return blocks


def _readme_python_example() -> str:
    return _readme_python_examples()[0]


def test_readme_examples_use_only_the_public_api():
    for code in _readme_python_examples():
        imports = re.findall(r"^\s*(?:from|import) (fg_tea\S*)", code, re.M)
        assert imports and set(imports) == {"fg_tea"}, imports
        assert "from fg_tea" not in code


def test_readme_made_up_observations_example_runs_without_a_simulator(capsys):
    import subprocess
    import sys

    code = _readme_python_examples()[1] + "\nimport sys\nprint(sorted(m for m in sys.modules if m.startswith('pybullet')))\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.strip().splitlines()
    assert lines[-1] == "[]"  # no simulator was loaded
    assert lines[0].startswith("search_mug -> ")
    q_sideboard, next_action = lines[-2].split()
    assert float(q_sideboard) > 0.99 and next_action == "pick_mug"


def test_public_api_lists_every_name_and_loads_lazily():
    import subprocess
    import sys

    code = ("import sys, fg_tea as fg\n"
            "assert 'numpy' not in sys.modules, 'import fg_tea loads numpy'\n"
            "missing = [n for n in fg.__all__ if getattr(fg, n, None) is None]\n"
            "assert not missing, missing\n"
            "import pydoc\ntext = pydoc.render_doc(fg, renderer=pydoc.plaintext)\n"
            "print(all(n in text for n in fg.__all__ if not n.startswith('_')))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "True"


def test_readme_python_example_runs_unchanged(tmp_path, monkeypatch, capsys):
    code = _readme_python_example()
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__readme__"}
    exec(compile(code, "README.md", "exec"), namespace)
    out = capsys.readouterr().out
    png = tmp_path / "runs" / "mug_belief.png"
    assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    history, runner = namespace["history"], namespace["runner"]
    assert namespace["agent"] is runner.agent
    assert runner.done and runner.reason == "complete" and "complete" in out
    assert len(history) == runner.state.steps + 2  # the prior, each action step, the end step
    assert history[0] == pytest.approx(dict(zip(runner.events[0]["belief"]["sites"],
                                                runner.events[0]["belief"]["locations"]["mug"])))
    assert max(history[-1].values()) > 0.99  # the mug was found
