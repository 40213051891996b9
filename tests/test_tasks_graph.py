"""Task graph structure: the make-tea graph (docs/design.md §7.2), readiness [18], relevance [14, 15],
validation and task files."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from fg_tea.common.errors import InputError
from fg_tea.model.spec import load_model
from fg_tea.world.scenario import load_scenario
from fg_tea.tasks import TaskAction, TaskGraph, load_task

ROOT = Path(__file__).resolve().parent.parent

# The make-tea graph of docs/design.md §7.2, written out: action -> (kind, dependencies).
TABLE_2 = {
    "search_mug": ("SEARCH", set()),
    "pick_mug": ("PICK", {"search_mug"}),
    "carry_mug": ("NAVIGATE", {"pick_mug"}),
    "place_mug": ("PLACE", {"carry_mug"}),
    "search_teabag": ("SEARCH", set()),
    "pick_teabag": ("PICK", {"search_teabag", "place_mug"}),
    "carry_teabag": ("NAVIGATE", {"pick_teabag"}),
    "insert_teabag": ("INSERT", {"carry_teabag", "place_mug"}),
    "search_kettle": ("SEARCH", set()),
    "inspect_kettle_water": ("INSPECT", {"search_kettle"}),
    "fill_kettle": ("FILL", {"inspect_kettle_water"}),
    "boil_kettle": ("USE", {"fill_kettle"}),
    "pick_kettle": ("PICK", {"boil_kettle", "insert_teabag"}),
    "carry_kettle": ("NAVIGATE", {"pick_kettle"}),
    "pour_hot_water": ("POUR", {"carry_kettle", "insert_teabag"}),
    "place_kettle": ("PLACE", {"pour_hot_water"}),
    "steep_tea": ("WAIT", {"pour_hot_water"}),
    "serve_tea": ("USE", {"steep_tea", "place_kettle"}),
}


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("default_apartment")


@pytest.fixture(scope="module")
def model():
    return load_model("factorised")


@pytest.fixture()
def tea(model, scenario):
    return load_task("make_tea", model, scenario)


def _write(tmp_path: Path, actions: list, **extra) -> Path:
    path = tmp_path / "task.json"
    path.write_text(json.dumps({"name": "t", "actions": actions, **extra}))
    return path


def _load_error(tmp_path, model, scenario, actions, **extra) -> InputError:
    path = _write(tmp_path, actions, **extra)
    with pytest.raises(InputError) as info:
        load_task(path, model, scenario)
    assert info.value.file == str(path)
    return info.value


# ------------------------------------------------------------------ the make-tea graph (§7.2)
def test_make_tea_has_exactly_the_18_actions_and_dependencies_of_table_2(tea):
    assert list(tea.ids) == list(TABLE_2)  # same ids, same insertion order
    assert len(tea) == 18
    for node, (kind, deps) in TABLE_2.items():
        assert tea.action(node).verb == kind, node
        assert set(tea.dependencies(node)) == deps, node
    assert tea.nx_graph.number_of_edges() == sum(len(d) for _, d in TABLE_2.values())  # 19


def test_make_tea_actions_carry_the_model_transitions_and_table_6_thresholds(tea, scenario):
    boil = tea.action("boil_kettle")
    assert (boil.verb, boil.requires_affordance, boil.transition) == ("USE", "heatable", "boil")
    assert [(c.state, c.at_least) for c in boil.preconditions] == [("kettle.contains_water", 0.85)]
    fill = tea.action("fill_kettle")
    assert [(c.state, c.at_least) for c in fill.goals] == [("kettle.contains_water", 0.90)]
    assert fill.effects[0].state == "kettle.contains_water" and fill.effects[0].success == 0.995
    pour = tea.action("pour_hot_water")
    assert (pour.object, pour.destination) == ("kettle", "mug")
    assert {(c.state, c.at_least) for c in pour.preconditions} == {
        ("kettle.contains_water", 0.85), ("kettle.water_hot", 0.90)}
    assert {e.state for e in pour.effects} == {"mug.contains_water", "mug.water_hot",
                                               "kettle.contains_water", "kettle.water_hot"}
    serve = tea.action("serve_tea")
    assert (serve.verb, serve.object, serve.transition) == ("USE", "mug", "serve")
    assert [(c.state, c.at_least) for c in serve.preconditions] == [("mug.tea_brewed", 0.90)]
    inspect = tea.action("inspect_kettle_water")
    assert inspect.state == "kettle.contains_water"
    assert (inspect.sensor.sensitivity, inspect.sensor.specificity) == (0.95, 0.95)
    for node in ("carry_mug", "place_mug", "carry_teabag", "carry_kettle", "place_kettle"):
        assert tea.action(node).site == scenario.preparation_site == "dining_table"


def test_preparation_site_is_a_parameter(model, scenario):
    graph = load_task("make_tea", model, scenario, preparation_site="coffee_table")
    assert graph.action("place_kettle").site == "coffee_table"
    assert graph.action("place_mug").site == "coffee_table"


def test_heat_water_reuses_the_verbs_and_transitions(model, scenario, tea):
    heat = load_task("heat_water", model, scenario)
    assert heat.name == "heat_water" and "teabag" not in {a.object for a in heat.actions()}
    assert {a.verb for a in heat.actions()} <= {a.verb for a in tea.actions()}
    assert {a.transition for a in heat.actions()} - {None} == {"fill", "boil", "pour"}


# ------------------------------------------------------------------ readiness [18]
def test_ready_keeps_insertion_order_and_treats_skipped_as_finished(tea):
    assert tea.ready() == ["search_mug", "search_teabag", "search_kettle"]
    tea.set_status("search_kettle", "complete")
    tea.set_status("search_mug", "complete")
    # Three ready actions, listed by insertion order, not by completion order.
    assert tea.ready() == ["pick_mug", "search_teabag", "inspect_kettle_water"]
    tea.set_status("inspect_kettle_water", "complete")
    tea.set_status("fill_kettle", "skipped")
    assert "boil_kettle" in tea.ready()
    tea.set_status("pick_mug", "active")
    assert "pick_mug" not in tea.ready() and "pick_mug" in tea.frontier()
    assert tea.status_counts() == {"pending": 13, "active": 1, "complete": 3, "skipped": 1,
                                   "failed": 0}
    assert tea.to_json()["fill_kettle"] == "skipped" and list(tea.to_json()) == list(TABLE_2)


def test_ready_requires_every_dependency(tea):
    for node in ("search_mug", "pick_mug", "carry_mug", "place_mug"):
        tea.set_status(node, "complete")
    assert "pick_teabag" not in tea.ready()  # search_teabag is still pending
    tea.set_status("search_teabag", "complete")
    assert "pick_teabag" in tea.ready()


# ------------------------------------------------------------------ relevance [14, 15]
def test_relevance_of_make_tea_by_hand(tea):
    # search_mug: 12 descendants (pick, carry, place mug; pick, carry, insert teabag; pick, carry
    # kettle; pour; place kettle; steep; serve) -> 13. search_teabag: 9 -> 10. search_kettle: 9
    # (inspect, fill, boil, pick, carry, pour, place, steep, serve) -> 10. Max 13.
    assert tea.relevance() == pytest.approx({"mug": 1.0, "teabag": 10 / 13, "kettle": 10 / 13})
    for node in ("search_mug", "pick_mug", "carry_mug", "place_mug"):
        tea.set_status(node, "complete")
    # mug's search is finished and drops out; teabag 1 + 9 = 10, kettle 1 + 9 = 10.
    assert tea.relevance() == pytest.approx({"teabag": 1.0, "kettle": 1.0})
    tea.set_status("search_kettle", "complete")
    tea.set_status("inspect_kettle_water", "complete")
    tea.set_status("fill_kettle", "skipped")
    assert tea.relevance() == {"teabag": 1.0}


def test_relevance_small_graph_by_hand():
    a = [TaskAction("search_a", "SEARCH", "a"), TaskAction("search_b", "SEARCH", "b"),
         TaskAction("x", "WAIT", "a"), TaskAction("y", "WAIT", "b")]
    graph = TaskGraph(a, {"x": ["search_a"], "y": ["x", "search_b"]})
    # a: 1 + |{x, y}| = 3; b: 1 + |{y}| = 2; r = (3/3, 2/3).
    assert graph.relevance() == pytest.approx({"a": 1.0, "b": 2 / 3})
    graph.set_status("x", "complete")
    # a: 1 + |{y}| = 2; b: 2; r = (1, 1).
    assert graph.relevance() == pytest.approx({"a": 1.0, "b": 1.0})


# ------------------------------------------------------------------ validation
def test_cycle_is_printed_with_node_names(tmp_path, model, scenario):
    err = _load_error(tmp_path, model, scenario, [
        {"id": "a", "verb": "SEARCH", "object": "mug", "depends_on": ["b"]},
        {"id": "b", "verb": "PICK", "object": "mug", "depends_on": ["a"]},
    ])
    assert "cycle: a -> b -> a" in err.fault
    assert err.path == "$.actions[0].depends_on"


def test_longer_cycle_is_printed_from_the_earliest_action(tmp_path, model, scenario):
    err = _load_error(tmp_path, model, scenario, [
        {"id": "start", "verb": "SEARCH", "object": "mug"},
        {"id": "p", "verb": "PICK", "object": "mug", "depends_on": ["start", "r"]},
        {"id": "q", "verb": "NAVIGATE", "object": "mug", "site": "sideboard", "depends_on": ["p"]},
        {"id": "r", "verb": "PLACE", "object": "mug", "site": "sideboard", "depends_on": ["q"]},
    ])
    assert "cycle: p -> r -> q -> p" in err.fault


def test_dangling_dependency_names_both_actions(tmp_path, model, scenario):
    err = _load_error(tmp_path, model, scenario, [
        {"id": "search_mug", "verb": "SEARCH", "object": "mug"},
        {"id": "pick_mug", "verb": "PICK", "object": "mug", "depends_on": ["search_mug", "x"]},
    ])
    assert err.path == "$.actions[1].depends_on[1]"
    assert "'pick_mug' depends on 'x', which is not defined" in err.fault


def test_graph_constructor_validates_too():
    with pytest.raises(InputError, match="depends on 'nope', which is not defined"):
        TaskGraph([TaskAction("a", "WAIT", "mug")], {"a": ["nope"]})
    with pytest.raises(InputError, match=r"cycle: a -> a"):
        TaskGraph([TaskAction("a", "WAIT", "mug")], {"a": ["a"]})


@pytest.mark.parametrize("action, path, fault", [
    ({"id": "a", "verb": "BREW", "object": "mug"}, "$.actions[0].verb", "unknown verb 'BREW'"),
    ({"id": "a", "verb": "PICK", "object": "spoon"}, "$.actions[0].object", "'spoon' is not an object"),
    ({"id": "a", "verb": "NAVIGATE", "object": "mug", "site": "garage"}, "$.actions[0].site",
     "site 'garage' is not a site"),
    ({"id": "a", "verb": "NAVIGATE", "object": "mug"}, "$.actions[0].site", "needs a target site"),
    ({"id": "a", "verb": "NAVIGATE", "object": "mug", "site": "$kitchen"}, "$.actions[0].site",
     "unknown variable '$kitchen'"),
    ({"id": "a", "verb": "FILL", "object": "kettle", "transition": "freeze"},
     "$.actions[0].transition", "declares no transition 'freeze'"),
    ({"id": "a", "verb": "INSPECT", "object": "mug", "state": "open"}, "$.actions[0].state",
     "'mug.open' is declared neither"),
    ({"id": "a", "verb": "INSPECT", "object": "mug", "state": "contains_water", "sensor": "sonar"},
     "$.actions[0].sensor", "no sensor 'sonar'"),
    ({"id": "a", "verb": "FILL", "object": "teabag", "transition": "fill"},
     "$.actions[0].transition", "'teabag.contains_water' is declared neither"),
    ({"id": "a", "verb": "WAIT", "object": "teabag", "transition": "steep"},
     "$.actions[0].transition", "refers to {destination}"),
    ({"id": "a", "verb": "POUR", "object": "kettle", "transition": "pour"},
     "$.actions[0].destination", "POUR needs a destination"),
    ({"id": "a", "verb": "PICK", "object": "mug", "requires_affordance": "graspable"},
     "$.actions[0].requires_affordance", "requires_affordance is for USE and WAIT"),
    ({"id": "a", "verb": "PICK", "object": "mug", "colour": "red"}, "$.actions[0].colour",
     "unknown field"),
    ({"id": "a", "verb": "FILL", "object": "kettle", "transition": "fill",
      "recovery": {"max_retries": 1, "reinspect": ["{object}.water_level"]}},
     "$.actions[0].recovery.reinspect[0]", "'kettle.water_level' is declared neither"),
    ({"id": "a", "verb": "FILL", "object": "kettle", "recovery": {"max_retries": -1}},
     "$.actions[0].recovery.max_retries", "non-negative"),
    ({"id": "a", "verb": "USE", "object": "kettle",
      "goals": [{"state": "{object}.water_hot", "at_least": 1.5}]},
     "$.actions[0].goals[0].at_least", "outside [0, 1]"),
])
def test_task_file_faults_name_file_and_json_path(tmp_path, model, scenario, action, path, fault):
    err = _load_error(tmp_path, model, scenario, [action])
    assert err.path == path
    assert fault in err.fault


def test_duplicate_ids_and_empty_tasks_are_faults(tmp_path, model, scenario):
    err = _load_error(tmp_path, model, scenario, [{"id": "a", "verb": "SEARCH", "object": "mug"},
                                                  {"id": "a", "verb": "SEARCH", "object": "kettle"}])
    assert (err.path, err.fault) == ("$.actions[1].id", "duplicate action id 'a'")
    err = _load_error(tmp_path, model, scenario, [])
    assert err.path == "$.actions"


def test_bad_preparation_site_argument_is_a_fault(model, scenario):
    with pytest.raises(InputError) as info:
        load_task("make_tea", model, scenario, preparation_site="garage")
    assert info.value.path == "$.actions[2].site"  # carry_mug, the first use
    assert "'garage'" in info.value.fault


def test_declares_states_lets_objects_gain_states(tmp_path, model, scenario):
    actions = [{"id": "look", "verb": "INSPECT", "object": "mug", "state": "open"}]
    graph = load_task(_write(tmp_path, actions, declares_states={"mug": {"open": 0.3}}),
                      model, scenario)
    assert graph.declared_states == {"mug.open": 0.3}
    assert graph.action("look").state == "mug.open"
    err = _load_error(tmp_path, model, scenario, actions, declares_states={"spoon": {"open": 0.3}})
    assert err.path == "$.declares_states.spoon"
    err = _load_error(tmp_path, model, scenario, actions,
                      declares_states={"mug": {"contains_water": 0.3}})
    assert "already declared by the scenario" in err.fault


def test_unreadable_files(tmp_path, model, scenario):
    with pytest.raises(InputError, match="file not found"):
        load_task(tmp_path / "missing.json", model, scenario)
    bad = tmp_path / "bad.json"
    bad.write_text("{\"name\": ")
    with pytest.raises(InputError, match="invalid JSON") as info:
        load_task(bad, model, scenario)
    assert info.value.file == str(bad)


def test_every_bundled_task_loads_under_every_bundled_model(scenario):
    tasks = sorted((ROOT / "scenarios" / "tasks").glob("*.json"))
    assert {p.stem for p in tasks} >= {"make_tea", "heat_water", "make_tea_milk_sugar"}
    models = sorted((ROOT / "models").glob("*.toml")) + sorted((ROOT / "models" / "ablations").glob("*.toml"))
    five = load_scenario("milk_sugar_apartment")  # holds every object a bundled task names but the box's
    box = load_scenario("tea_box_apartment")       # a teabag box and a tea tin instead of a teabag
    needs_milk_and_sugar = {"make_tea_milk_sugar"}
    needs_the_box = {"make_tea_from_box"}
    for model_path in models:
        for task in tasks:
            assert len(load_task(task, load_model(model_path), box if task.stem in needs_the_box else five)) > 0
            if task.stem not in needs_milk_and_sugar | needs_the_box:
                assert len(load_task(task, load_model(model_path), scenario)) > 0


def test_task_layer_never_imports_a_simulator():
    code = ("import sys, fg_tea.tasks, fg_tea.tasks.executor, fg_tea.tasks.load; "
            "bad = [m for m in sys.modules if m.split('.')[0] in ('pybullet', 'pybullet_data') "
            "or m.startswith('fg_tea.env.') and m != 'fg_tea.env.base']; print(bad); "
            "sys.exit(1 if bad else 0)")
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                            env={"PYTHONPATH": str(ROOT), "PATH": ""})
    assert result.returncode == 0, result.stdout + result.stderr
    for path in (ROOT / "fg_tea" / "tasks").glob("*.py"):
        assert "pybullet" not in path.read_text(), path
