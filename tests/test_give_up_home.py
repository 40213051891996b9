"""One home for the give-up's formula (docs/design.md §7.8, eq. 58): fg_tea/model/give_up.py
writes F_o and its inverse; the executor's bound and the agent's weighing both read it there."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import pytest

from fg_tea.model.give_up import findable, findable_below, remaining_below
from fg_tea.model.spec import load_model

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("p", [1e-3, 0.05, 0.3])
@pytest.mark.parametrize("a", [1e-3, 0.01, 0.2])
def test_the_safety_net_bound_is_eq_58_inverted(p, a):
    bound = findable_below(p, a)
    assert findable(bound, a) == pytest.approx(p, rel=1e-12)
    assert findable(bound * 0.999, a) < p < findable(bound * 1.001, a)


def test_each_rule_reads_its_bound_from_the_one_home():
    planning = load_model("factorised").planning
    cost = replace(planning, give_up="cost")
    assert remaining_below(cost) == findable_below(cost.give_up_probability, cost.absent_probability)
    probability = replace(planning, give_up="probability")
    assert remaining_below(probability) == probability.give_up_probability


def test_the_formula_is_written_once():
    # F_o's numerator R (1 - a), or the inverse's p a / ((1 - p)(1 - a)), written anywhere else.
    pattern = re.compile(r"\*\s*\(1(\.0)?\s*-\s*(a|absent)\)")
    writers = [str(p.relative_to(ROOT)) for p in sorted((ROOT / "fg_tea").rglob("*.py"))
               if pattern.search(p.read_text())]
    assert writers == ["fg_tea/model/give_up.py"]


def test_the_executor_gives_up_at_the_homes_bound():
    import fg_tea as fg

    scenario = fg.load_scenario("default_apartment")
    for rule in ("cost", "probability"):
        model = fg.load_model("factorised_close")
        model = replace(model, planning=replace(model.planning, give_up=rule))
        agent = fg.Agent(scenario, model, planner="efe")
        threshold = agent.executor.search_outlook("mug")["threshold"]
        assert threshold == remaining_below(model.planning)


def test_both_rules_are_decided_by_the_agent_and_the_executor_only_records():
    from fg_tea.agent import give_up
    from fg_tea.tasks.executor import TaskExecutor

    assert not hasattr(TaskExecutor, "_give_up")  # the executor gives a search up when told to
    assert callable(give_up.probability_rule) and callable(give_up.weigh)
    budget_writers = [str(p.relative_to(ROOT)) for p in sorted((ROOT / "fg_tea").rglob("*.py"))
                      if "math.log(mu)" in p.read_text()]
    assert budget_writers == ["fg_tea/model/give_up.py"]


def test_the_executor_alone_never_gives_a_search_up():
    import fg_tea as fg

    scenario = fg.load_scenario("default_apartment")
    model = fg.load_model("factorised_close")
    model = replace(model, planning=replace(model.planning, give_up="probability",
                                            max_inspections_per_object=1))
    agent = fg.Agent(scenario, model, planner="efe", task="find_mug")
    search = agent.next_action()
    decision = agent.decide(search, scenario.start_position)
    agent.observe_look(decision.viewpoint, {"mug": None})  # one miss: the budget of one look spent
    assert agent.executor.next_action().id == search.id  # the executor goes on searching
    assert agent.next_action() is None  # the agent's rule gives it up
    assert agent.end_reason().startswith("not_found: mug") and "budget of 1 looks" in agent.end_reason()
