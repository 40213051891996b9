"""Episodes through the compiled path (docs/design.md §4.8): with ``--solver compiled`` the
belief's location block is a compiled program (fg_tea/beliefs/compiled_location.py), and every
log is the numpy path's to 9 significant digits (tests/golden_match.py): the golden episodes of
the bundled models, and the fake house with occlusion's coupled looks, the close-look models, a
larger generated house and model programs (a user factor over three objects; task states coupled
with two objects' locations)."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

import fg_tea as fg
from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.cli.main import main
from golden_match import event_differences, report
from test_golden_logs import golden_logs

ROOT = Path(__file__).resolve().parent.parent


def _events(args: list[str], out: Path) -> list[dict]:
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["run", *args, "--no-video", "--out", str(out)]) == 0
    events = [json.loads(line) for line in (out / "episode.jsonl").read_text().splitlines()]
    for key in ("versions", "git", "inputs"):
        events[0].pop(key, None)
    return events


def _same_but_the_solver(expected: list[dict], actual: list[dict], where: str) -> None:
    assert actual[0]["parameters"]["run"]["belief_backend"] == "compiled"
    actual[0]["parameters"]["run"]["belief_backend"] = expected[0]["parameters"]["run"]["belief_backend"]
    # The log names the method each query used (docs/log-format.md): the compiled block's (or its
    # subset program), with its components; the factor attribution must be the same.
    mine, theirs = actual[0]["inference"], expected[0]["inference"]
    assert mine["solver"] == "compiled" and mine["locations"] in ("compiled", "structured")
    assert ("components" in mine) == (mine["locations"] == "compiled")
    assert mine["attribution"] == theirs["attribution"] and mine["states"] == theirs["states"]
    actual[0]["inference"] = theirs
    found = list(event_differences(expected, actual))
    assert not found, report(where, found)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["default_apartment-factorised-0", "default_apartment-joint-1",
                                  "generated_small-factorised-2", "generated_small-joint-0",
                                  "milk_sugar_apartment-factorised-1", "milk_sugar_apartment-joint-2"])
def test_golden_episodes_through_the_compiled_location_block(name, tmp_path):
    scenario, model, seed = name.rsplit("-", 2)
    task = ["--task", "make_tea_milk_sugar"] if scenario == "milk_sugar_apartment" else []
    events = _events([scenario, "--model", model, "--seed", seed, *task, "--solver", "compiled"], tmp_path)
    _same_but_the_solver(golden_logs()[name], events, f"golden [{name}] through --solver compiled")


@pytest.mark.parametrize("args", [
    ["--model", "factorised_occlusion", "--seed", "3"],
    ["--model", "joint_close", "--seed", "1"],
    ["generated_medium", "--model", "joint", "--seed", "2"],
    ["--model", str(ROOT / "experiments" / "programs" / "kept_together.py"), "--seed", "0"],
    ["--model", str(ROOT / "experiments" / "programs" / "together_when_full.py"), "--seed", "4"],
])
def test_the_fake_house_through_the_compiled_location_block(args, tmp_path):
    numpy = _events([*args, "--env", "fake"], tmp_path / "numpy")
    compiled = _events([*args, "--env", "fake", "--solver", "compiled"], tmp_path / "compiled")
    _same_but_the_solver(numpy, compiled, " ".join(args))


def test_the_compiled_block_is_rebuilt_only_when_its_factors_change():
    scenario = fg.load_scenario("default_apartment")
    engine = BeliefEngine(scenario, fg.load_model("joint"), backend="compiled")
    assert engine.location_method == "compiled"
    reference = BeliefEngine(scenario, fg.load_model("joint"))
    first = engine.location_matrix()
    base = engine._compiled_base[1]
    for e in (engine, reference):
        e.observe_site(scenario.sites[0].name, {"mug": False, "kettle": False, "teabag": False})
    np.testing.assert_allclose(engine.location_matrix(), reference.location_matrix(), rtol=0, atol=1e-14)
    np.testing.assert_allclose(engine.pairwise(), reference.pairwise(), rtol=0, atol=1e-14)
    engine._cache.pop("compiled")  # the dense joint the planners' gains read is the block's table
    np.testing.assert_allclose(engine.location_joint(), reference.location_joint(), rtol=0, atol=1e-15)
    assert "compiled" in engine._cache
    assert engine._compiled_base[1] is base and not np.allclose(first, engine.location_matrix())
    with pytest.raises(ValueError, match="'numpy', 'gtsam' or 'compiled'"):
        BeliefEngine(scenario, fg.load_model("joint"), backend="pgmpy")


def test_a_large_site_local_block_is_answered_by_the_subset_program_the_gains_read():
    """Three objects in a 45-site house under the joint model (85,184 joint states, relations
    site/room-local): the compiled backend answers by the subset program, the one the planners'
    joint gains read, so a decision builds one model, not a dense table beside it."""
    from fg_tea.study.sweep import world_path
    from fg_tea.world.distributions import load_world

    scenario = load_world(world_path("generated_large")).sample(0)
    engine = BeliefEngine(scenario, fg.load_model("joint"), backend="compiled")
    reference = BeliefEngine(scenario, fg.load_model("joint"))
    assert engine.location_method == reference.location_method == "structured"
    for e in (engine, reference):
        e.observe_site(scenario.sites[0].name, {o: False for o in e.objects})
    np.testing.assert_allclose(engine.location_matrix(), reference.location_matrix(), rtol=0, atol=1e-14)
    assert engine.structured_model() is engine._cache["structured"]
    assert "compiled" not in engine._cache
    smaller = BeliefEngine(load_world(world_path("generated_medium")).sample(0), fg.load_model("joint"),
                           backend="compiled")
    assert smaller.location_method == "compiled"  # 19,683 states: the compiled dense table
