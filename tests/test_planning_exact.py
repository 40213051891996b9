"""The exact planner and the yardstick that measures planners against the limit
(fg_tea/planning/exact.py, fg_tea/study/yardstick.py, docs/design.md §6.9)."""

from __future__ import annotations

import numpy as np
import pytest

import fg_tea as fg
from fg_tea.planning import ExactPlanner, ExactSettings, check_planner, make_planner
from fg_tea.planning.limit import _useful, solve_tables
from fg_tea.study import yardstick


def test_exact_specs_parse_and_bad_ones_are_refused():
    assert ExactSettings.parse("") == ExactSettings() and ExactSettings.parse("cap=2").cap == 2
    check_planner("exact")
    check_planner("exact:cap=4")
    for bad in ("exact:cap=0", "exact:cap=x", "exact:depth=2", "exact:cap=2,cap=3"):
        with pytest.raises(ValueError):
            check_planner(bad)
    assert isinstance(make_planner("exact:cap=2", fg.load_model("factorised_close")), ExactPlanner)


def test_a_correlated_belief_is_refused_before_the_episode():
    with pytest.raises(fg.PlannerRefused, match="correlated"):
        fg.Agent(fg.load_scenario("default_apartment"), fg.load_model("joint_close"), "exact",
                 task="find_three")


@pytest.mark.slow
def test_the_exact_policy_is_the_limit_and_the_lookahead_is_not():
    """Evaluated exactly (every outcome enumerated, a give-up finished by a sweep), the exact
    planner's policy (the upper cut's at cap 3) costs the limit to 0.05 %; the lookahead's costs
    more than the limit's upper end (the upper cut at cap 4) by 2 %."""
    limit, objects = yardstick.start_limit("independent", "factorised_close", "find_three", tolerance=0.01)
    assert objects == ["mug", "kettle", "teabag"] and limit.width <= 0.01
    exact = yardstick.evaluate_policy("independent", "factorised_close", "exact", "find_three")
    assert exact.unexpanded < 1e-6 and exact.given_up < 0.01
    assert limit.lower <= exact.cost <= limit.lower * 1.0005
    lookahead = yardstick.evaluate_policy("independent", "factorised_close", "lookahead", "find_three")
    assert lookahead.cost > limit.upper * 1.02


def test_the_gap_analysis_accounts_for_a_planner_s_excess():
    """The performance-difference identity: regrets weighted by the chance of each decision sum
    to the planner's excess over the cut policy."""
    gaps = yardstick.gap_analysis("independent", "factorised_close", "efe", "find_mug")
    assert gaps["rows"] and gaps["beyond_cut"] < 1e-3
    excess = gaps["policy"].cost - gaps["cut_policy"]
    assert excess > 0.5 and gaps["excess"] == pytest.approx(excess, rel=0.02)
    worst = gaps["rows"][0]
    assert worst["chosen"] != worst["best"] and worst["weighted"] > 0


def test_a_changed_belief_is_solved_again(monkeypatch):
    """The tables describe the belief they were solved from, updated by misses; evidence they do
    not count (here an excluded site) makes the planner solve again from the belief it sees."""
    scenario, model = fg.load_scenario("default_apartment"), fg.load_model("factorised_close")
    agent = fg.Agent(scenario, model, "exact", task="find_mug")
    planner = agent.planner
    action = agent.next_action()
    d1 = agent.decide(action, scenario.start_position)
    assert planner.solves == 1 and d1.info["exact"].startswith("cap=")
    agent.observe_look(d1.viewpoint, {"mug": None})
    d2 = agent.decide(action, scenario.start_position)
    assert planner.solves == 1  # a miss the tables count: no new solve
    chosen = {c.viewpoint: c.total for c in d2.candidates}
    assert d2.viewpoint == min(chosen, key=chosen.get)
    agent.belief.observe_viewpoint(agent.views.view(d2.viewpoint), {"mug": None})  # not counted
    agent.decide(action, scenario.start_position)
    assert planner.solves == 2


def test_tables_q_values_match_the_root_and_take_any_start():
    rng = np.random.default_rng(3)
    from limit_problems import random_problem

    problem = random_problem(rng, 4, 2, 4)
    views, sites, q0 = _useful(problem)
    tables = solve_tables(problem, views, sites, q0, 2, upper=True)
    q = tables.q_values(None, np.zeros(len(views), dtype=np.int64), 0)
    assert float(q.min()) == pytest.approx(tables.root, abs=1e-12)
    shifted = tables.q_values(None, np.zeros(len(views), dtype=np.int64), 0, travel=tables.start + 1.0)
    assert np.allclose(shifted, q + 1.0)


def test_lookahead_relook_weighs_a_look_from_where_the_agent_stands():
    """With relook=1 the look from the nearest viewpoint (where the agent stands after a miss) is
    among the root's candidates, valued by the tree; without it only the best-scored looks are."""
    from fg_tea.planning import LookaheadSettings

    assert LookaheadSettings.parse("relook=1").relook == 1 and "relook=1" in LookaheadSettings(relook=1).spec()
    with pytest.raises(ValueError):
        LookaheadSettings.parse("relook=2")
    scenario, model = fg.load_scenario("default_apartment"), fg.load_model("factorised_close")
    seen = {}
    for spec in ("lookahead", "lookahead:relook=1"):  # a miss of all three at the pantry shelf
        agent = fg.Agent(scenario, model, spec, task="find_three")
        action = agent.next_action()
        agent.observe_look("pantry_shelf", {"mug": None, "kettle": None, "teabag": None})
        here = scenario.site("pantry_shelf").vantage
        seen[spec] = {c.viewpoint for c in agent.decide(action, here).candidates}
    assert "pantry_shelf" not in seen["lookahead"] and "pantry_shelf" in seen["lookahead:relook=1"]
    assert seen["lookahead"] <= seen["lookahead:relook=1"]
