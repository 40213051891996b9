"""The third task, make_tea_milk_sugar: its graph, truth effects, bodies and whole episodes."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from fg_tea.beliefs.graph import build_graph
from fg_tea.env.fake import FakeHouse
from fg_tea.env.house import PyBulletHouse
from fg_tea.env.truth import EFFECTS, TeaTruth
from fg_tea.episode.log import EventLog
from fg_tea.episode.metrics import score
from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
from fg_tea.common.errors import InputError
from fg_tea.world.interface import ActionRequest
from fg_tea.model.spec import load_model
from fg_tea.world.scenario import load_scenario
from fg_tea.tasks import load_task

TASK = "make_tea_milk_sugar"
SCENARIO = load_scenario("milk_sugar_apartment")
MODELS = ("factorised", "joint")

# The actions the task adds to make_tea, and serve_tea's new dependencies: id -> (verb, deps).
ADDED = {
    "search_milk": ("SEARCH", set()),
    "pick_milk": ("PICK", {"search_milk", "steep_tea", "place_kettle"}),
    "carry_milk": ("NAVIGATE", {"pick_milk"}),
    "pour_milk": ("POUR", {"carry_milk"}),
    "place_milk": ("PLACE", {"pour_milk"}),
    "search_sugar": ("SEARCH", set()),
    "pick_sugar": ("PICK", {"search_sugar", "place_milk"}),
    "carry_sugar": ("NAVIGATE", {"pick_sugar"}),
    "add_sugar": ("POUR", {"carry_sugar", "steep_tea"}),
    "place_sugar": ("PLACE", {"add_sugar"}),
    "serve_tea": ("USE", {"steep_tea", "place_kettle", "place_milk", "place_sugar"}),
}


def run(model: str, env_cls=FakeHouse, seed: int = 0) -> EpisodeRunner:
    m = load_model(model)
    env = env_cls(SCENARIO, env_config_for(m))
    try:
        with EventLog(None) as log:
            runner = EpisodeRunner(SCENARIO, m, env, RunConfig(seed=seed, task=TASK), log)
            runner.run()
    finally:
        env.close()
    return runner


# ---------------------------------------------------------------------- the task graph

@pytest.mark.parametrize("model", MODELS)
def test_task_is_make_tea_plus_milk_and_sugar(model):
    m = load_model(model)
    graph = load_task(TASK, m, SCENARIO)
    tea = load_task("make_tea", m, SCENARIO)
    assert len(graph) == len(tea) + 10 == 28
    for node in graph:
        if node in ADDED:
            verb, deps = ADDED[node]
        else:  # every make_tea action keeps its verb and dependencies
            verb, deps = tea.action(node).verb, set(tea.dependencies(node))
        assert graph.action(node).verb == verb, node
        assert set(graph.dependencies(node)) == deps, node
    # the old actions come first, in make_tea's order; serving is the last thing done
    assert list(graph)[:17] == [n for n in tea if n != "serve_tea"]
    assert graph.descendants("steep_tea")[-1] == "serve_tea"
    assert set(graph.descendants("pour_milk")) >= {"place_milk", "pick_sugar", "add_sugar", "serve_tea"}


def test_milk_and_sugar_effects_goals_and_serve_preconditions():
    graph = load_task(TASK, load_model("factorised"), SCENARIO)
    milk, sugar, serve = graph.action("pour_milk"), graph.action("add_sugar"), graph.action("serve_tea")
    assert (milk.object, milk.destination, milk.transition) == ("milk", "mug", "add_milk")
    assert (sugar.object, sugar.destination, sugar.transition) == ("sugar", "mug", "add_sugar")
    assert [(e.state, e.value) for e in milk.effects] == [("mug.has_milk", True)]
    assert [(e.state, e.value) for e in sugar.effects] == [("mug.has_sugar", True)]
    assert [(c.state, c.at_least) for c in milk.goals] == [("mug.has_milk", 0.90)]
    assert [(c.state, c.at_least) for c in serve.preconditions] == [
        ("mug.tea_brewed", 0.90), ("mug.has_milk", 0.90), ("mug.has_sugar", 0.90)]
    assert graph.declared_states == {"mug.has_milk": 0.01, "mug.has_sugar": 0.01}
    # make_tea's serve is untouched: the extra preconditions belong to this task only
    plain = load_task("make_tea", load_model("factorised"), SCENARIO).action("serve_tea")
    assert [c.state for c in plain.preconditions] == ["mug.tea_brewed"]


def test_task_needs_milk_and_sugar_in_the_scenario():
    with pytest.raises(InputError, match="object 'milk' is not an object of scenario 'default_apartment'"):
        load_task(TASK, load_model("factorised"), load_scenario("default_apartment"))


# ---------------------------------------------------------------------- the model's relations

def test_sugar_relations_apply_only_where_there_is_sugar():
    joint = load_model("joint")
    five = build_graph(SCENARIO, joint)
    labels = {p.label for p in five.pairs}
    assert {"co_location teabag~kettle", "co_location sugar~kettle",
            "co_location sugar~teabag"} <= labels
    assert not any("milk" in label for label in labels)  # milk's kitchen tendency is a prior
    three = build_graph(load_scenario("default_apartment"), joint)
    assert [p.label for p in three.pairs] == ["co_location teabag~kettle"]
    assert three.relational_labels == ("capacity", "co_location teabag~kettle")


# ---------------------------------------------------------------------- truth effects

def test_add_milk_and_add_sugar_truth_effects():
    assert {"add_milk", "add_sugar"} <= set(EFFECTS)
    truth = TeaTruth(SCENARIO.objects)
    for name in ("contains_water", "water_hot", "tea_brewed"):
        truth.set("mug", name, True)
    before = dict(truth.states)
    truth.apply_effect("add_milk", "milk", "mug")
    assert truth.get("mug", "has_milk") and not truth.get("mug", "has_sugar")
    truth.apply_effect("add_sugar", "sugar", "mug")
    assert truth.get("mug", "has_sugar")
    assert {k: v for k, v in truth.states.items() if k in before} == before  # nothing else moves
    for effect in ("add_milk", "add_sugar"):
        with pytest.raises(ValueError, match="needs a destination"):
            truth.apply_effect(effect, "milk")


def test_pouring_milk_needs_it_held_and_the_mug_in_reach():
    env = FakeHouse(SCENARIO)
    env.reset(0)
    pour = ActionRequest("POUR", "milk", "sideboard", "mug", "add_milk")
    assert env.execute(pour).reason == "not_held"
    assert env.execute(ActionRequest("PICK", "milk", "kitchen_counter")).ok
    assert not env.truth_report()["states"].get("mug.has_milk", False)
    assert env.execute(pour).ok
    assert env.truth_report()["states"]["mug.has_milk"] is True
    with pytest.raises(ValueError, match="unknown truth effect"):
        env.execute(ActionRequest("POUR", "milk", "sideboard", "mug", "add_cream"))


# ---------------------------------------------------------------------- episodes

def _check_episode(runner: EpisodeRunner) -> None:
    metrics = runner.metrics()
    assert metrics["success"], metrics["reason"]
    assert metrics["actions_complete"] + metrics["actions_skipped"] == metrics["actions_total"] == 28
    assert metrics["goals_true"] is True  # every goal it believes holds in the world too
    assert set(metrics["inspections_until_resolved"]) == set(SCENARIO.object_names)
    end = next(e for e in runner.events if e["event"] == "episode_end")
    truth = end["world_truth"]
    for state in ("mug.tea_brewed", "mug.has_milk", "mug.has_sugar", "mug.served"):
        assert truth["states"][state] is True, state
        assert state in end["goal_conditions"]["final_states"], state
    prep = SCENARIO.preparation_site
    assert set(truth["sites"].values()) == {prep} and truth["held"] is None
    assert truth["contained_in"] == {"teabag": "mug"}  # the teabag stays in the mug
    order = [e["action"] for e in runner.events if e["event"] == "action"]
    assert order.index("steep_tea") < order.index("pour_milk") < order.index("add_sugar")
    assert order[-1] == "serve_tea"


@pytest.mark.parametrize("model", MODELS)
def test_fake_episode_makes_tea_with_milk_and_sugar(model):
    _check_episode(run(model))


def test_pybullet_episode_makes_tea_with_milk_and_sugar():
    _check_episode(run("joint", PyBulletHouse))  # ~2 s; how long it takes is no test's business


# ---------------------------------------------------------------------- bodies

@pytest.fixture(scope="module")
def house():
    h = PyBulletHouse(SCENARIO)
    h.reset(0)
    yield h
    h.close()


@pytest.mark.parametrize("obj", ["milk", "sugar"])
def test_milk_and_sugar_are_detected_on_each_site_from_its_vantage(house, obj):
    house.reset(0)
    for site in SCENARIO.sites:
        house.move_object(obj, site.name)
        result = house.inspect_viewpoint(site.name, [obj])
        assert result.detections[obj], (obj, site.name, result.pixel_counts)
        assert result.pixel_counts[obj] >= 25


def test_milk_is_medium_and_sugar_small_in_the_image(house):
    """Pixel counts follow real sizes: sugar ~ teabag < mug < milk < kettle, site by site."""
    for site in SCENARIO.sites:
        house.reset(0)
        parking = "console_table" if site.name != "console_table" else "coffee_table"
        for obj in SCENARIO.object_names:
            house.move_object(obj, parking)
        counts = {}
        for obj in SCENARIO.object_names:  # alone on the site, so nothing occludes it
            house.move_object(obj, site.name)
            counts[obj] = house.inspect_viewpoint(site.name, [obj]).pixel_counts[obj]
            house.move_object(obj, parking)
        assert counts["mug"] < counts["milk"] < counts["kettle"], (site.name, counts)
        assert counts["sugar"] < counts["mug"] * 1.2, (site.name, counts)
        assert 0.5 < counts["sugar"] / counts["teabag"] < 2.0, (site.name, counts)


def test_five_bodies_look_different(house):
    """Mean colours of the five bodies, all on one counter, differ pairwise.

    The threshold 0.15 (RGB in [0, 1]) is three quarters of the closest pair measured, milk and
    teabag at 0.20; the three original bodies are more than 0.5 apart.
    """
    house.reset(0)
    for obj in SCENARIO.object_names:
        house.move_object(obj, "kitchen_counter")
    assert all(house.inspect_viewpoint("kitchen_counter", list(SCENARIO.object_names)).detections.values())
    rgb, _, semantic = house.render_ego(house.config.ego_width, house.config.ego_height)
    means = {o.name: rgb[semantic == o.semantic_id].mean(axis=0) / 255.0 for o in SCENARIO.objects}
    for a, b in itertools.combinations(means, 2):
        assert np.linalg.norm(means[a] - means[b]) > 0.15, (a, b, means[a], means[b])
