"""The clairvoyant yardstick and SPL: exact routes, the log record, and the metric's range."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from fg_tea.env.fake import FakeHouse
from fg_tea.env.house import PyBulletHouse
from fg_tea.episode.metrics import score
from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
from fg_tea.episode.yardstick import clairvoyant_route, sees_table, spl
from fg_tea.model.spec import load_model
from fg_tea.world.scenario import load_scenario


def brute_force(objects, sees, start, legs):
    """Shortest covering route by enumerating every ordered selection of distinct viewpoints."""
    names = list(sees)
    best = math.inf
    for r in range(1, len(names) + 1):
        for order in itertools.permutations(names, r):
            if set().union(*(set(sees[v]) for v in order)) >= set(objects):
                length = start[order[0]] + sum(legs[a][b] for a, b in zip(order, order[1:]))
                best = min(best, length)
    return best


@pytest.mark.parametrize("seed", range(12))
def test_route_is_the_brute_force_optimum(seed):
    rng = np.random.default_rng(seed)
    objects = [f"o{i}" for i in range(int(rng.integers(1, 4)))]
    names = [f"v{i}" for i in range(int(rng.integers(2, 6)))]
    xy = {v: rng.uniform(0, 10, 2) for v in names}
    start_xy = rng.uniform(0, 10, 2)
    sees = {v: [o for o in objects if rng.random() < 0.4] for v in names}
    for o in objects:  # every object seen from somewhere
        if not any(o in s for s in sees.values()):
            sees[names[int(rng.integers(len(names)))]].append(o)
    sees = {v: s for v, s in sees.items() if s}
    # Walked legs: straight line times a detour factor >= 1 (so straight lines bound them).
    detour = {(a, b): 1 + rng.uniform(0, 0.5) for a in names for b in names}
    walk = {a: {b: 0.0 if a == b else float(np.hypot(*(xy[a] - xy[b])) * detour[(a, b)])
                for b in names} for a in names}
    start = {v: float(np.hypot(*(xy[v] - start_xy)) * detour[(v, v)]) for v in names}
    expected = brute_force(objects, sees, start, walk)
    eager = clairvoyant_route(objects, sees, start.__getitem__, lambda a, b: walk[a][b])
    lazy = clairvoyant_route(objects, sees, start.__getitem__, lambda a, b: walk[a][b],
                             {v: xy[v] for v in names}, start_xy)
    assert eager[0] == pytest.approx(expected, abs=1e-12)
    assert lazy[0] == pytest.approx(expected, abs=1e-12)
    covered = set().union(*(set(sees[v]) for v in lazy[1]))
    assert covered >= set(objects)


def test_route_may_pass_a_viewpoint_that_sees_nothing_new():
    # a->c directly is long (a wall); a->b->c is short; b sees nothing b did not (it sees o1 too).
    sees = {"a": ["o1"], "b": ["o1"], "c": ["o2"]}
    legs = {("a", "b"): 1.0, ("b", "c"): 1.0, ("a", "c"): 10.0, ("b", "a"): 1.0, ("c", "a"): 10.0,
            ("c", "b"): 1.0}
    length, route = clairvoyant_route(["o1", "o2"], sees, {"a": 0.0, "b": 5.0, "c": 9.0}.__getitem__,
                                      lambda x, y: legs[(x, y)])
    assert length == pytest.approx(2.0) and route == ("a", "b", "c")


def test_unseeable_object_gives_no_route_and_no_objects_a_zero_route():
    assert clairvoyant_route(["o1"], {"a": ["o1"]}, lambda v: math.inf, lambda a, b: 1.0) is None
    assert clairvoyant_route([], {}, lambda v: 1.0, lambda a, b: 1.0) == (0.0, ())


def test_sees_table_uses_the_viewpoints_sites():
    views = [{"name": "s1", "sites": ["s1"]}, {"name": "s2", "sites": ["s2"]},
             {"name": "room", "sites": ["s1", "s2"]}]
    table = sees_table(views, {"mug": "s2", "kettle": "s1", "teabag": "s3"}, ["mug", "kettle"])
    assert table == {"s1": ("kettle",), "s2": ("mug",), "room": ("mug", "kettle")}


def test_spl_cases():
    assert spl(True, 10.0, 5.0) == 0.5
    assert spl(True, 4.0, 5.0) == 1.0  # search travel below the bound saturates
    assert spl(False, 4.0, 5.0) == 0.0
    assert spl(True, 0.0, 0.0) == 1.0
    assert spl(True, 3.0, None) is None


def fake_runner(model: str, scenario: str = "default_apartment", seed: int = 0) -> EpisodeRunner:
    s, m = load_scenario(scenario), load_model(model)
    runner = EpisodeRunner(s, m, FakeHouse(s, env_config_for(m)), RunConfig(seed=seed))
    runner.run()
    return runner


@pytest.mark.parametrize("model", ["factorised", "factorised_close", "joint_close"])
def test_episode_end_carries_the_yardstick_and_the_score_its_spl(model):
    runner = fake_runner(model)
    end = next(e for e in runner.events if e["event"] == "episode_end")
    start = runner.events[0]
    record = end["yardstick"]
    truth = {s.name: s.true_site for s in runner.scenario.objects}
    views = {v["name"]: v for v in start["viewpoints"]}
    assert set(record["route"]) <= set(views)  # only the model's own viewpoints
    seen = {o for v in record["route"] for o in start["searched"] if truth[o] in views[v]["sites"]}
    assert seen == set(start["searched"])
    if model != "factorised":  # close looks only: every route stop is a site
        assert all(views[v]["kind"] == "site" for v in record["route"])
    metrics = score(runner.events)
    assert metrics["clairvoyant_search_travel"] == record["clairvoyant_search_travel"] > 0
    assert 0.0 <= metrics["spl"] <= 1.0
    expected = metrics["clairvoyant_search_travel"] / max(metrics["search_distance"],
                                                          metrics["clairvoyant_search_travel"])
    assert metrics["spl"] == pytest.approx(expected, abs=1e-6)  # search_distance is rounded
    assert runner.events[-1]["spl"] == metrics["spl"]  # the logged metrics event has it too


def test_spl_is_zero_when_the_search_fails():
    runner = fake_runner("factorised_close")
    events = [dict(e) for e in runner.events]
    for e in events:
        if e["event"] == "observation":
            e["resolved"] = []
    assert score(events)["spl"] == 0.0


def test_old_logs_without_a_yardstick_score_none():
    runner = fake_runner("factorised_close")
    events = [{k: v for k, v in e.items() if k != "yardstick"} for e in runner.events]
    metrics = score(events)
    assert metrics["clairvoyant_search_travel"] is None and metrics["spl"] is None


def test_walked_legs_are_what_the_agent_walks_in_the_pybullet_house():
    """The yardstick's first leg equals the logged travel of a look made from the start."""
    s, m = load_scenario("default_apartment"), load_model("factorised_close")
    env = PyBulletHouse(s, env_config_for(m))
    try:
        runner = EpisodeRunner(s, m, env, RunConfig(seed=0))
        runner.start()
        pose = env.agent_pose()
        runner.step()
        look = next(e for e in runner.events if e["event"] == "observation")
        assert env.walking_distance(look["viewpoint"], (pose.x, pose.y)) == pytest.approx(look["distance"], abs=1e-6)
        # The planner's grid estimate is longer than the walk (docs/design.md §8.2).
        decision = next(e for e in runner.events if e["event"] == "decision")
        planned = next(c for c in decision["candidates"] if c["viewpoint"] == look["viewpoint"])["distance"]
        assert look["distance"] <= planned + 1e-9
    finally:
        env.close()
