"""near_exact's tables restricted to the viewpoints that cover most mass, where the tables of every
viewpoint do not fit (``near_exact:restrict=1``; fg_tea/planning/restricted_tables.py,
docs/design.md §6.9)."""

from __future__ import annotations

import numpy as np
import pytest
from limit_problems import make_problem

import fg_tea as fg
from fg_tea.planning import NearExactSettings, check_planner
from fg_tea.planning.limit import _useful, solve_tables
from fg_tea.planning.near_exact import decision_route, restricted_size, table_entries
from fg_tea.planning.restricted_tables import greedy_cover, restricted_problem, solve_restricted


def test_the_cover_keeps_the_viewpoints_of_most_mass_and_the_one_the_agent_stands_at():
    shows = np.eye(5, dtype=bool)
    shows[4, :2] = True                                  # a glance over sites 0 and 1
    mass = np.array([0.3, 0.25, 0.05, 0.2, 0.0])
    assert greedy_cover(shows, mass, 2).tolist() == [3, 4]        # the glance adds 0.55, then site 3
    assert greedy_cover(shows, mass, 2, first=2).tolist() == [2, 4]
    assert greedy_cover(shows, mass, 3).tolist() == [2, 3, 4]     # 0 and 1 add nothing past the glance
    assert greedy_cover(shows, mass, 9).tolist() == [0, 1, 2, 3, 4]


def test_an_object_the_cover_would_leave_out_gets_its_best_viewpoint():
    """Two objects piled on sites 0-2, a third spread thin over sites 3-5: the three sites of most
    summed mass would leave it no mass at all, so the last pick gives way to its best site."""
    shows = np.eye(6, dtype=bool)
    masses = np.array([[0.4, 0.35, 0.25, 0, 0, 0], [0.4, 0.35, 0.25, 0, 0, 0], [0, 0, 0, 0.3, 0.4, 0.3]])
    assert greedy_cover(shows, masses.sum(axis=0), 3).tolist() == [0, 1, 2]   # summed mass alone
    assert greedy_cover(shows, masses, 3).tolist() == [0, 1, 4]
    assert greedy_cover(shows, masses, 3, first=2).tolist() == [0, 2, 4]      # the agent's own stays
    with pytest.raises(ValueError, match="2 viewpoints cannot cover some mass of every object"):
        greedy_cover(shows, np.vstack([masses, [[0, 0, 0.5, 0, 0, 0.5]]]), 2, first=1)


def test_the_restricted_search_is_the_belief_conditioned_on_the_kept_sites():
    prob = np.zeros((4, 2, 4))
    for j in range(4):
        prob[j, :, j] = 0.9
    factors = [[0.4, 0.3, 0.2, 0.1], [0.1, 0.1, 0.5, 0.3]]
    between = np.abs(np.subtract.outer(np.arange(4.0), np.arange(4.0)))
    problem = make_problem(prob, factors, [1.0, 2.0, 3.0, 4.0], between, [0.144] * 4)
    sub = restricted_problem(problem, np.array([0, 2]))
    assert sub.names == ("v0", "v2") and sub.allowed.tolist() == [0, 2]
    assert np.allclose(_useful(sub)[2], [[2 / 3, 1 / 3], [1 / 6, 5 / 6]])
    assert sub.between.tolist() == [[0.0, 2.0], [2.0, 0.0]] and sub.start.tolist() == [1.0, 3.0]
    with pytest.raises(ValueError, match="no mass at the sites of the chosen viewpoints"):
        restricted_problem(make_problem(prob, [[0.5, 0.5, 0, 0], [0.5, 0.5, 0, 0]], [1.0] * 4, between,
                                        [0.144] * 4), np.array([2, 3]))


