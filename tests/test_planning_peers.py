"""POUCT and POMCP through pomdp-py on the derived search problem (the optional [peers] extra)."""

from __future__ import annotations

import pytest

pytest.importorskip("pomdp_py")

from fg_tea.env.fake import FakeHouse
from fg_tea.episode.log import encode
from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
from fg_tea.model import load_model
from fg_tea.planning import check_planner_name, make_planner, planner_names
from fg_tea.sweep import Job, check_jobs, world_path
from fg_tea.worlds import load_world

pytestmark = pytest.mark.peers


def _run(planner, model_name="factorised_close", seed=1):
    scenario = load_world(world_path("correlated")).sample(seed)
    model = load_model(model_name)
    env = FakeHouse(scenario, env_config_for(model))
    runner = EpisodeRunner(scenario, model, env, RunConfig(seed=seed, planner=planner))
    runner.run()
    return runner


@pytest.mark.parametrize("planner", ["pouct:200", "pomcp:200"])
def test_peer_finds_everything_and_is_reproducible(planner):
    a, b = _run(planner), _run(planner)
    assert a.metrics()["success"]
    decisions = [e for e in a.log.events if e["event"] == "decision"]
    assert decisions and all(e["planner"] == planner for e in decisions)
    assert all(e["info"]["best_value"] <= e["info"]["second_value"] for e in decisions)
    assert [encode(e) for e in a.log.events] == [encode(e) for e in b.log.events]


def test_peer_with_room_glances():
    runner = _run("pouct:100", "factorised", seed=2)
    assert runner.done and any(e["event"] == "decision" for e in runner.log.events)


def test_peer_names_in_registry_and_sweeps():
    assert {"pouct:1000", "pomcp:1000"} <= set(planner_names())
    check_planner_name("pouct:50")
    check_jobs([Job(world="correlated", world_seed=0, model="factorised_close", planner="pomcp:20",
                    env="fake")])
    with pytest.raises(ValueError):
        make_planner("pouct:0", load_model("factorised"))
