"""The task executor with a scripted observation source (no simulator).

The fake world answers state readings from a truth dict, confirms searches at the objects' true
sites and applies deterministic truth effects; the executor sees only readings and outcomes.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.world.interface import ActionRequest, ActionResult
from fg_tea.model.spec import load_model
from fg_tea.world.scenario import load_scenario
from fg_tea.tasks import AffordanceError, PreconditionError, TaskError, TaskExecutor, load_task

ROOT = Path(__file__).resolve().parent.parent
PREP = "dining_table"

# Hand-computed beliefs (sensor alpha = beta = 0.95, prior q(kettle.contains_water) = 0.35).
Q_WATER_AFTER_TRUE = 0.95 * 0.35 / (0.95 * 0.35 + 0.05 * 0.65)   # eq. 23: 0.91096
Q_WATER_AFTER_FALSE = 0.05 * 0.35 / (0.05 * 0.35 + 0.95 * 0.65)  # eq. 24: 0.02756


class ScriptedWorld:
    """Truth as a dict; perfect readings; effects applied when their `requires` hold."""

    def __init__(self, scenario, fail_plan=None, readings=None):
        self.scenario = scenario
        self.truth = {f"{o.name}.{k}": v for o in scenario.objects
                      for k, v in o.hidden_state_truth.items()}
        self.fail_plan = {k: list(v) for k, v in (fail_plan or {}).items()}
        self.readings = dict(readings or {})  # state -> forced reading
        self.requests: list[ActionRequest] = []

    def read(self, state):
        return self.readings.get(state, self.truth.get(state, False))

    def execute(self, executor, action):
        self.requests.append(executor.request(action))
        plan = self.fail_plan.get(action.id)
        if plan:
            return ActionResult(False, plan.pop(0))
        for e in action.effects:  # the truth side of the same transition, deterministic
            if all(self.truth.get(r, False) for r in e.requires):
                self.truth[e.state] = e.value
        return ActionResult(True)


def run(executor, world, max_steps=200):
    """A minimal runner: search, inspect, verify, execute, complete or recover."""
    for _ in range(max_steps):
        action = executor.next_action()
        if action is None:
            return
        if action.verb == "SEARCH":
            executor.confirm_search(action.object, world.scenario.object(action.object).true_site)
            continue
        if action.verb == "INSPECT":
            executor.observe(action, world.read(action.state))
            continue
        while states := executor.verification_inspections(action):  # bounded by the executor
            for state in states:
                executor.observe_state(state, world.read(state))
        result = world.execute(executor, action)
        if result.ok:
            executor.complete(action, result)
        else:
            decision = executor.fail(action, result.reason)
            for state in decision.inspections:
                executor.observe_state(state, world.read(state), purpose="recovery")
    raise AssertionError("runner did not terminate")


def make(scenario_name="default_apartment", model_name="factorised", task="make_tea", scenario=None):
    scenario = scenario or load_scenario(scenario_name)
    model = load_model(ROOT / "models" / f"{model_name}.toml")
    belief = BeliefEngine(scenario, model)
    graph = load_task(task, model, scenario) if isinstance(task, (str, Path)) else task(model, scenario)
    return TaskExecutor(graph, belief, scenario, model), scenario


def events(executor, kind):
    return [e for e in executor.events if e["event"] == kind]


def assert_tea_made(ex):
    objects = ex.object_state()
    assert ex.done and ex.stuck_reason is None
    assert objects["teabag"]["contained_in"] == "mug"
    assert objects["teabag"]["current_site"] == objects["mug"]["current_site"] == PREP
    assert objects["kettle"]["current_site"] == PREP
    assert not any(o["held"] for o in objects.values())
    assert ex.belief.state("mug.tea_brewed") >= 0.90
    assert ex.belief.state("mug.served") >= 0.90
    assert ex.graph.status("serve_tea") == "complete"


# ------------------------------------------------------------------ the two kettle worlds
def test_empty_kettle_world_fills_the_kettle():
    ex, scenario = make("default_apartment")
    run(ex, ScriptedWorld(scenario))
    inspect = events(ex, "inspect")[0]
    assert inspect["value"] is False
    assert inspect["after"] == pytest.approx(Q_WATER_AFTER_FALSE, abs=1e-12)
    assert ex.graph.status("fill_kettle") == "complete"
    assert events(ex, "skip") == []
    assert events(ex, "observe_state") == []  # no verification needed in this world
    assert all(s == "complete" for s in ex.graph.to_json().values())
    assert_tea_made(ex)


def test_filled_kettle_world_skips_fill_and_verifies_before_serving():
    ex, scenario = make("filled_kettle")
    run(ex, ScriptedWorld(scenario))
    inspect = events(ex, "inspect")[0]
    assert inspect["value"] is True
    assert inspect["after"] == pytest.approx(Q_WATER_AFTER_TRUE, abs=1e-12)
    assert inspect["after"] > 0.90
    skips = events(ex, "skip")
    assert [s["action"] for s in skips] == ["fill_kettle"]
    assert skips[0]["goals"] == [{"state": "kettle.contains_water",
                                  "belief": pytest.approx(Q_WATER_AFTER_TRUE, abs=1e-12),
                                  "threshold": 0.90}]
    assert ex.graph.status("fill_kettle") == "skipped"
    assert ex.graph.status("boil_kettle") == "complete"
    # Full transitions leave the brew just short of the serve precondition; one verification
    # reading of the brewed tea lifts it.
    checks = events(ex, "observe_state")
    assert [(c["state"], c["value"]) for c in checks] == [("mug.tea_brewed", True)]
    assert checks[0]["before"] < 0.90 <= checks[0]["after"]
    assert [e["action"] for e in events(ex, "complete")][-1] == "serve_tea"
    assert_tea_made(ex)


def test_filled_world_sends_no_fill_request_and_empty_world_does():
    for name, fills in (("filled_kettle", 0), ("default_apartment", 1)):
        ex, scenario = make(name)
        world = ScriptedWorld(scenario)
        run(ex, world)
        assert [r.verb for r in world.requests].count("FILL") == fills


def test_practical_requests_name_the_believed_sites():
    ex, scenario = make("default_apartment")
    world = ScriptedWorld(scenario)
    run(ex, world)
    by_verb = {(r.verb, r.object): r for r in world.requests}
    assert by_verb[("PICK", "mug")] == ActionRequest("PICK", "mug", "sideboard", None, None)
    assert by_verb[("FILL", "kettle")] == ActionRequest("FILL", "kettle", "kitchen_counter", None, "fill")
    assert by_verb[("POUR", "kettle")] == ActionRequest("POUR", "kettle", PREP, "mug", "pour")
    assert by_verb[("INSERT", "teabag")].site == PREP
    assert by_verb[("WAIT", "teabag")] == ActionRequest("WAIT", "teabag", None, "mug", "steep")


def test_joint_model_runs_the_same_task():
    ex, scenario = make("filled_kettle", model_name="joint")
    run(ex, ScriptedWorld(scenario))
    assert ex.graph.status("fill_kettle") == "skipped"
    assert_tea_made(ex)


def test_heat_water_runs_end_to_end_with_the_same_executor():
    ex, scenario = make("default_apartment", task="heat_water")
    run(ex, ScriptedWorld(scenario))
    assert ex.done and ex.stuck_reason is None
    objects = ex.object_state()
    assert objects["mug"]["current_site"] == objects["kettle"]["current_site"] == PREP
    assert objects["teabag"]["current_site"] is None  # never searched: nothing needed it
    assert ex.graph.status("fill_kettle") == "complete"
    assert events(ex, "inspect")[-1]["state"] == "mug.water_hot"
    assert ex.belief.state("mug.water_hot") >= 0.99
    assert ex.belief.state("mug.tea_brewed") == pytest.approx(0.01)  # untouched


# ------------------------------------------------------------------ next_action and searches
def test_next_action_order_and_searches_confirmed_by_any_inspection():
    ex, _ = make()
    first = ex.next_action()
    assert first.id == "search_mug" and ex.graph.status("search_mug") == "active"
    assert ex.pending_search_objects() == ["mug", "teabag", "kettle"]
    assert ex.search_relevance() == pytest.approx({"mug": 1.0, "teabag": 10 / 13, "kettle": 10 / 13})
    # The planner serving search_mug finds the kettle first.
    ev = ex.confirm_search("kettle", "kitchen_counter")
    assert ev["completed"] == ["search_kettle"]
    assert ex.object_state()["kettle"]["resolved_site"] == "kitchen_counter"
    assert ex.graph.status("search_mug") == "active"
    assert ex.next_action().id == "search_mug"  # still the frontier action, until the mug is found
    assert ex.pending_search_objects() == ["mug", "teabag"]
    ex.confirm_search("mug", "sideboard")
    assert ex.next_action().id == "pick_mug"


def test_complete_refuses_wrong_calls():
    ex, _ = make()
    tea = ex.graph
    with pytest.raises(TaskError, match="not ready, waiting on search_mug"):
        ex.complete(tea.action("pick_mug"))
    with pytest.raises(TaskError, match="confirm_search"):
        ex.complete(tea.action("search_mug"))
    ex.confirm_search("kettle", "kitchen_counter")
    with pytest.raises(TaskError, match="through observe"):
        ex.complete(tea.action("inspect_kettle_water"))
    ex.confirm_search("mug", "sideboard")
    with pytest.raises(TaskError, match="call fail"):
        ex.complete(tea.action("pick_mug"), ActionResult(False, "hands_full"))


# ------------------------------------------------------------------ explicit errors
def _tiny(tmp_path, actions):
    path = tmp_path / "tiny.json"
    path.write_text(json.dumps({"name": "tiny", "actions": actions}))
    return lambda model, scenario: load_task(path, model, scenario)


def _frozen_state(ex):
    return (json.dumps(ex.belief.snapshot(), sort_keys=True), json.dumps(ex.graph_state()),
            json.dumps(ex.object_state()), len(ex.events))


def _advance_to(ex, world, target):
    """Run the tiny task until `target` is the next action; return it."""
    while True:
        action = ex.next_action()
        if action.id == target:
            return action
        if action.verb == "SEARCH":
            ex.confirm_search(action.object, world.scenario.object(action.object).true_site)
        else:
            ex.complete(action, world.execute(ex, action))


def test_boiling_without_enough_water_belief_raises_and_changes_nothing(tmp_path):
    ex, scenario = make(task=_tiny(tmp_path, [
        {"id": "search_kettle", "verb": "SEARCH", "object": "kettle"},
        {"id": "boil_kettle", "verb": "USE", "object": "kettle", "transition": "boil",
         "requires_affordance": "heatable", "depends_on": ["search_kettle"]}]))
    boil = _advance_to(ex, ScriptedWorld(scenario), "boil_kettle")
    before = _frozen_state(ex)
    assert ex.belief.state("kettle.contains_water") == pytest.approx(0.35)
    with pytest.raises(PreconditionError) as info:
        ex.complete(boil, ActionResult(True))
    message = str(info.value)
    assert "boil_kettle" in message and "kettle.contains_water" in message
    assert "0.3500" in message and "0.85" in message
    v = info.value.violations[0]
    assert (v.state, v.belief, v.threshold) == ("kettle.contains_water", pytest.approx(0.35), 0.85)
    assert _frozen_state(ex) == before


def test_pouring_from_a_non_pourable_object_raises_and_changes_nothing(tmp_path):
    ex, scenario = make(task=_tiny(tmp_path, [
        {"id": "search_mug", "verb": "SEARCH", "object": "mug"},
        {"id": "search_kettle", "verb": "SEARCH", "object": "kettle"},
        {"id": "pick_mug", "verb": "PICK", "object": "mug", "depends_on": ["search_mug"]},
        {"id": "pour_mug", "verb": "POUR", "object": "mug", "destination": "kettle",
         "depends_on": ["pick_mug", "search_kettle"]}]))
    pour = _advance_to(ex, ScriptedWorld(scenario), "pour_mug")
    assert ex.object_state()["mug"]["held"]
    before = _frozen_state(ex)
    with pytest.raises(AffordanceError) as info:
        ex.complete(pour, ActionResult(True))
    assert "pour_mug" in str(info.value) and "'pourable'" in str(info.value)
    assert info.value.violations[0].affordance == "pourable"
    assert _frozen_state(ex) == before


def test_inserting_into_a_non_container_raises_and_changes_nothing(tmp_path):
    ex, scenario = make(task=_tiny(tmp_path, [
        {"id": "search_teabag", "verb": "SEARCH", "object": "teabag"},
        {"id": "search_kettle", "verb": "SEARCH", "object": "kettle"},
        {"id": "pick_teabag", "verb": "PICK", "object": "teabag", "depends_on": ["search_teabag"]},
        {"id": "insert_teabag", "verb": "INSERT", "object": "teabag", "destination": "kettle",
         "depends_on": ["pick_teabag", "search_kettle"]}]))
    insert = _advance_to(ex, ScriptedWorld(scenario), "insert_teabag")
    before = _frozen_state(ex)
    with pytest.raises(AffordanceError) as info:
        ex.complete(insert, ActionResult(True))
    assert "insert_teabag" in str(info.value) and "'container'" in str(info.value)
    assert [v.kind for v in info.value.violations] == ["affordance"]  # the teabag is held
    assert _frozen_state(ex) == before


def test_picking_a_non_graspable_object_raises_and_changes_nothing(tmp_path):
    base = load_scenario("default_apartment")
    objects = tuple(dataclasses.replace(o, affordances=frozenset({"steepable"}))
                    if o.name == "teabag" else o for o in base.objects)
    scenario = dataclasses.replace(base, objects=objects)
    ex, _ = make(scenario=scenario, task=_tiny(tmp_path, [
        {"id": "search_teabag", "verb": "SEARCH", "object": "teabag"},
        {"id": "pick_teabag", "verb": "PICK", "object": "teabag", "depends_on": ["search_teabag"]}]))
    pick = _advance_to(ex, ScriptedWorld(scenario), "pick_teabag")
    before = _frozen_state(ex)
    with pytest.raises(AffordanceError, match="pick_teabag: PICK needs object 'teabag' to be "
                                              "'graspable'; it affords steepable"):
        ex.complete(pick, ActionResult(True))
    assert _frozen_state(ex) == before
    assert ex.check(pick)[0].affordance == "graspable"


# ------------------------------------------------------------------ recovery (docs/design.md §7.6)
def test_failed_fill_reinspects_and_retries_then_completes():
    ex, scenario = make("default_apartment")
    run(ex, ScriptedWorld(scenario, fail_plan={"fill_kettle": ["object_out_of_reach"]}))
    fails = events(ex, "fail")
    assert len(fails) == 1
    assert (fails[0]["action"], fails[0]["reason"], fails[0]["retry"]) == \
        ("fill_kettle", "object_out_of_reach", True)
    assert fails[0]["inspections"] == ["kettle.contains_water"]
    kinds = [(e["event"], e.get("action") or e.get("state")) for e in ex.events]
    i = kinds.index(("fail", "fill_kettle"))
    # Re-inspection of the water, then the retry, then completion.
    assert kinds[i + 1] == ("observe_state", "kettle.contains_water")
    assert kinds[i + 2:i + 4] == [("activate", "fill_kettle"), ("complete", "fill_kettle")]
    assert ex.attempts["fill_kettle"] == 1
    assert_tea_made(ex)


def test_exhausted_retry_budget_ends_with_the_reason():
    ex, scenario = make("default_apartment")
    run(ex, ScriptedWorld(scenario, fail_plan={"fill_kettle": ["object_out_of_reach"] * 5}))
    assert not ex.done
    assert ex.stuck_reason == "fill_kettle failed 3 times: object_out_of_reach"  # 1 + max_retries 2
    assert ex.graph.status("fill_kettle") == "failed"
    assert ex.next_action() is None
    assert events(ex, "stuck")[-1]["reason"] == ex.stuck_reason
    assert ex.graph.status("serve_tea") == "pending"
    assert ex.graph_state()["stuck_reason"] == ex.stuck_reason


def test_transient_failures_retry_on_the_same_evidence_up_to_the_models_budget():
    # injected_failure says nothing happened: no re-inspection, and retries beyond the task's
    # max_retries (2) up to k = ceil(log(tolerance / M) / log(failure_rate)) tries.
    ex, scenario = make("default_apartment")
    k = ex.transient_tries()
    m = ex.practical_runs()
    assert m == 14 * 3  # 14 practical make-tea actions, each run at most 1 + 2 reopenings times
    f, eps = ex.model.retries.failure_rate, ex.model.retries.tolerance
    assert m * f ** k <= eps < m * f ** (k - 1)
    run(ex, ScriptedWorld(scenario, fail_plan={"fill_kettle": ["injected_failure"] * (k - 1)}),
        max_steps=400)
    fails = events(ex, "fail")
    assert len(fails) == k - 1 > 3
    assert all(e["retry"] and e["inspections"] == [] for e in fails)
    assert not any(e["event"] == "observe_state" for e in ex.events)
    assert_tea_made(ex)


def test_transient_failure_budget_spent_ends_with_the_bound():
    ex, scenario = make("default_apartment")
    k = ex.transient_tries()
    run(ex, ScriptedWorld(scenario, fail_plan={"fill_kettle": ["injected_failure"] * (k + 3)}),
        max_steps=400)
    assert not ex.done
    assert ex.stuck_reason.startswith(f"fill_kettle failed {k} times: injected_failure (a doable "
                                      f"action fails {k} tries with probability <= 0.5^{k}")
    assert len(events(ex, "fail")) == k


def test_transient_budget_follows_the_declared_failure_model(tmp_path):
    from fg_tea.model.spec import RetryModel
    assert RetryModel(0.2, 1e-3).tries(42) == 7      # 42 x 0.2^7 = 5.4e-4 <= 1e-3 < 42 x 0.2^6
    assert RetryModel(0.5, 1e-3).tries(42) == 16
    assert RetryModel(0.0, 1e-3).tries(42) == 1
    path = tmp_path / "m.toml"
    path.write_text('extends = "factorised"\nname = "m"\n[recovery]\nfailure_rate = 0.2\n')
    from fg_tea.model.spec import load_model
    assert load_model(path).retries == RetryModel(0.2, 1e-3)
    path.write_text('extends = "factorised"\nname = "m"\n[recovery]\nfailure_rate = 1.0\n')
    from fg_tea.common.errors import InputError
    with pytest.raises(InputError, match="failure_rate"):
        load_model(path)


def test_unreachable_site_is_excluded_from_search():
    ex, _ = make()
    search = ex.next_action()
    decision = ex.fail(search, "unreachable", site="study_shelf")
    assert decision.retry and decision.exclude_site == "study_shelf"
    assert ex.excluded_sites == ["study_shelf"]
    assert ex.next_action().id == "search_mug"


def test_object_not_at_site_is_negative_evidence_and_reopens_the_search():
    ex, _ = make()
    ex.next_action()
    ex.confirm_search("mug", "sideboard")
    pick = ex.next_action()
    j = ex.belief.sites.index("sideboard")
    q_before = ex.belief.location("mug")[j]
    decision = ex.fail(pick, "object_not_at_site")
    assert decision.reopened_search == "mug" and decision.retry
    # Eq. 6: q'(j) = mu q(j) / (1 - (1 - mu) q(j)).
    mu = ex.model.miss_likelihood
    assert ex.belief.location("mug")[j] == pytest.approx(mu * q_before / (1 - (1 - mu) * q_before))
    assert ex.graph.status("search_mug") == "pending" and ex.graph.status("pick_mug") == "pending"
    assert ex.object_state()["mug"]["resolved_site"] is None
    assert ex.next_action().id == "search_mug"  # pick_mug waits for the search again


def test_verification_is_bounded_then_the_precondition_error_is_explicit():
    ex, scenario = make("filled_kettle")
    world = ScriptedWorld(scenario, readings={"mug.tea_brewed": False})
    with pytest.raises(PreconditionError, match=r"serve_tea: precondition q\(mug.tea_brewed = "
                                                r"true\) >= 0.9 fails"):
        run(ex, world)
    offered = [e for e in events(ex, "observe_state") if e["state"] == "mug.tea_brewed"]
    assert len(offered) == ex.max_verifications == 3
    assert ex.verification_inspections(ex.graph.action("serve_tea")) == []
    assert ex.graph.status("serve_tea") == "active"


# ------------------------------------------------------------------ belief effects [25-27]
def test_full_transition_matches_eq_27_by_hand():
    ex, scenario = make("default_apartment")
    run(ex, ScriptedWorld(scenario))
    fill = next(e for e in events(ex, "complete") if e["action"] == "fill_kettle")
    q = Q_WATER_AFTER_FALSE
    # q' = q + (1 - q) rho: already full stays full, empty becomes full with rho = 0.995.
    assert fill["belief_after"]["kettle.contains_water"] == pytest.approx(q + (1 - q) * 0.995,
                                                                         abs=1e-12)
    assert fill["transition"]["form"] == "full"


def test_direct_transition_form_sets_rho_exactly():
    ex, scenario = make("default_apartment", model_name="ablations/direct_effects")
    run(ex, ScriptedWorld(scenario))
    after = {e["action"]: e["belief_after"] for e in events(ex, "complete")}
    assert after["fill_kettle"]["kettle.contains_water"] == pytest.approx(0.995, abs=1e-12)
    assert after["boil_kettle"]["kettle.water_hot"] == pytest.approx(0.995, abs=1e-12)
    pour = after["pour_hot_water"]
    assert pour["mug.contains_water"] == pytest.approx(0.99, abs=1e-12)
    assert pour["mug.water_hot"] == pytest.approx(0.97, abs=1e-12)
    assert pour["kettle.contains_water"] == pytest.approx(1 - 0.99, abs=1e-12)  # eq. 26
    assert after["steep_tea"]["mug.tea_brewed"] == pytest.approx(0.98, abs=1e-12)
    assert after["serve_tea"]["mug.served"] == pytest.approx(0.995, abs=1e-12)
    assert events(ex, "complete")[-1]["transition"]["form"] == "direct"
    assert_tea_made(ex)


def test_complete_event_records_before_and_after():
    ex, scenario = make("default_apartment")
    run(ex, ScriptedWorld(scenario))
    insert = next(e for e in events(ex, "complete") if e["action"] == "insert_teabag")
    assert insert["objects_before"]["teabag"]["held"] is True
    assert insert["objects_after"]["teabag"] == {
        "held": False, "current_site": PREP, "contained_in": "mug", "resolved_site": "pantry_shelf",
        "affordances": ["graspable", "steepable"]}
    assert insert["graph_before"]["insert_teabag"] == "active"
    assert insert["graph_after"]["insert_teabag"] == "complete"
    json.dumps(ex.events)  # every event is JSON-serialisable


def test_declared_states_enter_the_belief(tmp_path):
    path = tmp_path / "open.json"
    path.write_text(json.dumps({"name": "open", "declares_states": {"mug": {"open": 0.3}},
                                "actions": [{"id": "look", "verb": "INSPECT", "object": "mug",
                                             "state": "open"}]}))
    ex, _ = make(task=lambda model, scenario: load_task(path, model, scenario))
    assert ex.belief.state("mug.open") == pytest.approx(0.3)
    look = ex.next_action()
    ev = ex.observe(look, True)
    assert ev["after"] == pytest.approx(0.95 * 0.3 / (0.95 * 0.3 + 0.05 * 0.7))
    assert ex.done


def test_inserted_object_shares_and_follows_its_container(tmp_path):
    ex, scenario = make(task=_tiny(tmp_path, [
        {"id": "search_mug", "verb": "SEARCH", "object": "mug"},
        {"id": "search_teabag", "verb": "SEARCH", "object": "teabag"},
        {"id": "pick_teabag", "verb": "PICK", "object": "teabag", "depends_on": ["search_teabag"]},
        {"id": "insert_teabag", "verb": "INSERT", "object": "teabag", "destination": "mug",
         "depends_on": ["pick_teabag", "search_mug"]},
        {"id": "pick_mug", "verb": "PICK", "object": "mug", "depends_on": ["insert_teabag"]},
        {"id": "carry_mug", "verb": "NAVIGATE", "object": "mug", "site": "study_shelf",
         "depends_on": ["pick_mug"]},
        {"id": "place_mug", "verb": "PLACE", "object": "mug", "site": "coffee_table",
         "depends_on": ["carry_mug"]}]))
    world = ScriptedWorld(scenario)
    sites = []
    while (action := ex.next_action()) is not None:
        if action.verb == "SEARCH":
            ex.confirm_search(action.object, scenario.object(action.object).true_site)
        else:
            ex.complete(action, world.execute(ex, action))
        o = ex.object_state()
        sites.append((action.id, o["teabag"]["current_site"], o["mug"]["current_site"],
                      o["teabag"]["held"], o["mug"]["held"]))
    assert sites == [
        ("search_mug", None, "sideboard", False, False),
        ("search_teabag", "pantry_shelf", "sideboard", False, False),
        ("pick_teabag", None, "sideboard", True, False),
        ("insert_teabag", "sideboard", "sideboard", False, False),  # shares the mug's site
        ("pick_mug", None, None, False, True),                      # contents travel along
        ("carry_mug", "study_shelf", "study_shelf", False, True),
        ("place_mug", "coffee_table", "coffee_table", False, False),
    ]
    assert ex.object_state()["teabag"]["contained_in"] == "mug"