def test_restricted_tables_choose_as_the_exact_policy_where_the_left_out_mass_is_small():
    """Six close looks in a row, one object; the far end holds 0.2 % of the mass. The tables over
    the five viewpoints of most mass choose the first look, and the next after it missed, as the
    exact tables over all six do (later the two cuts' sweeps part: the whole search's tour goes to
    the far end, the restricted one's does not, and the planner would solve again)."""
    prob = np.zeros((6, 1, 6))
    for j in range(6):
        prob[j, 0, j] = 0.8
    factors = [[0.3, 0.1, 0.25, 0.048, 0.3, 0.002]]
    pos = np.array([0.0, 1.0, 2.5, 3.0, 4.5, 9.0])
    between = np.abs(np.subtract.outer(pos, pos))
    problem = make_problem(prob, factors, np.abs(pos - 2.0), between, [0.144] * 6)
    views, sites, q0 = _useful(problem)
    full = solve_tables(problem, views, sites, q0, 2, upper=True)
    mine = solve_restricted(problem, ["o0"], {}, frozenset(), 5, 2)
    assert mine.kept == ("v0", "v1", "v2", "v3", "v4") and mine.names == list(mine.kept)
    counts_full, counts_mine = np.zeros(6, dtype=np.int64), np.zeros(5, dtype=np.int64)
    here = None
    for _ in range(2):                                     # follow the exact policy's misses
        travel = problem.start if here is None else between[here]
        q_full = full.q_values(None, counts_full, 0, travel=travel)
        q_mine = mine.tables.q_values(None, counts_mine, 0, travel=travel[:5])
        assert int(np.argmin(q_mine)) == int(np.argmin(q_full))
        here = int(np.argmin(q_full))
        counts_full[here] += 1
        counts_mine[here] += 1


class _Marginals:
    """A belief as the shortfall reads it: each object's marginal over the sites."""

    def __init__(self, rows: dict) -> None:
        self.rows = rows

    def marginal(self, o: str) -> np.ndarray:
        return np.asarray(self.rows[o], dtype=float)


def test_the_shortfall_is_the_mass_the_kept_viewpoints_miss_against_the_best_set_now():
    prob = np.zeros((4, 1, 4))
    for j in range(4):
        prob[j, 0, j] = 0.9
    between = np.abs(np.subtract.outer(np.arange(4.0), np.arange(4.0)))
    problem = make_problem(prob, [[0.4, 0.3, 0.2, 0.1]], [1.0, 2.0, 3.0, 4.0], between, [0.144] * 4)
    solved = solve_restricted(problem, ["o0"], {}, frozenset(), 2, 2)
    assert solved.kept == ("v0", "v1")
    assert solved.shortfall(_Marginals({"o0": [0.4, 0.3, 0.2, 0.1]}), ["o0"], None) == 0.0
    # misses at v0 moved mass to v2: the best pair is now v1 and v2, 0.2 more than v0 and v1
    assert solved.shortfall(_Marginals({"o0": [0.2, 0.3, 0.4, 0.1]}), ["o0"], None) == pytest.approx(0.2)
    assert solved.shortfall(_Marginals({"o0": [0.4, 0.3, 0.2, 0.1]}), ["o0"], "v3") == float("inf")


def _decisions(spec: str, task: str, model: str = "factorised_close"):
    scenario = fg.load_scenario("default_apartment")
    agent = fg.Agent(scenario, fg.load_model(model), spec, task=task)
    action = agent.next_action()
    first = agent.decide(action, scenario.start_position)
    agent.observe_look(first.viewpoint, {o: None for o in agent.searching()})
    second = agent.decide(agent.next_action(), scenario.site(first.viewpoint).vantage)
    return agent, first, second


