"""The world distribution's ``together`` rule draws with the program's own probabilities.

The rule (fg_tea/world/together.py) and the model program experiments/programs/kept_together.py
state one relation: every two of the mug, the teabag and the kettle within WITHIN metres weighs
TOGETHER. Here the rule's exact table is checked against the program's factor compiled with the
world's own placement priors and hard capacity, and seeded draws against that compiled joint.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest

import fg_tea as fg
from fg_tea.common.errors import InputError
from fg_tea.model.program import Program
from fg_tea.model.program_bundled import model_program
from fg_tea.world.distributions import parse_world
from fg_tea.world.together import Together, draw_together, together_table

ROOT = Path(__file__).resolve().parent.parent
PROGRAM = ROOT / "experiments" / "programs" / "kept_together.py"
KEPT, WITHIN, TOGETHER = ("mug", "teabag", "kettle"), 2.5, 20.0


def _world(**rule):
    data = {"name": "together_test", "base_scenario": "default_apartment",
            "placement": {"order": list(KEPT),
                          "together": [{"objects": list(KEPT), "within": WITHIN, "weight": TOGETHER, **rule}]}}
    return parse_world(data, "together_test.json")


def _bases(scenario):
    """Each kept object's placement distribution as the world draws it (affordance prior)."""
    out = []
    for name in KEPT:
        cat = scenario.object(name).category
        p = np.array([max(s.affordances.get(cat, 0.0), 0.0) for s in scenario.sites]) + 1e-9
        out.append(p / p.sum())
    return out


def _program_joint(scenario):
    """The program's relation compiled over the world's priors with hard capacity: a Program whose
    location priors are the world's, with the kept_together factor of the model program file."""
    model = fg.load_model(str(PROGRAM))
    agent = model_program(scenario, model)
    relation = agent.factor_named("kept_together")
    assert relation.scope == KEPT
    m = Program.from_scenario(scenario)
    for name, base in zip(KEPT, _bases(scenario)):
        m.location(name)
        m.table(name, base, name=f"world prior {name}")
    m.table(KEPT, relation.table, name="kept_together")

    def within_capacity(*sites):
        return all(sum(s.index == t.index for t in sites) <= (s.capacity or 99) for s in sites)

    m.function(KEPT, within_capacity, name="capacity")
    return fg.compile_program(m).joint(list(KEPT)), fg.compile_program(agent).joint(list(KEPT))


def test_the_program_file_states_the_rule_numbers():
    from fg_tea.model.program_file import load_program_source
    import sys

    source = load_program_source(str(PROGRAM))
    module = sys.modules[source.function.__module__]
    assert (module.KEPT, module.WITHIN, module.TOGETHER) == (KEPT, WITHIN, TOGETHER)
    assert source.base == "joint"


def test_rule_table_is_the_program_factor_compiled_with_the_world_priors():
    world = _world()
    scenario = world.house(0)
    capacity = np.array([s.capacity if s.capacity is not None else 10 ** 9 for s in scenario.sites])
    table = together_table(world.together[0], [s.position for s in scenario.sites], _bases(scenario), capacity)
    expected, agent = _program_joint(scenario)
    np.testing.assert_allclose(table, expected, rtol=1e-9, atol=1e-15)
    # the relation matters here: without it the kept objects are together far less often
    plain = together_table(Together(KEPT, WITHIN, 1.0), [s.position for s in scenario.sites],
                           _bases(scenario), capacity)
    close = _close_mask(scenario)
    assert table[close].sum() > plain[close].sum() + 0.2
    # the agent's program differs only by its priors' floor and soft capacity: close to the world's
    assert 0.5 * np.abs(agent - table).sum() < 0.05


def _close_mask(scenario):
    xy = np.array([s.position[:2] for s in scenario.sites])
    d = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1)) <= WITHIN
    k = len(xy)
    g = np.indices((k, k, k))
    return d[g[0], g[1]] & d[g[0], g[2]] & d[g[1], g[2]]


