"""POUCT and POMCP through pomdp-py on the derived search problem (the optional [peers] extra)."""

from __future__ import annotations

import pytest

pytest.importorskip("pomdp_py")

from fg_tea.env.fake import FakeHouse
from fg_tea.episode.log import encode
from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
from fg_tea.model.spec import load_model
from fg_tea.planning import check_planner_name, make_planner, planner_names
from fg_tea.study.sweep import Job, check_jobs, world_path
from fg_tea.world.distributions import load_world

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


@pytest.mark.parametrize("planner", ["pouct:50", "pomcp:50"])
def test_refusal_names_the_peer(planner, monkeypatch, capsys, tmp_path):
    """A truth table too large is refused before the episode starts, by the planner that
    refuses (for a factorised belief too: the peers hold the table of truths), as a row in a
    sweep and one line with exit status 2 in `fg-tea run`."""
    from fg_tea import cli
    from fg_tea.planning import peers, problem
    from fg_tea.study.sweep import run_job

    kind = planner.split(":")[0]
    monkeypatch.setattr(peers, "MAX_TRUTHS", 100)
    monkeypatch.setattr(problem, "MAX_TRUTHS", 100)
    for model in ("joint_close", "factorised_close"):
        with pytest.raises(ValueError, match=f"^{kind} planner: 3 objects over 8 sites give 512 truths"):
            _run(planner, model)
        row = run_job(Job("correlated", 0, model=model, planner=planner, env="fake"))
        assert row["reason"].startswith(f"refused: size: {kind} planner: 3 objects over 8 sites")
        assert "lookahead" not in row["reason"] and row["success"] is False
    out = tmp_path / "run"
    status = cli.main(["run", "default_apartment", "--model", "joint_close", "--planner", planner,
                       "--no-video", "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and f"the {kind} planner refuses this house" in err[0]
    assert "lookahead" not in err[0] and not (out / "episode.jsonl").exists()


def test_truth_belief_draws_as_pomdp_py_histogram():
    """The belief the peers sample start states from draws exactly what pomdp-py's Histogram over
    the same states and weights draws, for the same seed (it only avoids rebuilding the running
    sums at every simulation)."""
    import random

    import numpy as np
    import pomdp_py

    from fg_tea.planning.peers import _classes

    SearchState, *_, TruthBelief = _classes()
    weights = np.random.default_rng(3).dirichlet(np.ones(300))
    weights[[5, 17]] = 0.0
    states = [SearchState(-1, t, 0, 0) for t in range(len(weights))]
    fast = TruthBelief(states, weights)
    slow = pomdp_py.Histogram({s: float(w) for s, w in zip(states, weights)})
    random.seed(11)
    a = [fast.random().t for _ in range(2000)]
    random.seed(11)
    b = [slow.random().t for _ in range(2000)]
    assert a == b and 5 not in a and 17 not in a
    assert fast.mpe().t == slow.mpe().t and fast[states[9]] == pytest.approx(weights[9])