def test_in_the_apartment_with_room_for_seven_viewpoints_it_decides_as_the_exact_planner():
    """find_mug in the 8-site apartment with a budget of 50,000 entries: the tables of all 8 at cap
    2 do not fit (104,976), those of 7 do (30,618); the first two looks are the exact policy's."""
    assert table_entries(8, 1, 2) > 50_000 >= table_entries(7, 1, 2) and restricted_size(1, 50_000) == 7
    agent, a1, a2 = _decisions("near_exact:restrict=1,budget=50000", "find_mug")
    _, b1, b2 = _decisions("exact:cap=2", "find_mug")
    assert (a1.viewpoint, a2.viewpoint) == (b1.viewpoint, b2.viewpoint)
    assert a1.info["near_exact"] == "tables cap=2 over 7 of 8 viewpoints" and decision_route(a2) == "tables"
    assert agent.planner.solves == 1  # the miss kept the same viewpoints: the tables are reused
    with pytest.warns(UserWarning, match="more than the budget 50000"):  # without restrict: the lookahead
        _, c1, _ = _decisions("near_exact:budget=50000", "find_mug")
    assert decision_route(c1) == "lookahead"


def test_a_find_that_changes_the_room_in_the_budget_solves_again():
    """Three objects fit 5 viewpoints in 20,000 entries, two fit 6; finding one solves again over 6."""
    budget = 20_000
    assert restricted_size(3, budget) == 5 and restricted_size(2, budget) == 6
    agent, first, second = _decisions(f"near_exact:restrict=1,budget={budget}", "find_three")
    assert first.info["near_exact"] == "tables cap=2 over 5 of 8 viewpoints"
    solves = agent.planner.solves
    found = {o: None for o in agent.searching()} | {"kettle": second.viewpoint}
    agent.observe_look(second.viewpoint, found)
    scenario = fg.load_scenario("default_apartment")
    third = agent.decide(agent.next_action(), scenario.site(second.viewpoint).vantage)
    assert agent.planner.solves == solves + 1 and third.info["near_exact"] == "tables cap=2 over 6 of 8 viewpoints"


def test_the_setting_is_checked_and_a_correlated_belief_is_still_the_lookahead_s():
    assert NearExactSettings.parse("restrict=1") == NearExactSettings(restrict=1)
    assert NearExactSettings(restrict=1).spec() == "cap=2,budget=524288,restrict=1"
    assert NearExactSettings.parse("restrict=1,slack=0.03").spec() == "cap=2,budget=524288,restrict=1,slack=0.03"
    check_planner("near_exact:restrict=1,budget=2097152,slack=0.1")
    for bad, key in (("near_exact:restrict=2", "restrict"), ("near_exact:restrict=yes", "restrict"),
                     ("near_exact:slack=1", "slack"), ("near_exact:slack=-0.1", "slack"),
                     ("near_exact:slack=nan", "slack")):
        with pytest.raises(ValueError, match=key):
            check_planner(bad)
    with pytest.warns(UserWarning, match="near_exact: deciding as the lookahead does"):
        _, c1, _ = _decisions("near_exact:restrict=1", "find_three", model="joint_close")
    assert c1.info["near_exact"] == "lookahead: the belief is correlated"


def test_where_no_restricted_tables_cover_every_object_it_is_the_lookahead_and_says_why(monkeypatch):
    """The verdict turns on the belief's masses, so it is not kept: once a cover exists again, the
    tables decide."""
    import fg_tea.planning.restricted_tables as rt

    def no_cover(shows, masses, k, first=None):
        raise ValueError(f"restricted search: {k} viewpoints cannot cover some mass of every object")

    real = rt.greedy_cover
    monkeypatch.setattr(rt, "greedy_cover", no_cover)
    scenario = fg.load_scenario("default_apartment")
    agent = fg.Agent(scenario, fg.load_model("factorised_close"), "near_exact:restrict=1,budget=20000",
                     task="find_three")
    with pytest.warns(UserWarning, match="near_exact: deciding as the lookahead does"):
        first = agent.decide(agent.next_action(), scenario.start_position)
    assert first.info["near_exact"] == ("lookahead: restricted search: 5 viewpoints cannot cover some mass "
                                        "of every object")
    monkeypatch.setattr(rt, "greedy_cover", real)
    agent.observe_look(first.viewpoint, {o: None for o in agent.searching()})
    second = agent.decide(agent.next_action(), scenario.site(first.viewpoint).vantage)
    assert second.info["near_exact"] == "tables cap=2 over 5 of 8 viewpoints"