def test_drawn_worlds_follow_the_compiled_program_seeded():
    world = _world()
    scenario = world.house(0)
    expected, _ = _program_joint(scenario)
    names = scenario.site_names
    n = 4000
    counts = np.zeros_like(expected)
    for seed in range(n):
        truth = {o.name: names.index(o.true_site) for o in world.sample(seed).objects}
        counts[tuple(truth[o] for o in KEPT)] += 1
    assert counts[expected == 0].sum() == 0  # never an arrangement over capacity
    for axis, name in enumerate(KEPT):  # chi-square of each object's marginal against the program's
        keep = tuple(a for a in range(3) if a != axis)
        observed, p = counts.sum(axis=keep), expected.sum(axis=keep)
        live = p * n >= 5
        chi2 = float((((observed[live] - n * p[live]) ** 2) / (n * p[live])).sum())
        assert chi2 < 3 * live.sum() + 10, (name, chi2)  # far below a wrong distribution's
    share = counts[_close_mask(scenario)].sum() / n
    assert abs(share - expected[_close_mask(scenario)].sum()) < 4 * np.sqrt(0.25 / n)


def test_same_seed_same_arrangement_and_capacity_counts_objects_already_placed():
    world = _world()
    a = [o.true_site for o in world.sample(7).objects]
    assert a == [o.true_site for o in world.sample(7).objects]
    rule = Together(("a", "b"), 1.0, 5.0)
    positions = [(0.0, 0.0), (0.5, 0.0), (9.0, 0.0)]
    bases = [np.full(3, 1 / 3)] * 2
    table = together_table(rule, positions, bases, np.array([0, 1, 5]))  # site 0 is full
    assert table[0].sum() == 0 and table[:, 0].sum() == 0 and table[1, 1] == 0  # site 1 holds one
    assert table[1, 2] == pytest.approx(table[2, 2] / 5)  # far apart: weight 1; both on site 2: 5
    rng = np.random.default_rng(0)
    assert all(draw_together(rule, positions, bases, np.array([0, 1, 5]), rng)[0] != 0 for _ in range(50))


@pytest.mark.parametrize("rule, fault", [
    ({"weight": 0}, "weight"), ({"within": -1.0}, "within"),
    ({"objects": ["mug"]}, "at least two"), ({"objects": ["mug", "spoon"]}, "'spoon'"),
    ({"objects": ["mug", "mug"]}, "listed twice")])
def test_bad_rules_are_one_line_input_errors(rule, fault):
    with pytest.raises(InputError) as err:
        _world(**rule)
    assert fault in str(err.value) and "\n" not in str(err.value)


def test_an_object_with_a_co_location_rule_cannot_be_kept_together_too():
    data = json.loads(json.dumps({"name": "x", "base_scenario": "default_apartment", "placement": {
        "order": ["kettle", "teabag", "mug"],
        "co_location": [{"object": "teabag", "anchor": "kettle", "same_site": 0.5}],
        "together": [{"objects": ["teabag", "mug"], "within": 1.0, "weight": 2.0}]}}))
    with pytest.raises(InputError, match="co_location"):
        parse_world(copy.deepcopy(data), "x.json")


def test_a_world_without_the_rule_draws_as_before():
    plain = parse_world({"name": "p", "base_scenario": "default_apartment", "placement": {}}, "p.json")
    assert plain.together == () and "together" not in plain.parameters()


def test_the_relation_is_no_product_of_pairwise_factors():
    """Its three-way interaction — the alternating sum of log weights over two sites per object —
    is log TOGETHER for one site s (all three on it: close) against two sites x, y far from s and
    from each other; a product of factors over pairs has an interaction of zero at every choice."""
    scenario = _world().house(0)
    table = model_program(scenario, fg.load_model(str(PROGRAM))).factor_named("kept_together").table
    xy = np.array([site.position[:2] for site in scenario.sites])
    dist = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    s, x, y = next((s, x, y) for s in range(len(xy)) for x in range(len(xy)) for y in range(len(xy))
                   if min(dist[s, x], dist[s, y], dist[x, y]) > WITHIN)
    choices = ((s, x), (s, y), (s, x))

    def interaction(log):
        return sum((-1) ** (i + j + k) * log[choices[0][i], choices[1][j], choices[2][k]]
                   for i in (0, 1) for j in (0, 1) for k in (0, 1))

    assert interaction(np.log(table)) == pytest.approx(np.log(TOGETHER))
    pairwise = np.log(np.random.default_rng(1).random((3,) + table.shape[:2]))  # any pairwise product
    assert interaction(pairwise[0][:, :, None] + pairwise[1][:, None, :] + pairwise[2][None, :, :]) \
        == pytest.approx(0.0, abs=1e-9)
