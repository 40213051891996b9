"""A model program whose exact inference is over the budget is refused in one line, on every path.

The refusal names the variables, the elimination width and the table size, and comes before any
large table is built: in ``fg-tea validate`` (compiled first), ``beliefs``, ``run``, ``compare``
(before its first episode), ``compare --lifelong`` and the Agent. The belief engine's graph sums a
program's own variables out along the compiler's own min-fill order, priced by the same cost
function against the same budget (fg_tea/beliefs/budget.py, docs/design.md §4.8).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import fg_tea as fg
from fg_tea.beliefs import budget, compiled
from fg_tea.beliefs.elimination import min_fill_order, order_cost
from fg_tea.beliefs.graph import build_graph
from fg_tea.common.errors import InputError
from test_input_faults import assert_one_line_error, cli

#: A clique of nine variables of the program's own, eight values each, tied to the mug: summing
#: them out needs a table of 8^9 = 134,217,728 entries (width 8), above the budget of 50,000,000.
WIDE = '''\
import itertools
import fg_tea as fg
base = "factorised"

def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))
    names = [f"v{i}" for i in range(9)]
    for n in names:
        m.variable(n, list(range(8)))
    for a, b in itertools.combinations(names, 2):
        m.factor(a, b, name=f"{a}{b}")(lambda x, y: 2.0 if x == y else 1.0)

    @m.factor("v0", "mug")
    def link(v, mug):
        return 2.0 if v == mug.index else 1.0
    return m
'''
#: What every refusal line says (the variables, the width, the size and the budget).
WORDS = ("mug, v0, v1, v2, v3, v4, v5, v6, v7, v8", "elimination width 8", "134,217,728 entries",
         f"budget of {budget.BUDGET:,}", "refused")
#: A hang guard only (the refusal takes well under a second; summing out took minutes).
GUARD = 120


@pytest.fixture()
def wide(tmp_path):
    path = tmp_path / "wide_model.py"
    path.write_text(WIDE)
    return path


@pytest.fixture(autouse=True)
def _no_large_table(monkeypatch):
    """Any elimination step that builds a table above the budget fails the test at once."""
    real = budget.log_product

    def guarded(factors, scope, cards):
        size = int(np.prod([cards[v] for v in scope]))
        assert size <= budget.BUDGET, f"a table of {size:,} entries was built"
        return real(factors, scope, cards)
    monkeypatch.setattr(budget, "log_product", guarded)


@pytest.mark.parametrize("argv", [
    ["validate", "{p}"],
    ["beliefs", "--model", "{p}"],
    ["beliefs", "--model", "{p}", "--top", "3"],
    ["run", "--model", "{p}", "--env", "fake", "--out", "{d}/run"],
    ["preview", "--model", "{p}"],
], ids=["validate", "beliefs", "beliefs-top", "run", "preview"])
def test_every_command_refuses_it_in_one_line(argv, wide, tmp_path):
    status, _, err = cli([a.format(p=wide, d=tmp_path) for a in argv], seconds=GUARD)
    assert_one_line_error(status, err, str(wide), *WORDS)


@pytest.mark.parametrize("lifelong", [False, True])
def test_compare_refuses_it_before_any_episode(lifelong, wide, tmp_path):
    out = tmp_path / "out"
    argv = ["compare", "--worlds", "2", "--models", "factorised", wide, "--planners", "nearest",
            "--env", "fake", "--executor", "serial", "--out", out]
    status, _, err = cli(argv[:1] + (["--lifelong", "2"] if lifelong else []) + argv[1:], seconds=GUARD)
    assert_one_line_error(status, err, str(wide), *WORDS)
    assert not (out / "episodes.csv").exists() or len((out / "episodes.csv").read_text().splitlines()) <= 1


def test_the_agent_refuses_it(wide):
    with pytest.raises(InputError) as caught:
        fg.Agent(fg.load_scenario("default_apartment"), fg.load_model(wide))
    for word in WORDS:
        assert word in str(caught.value)
    assert "\n" not in str(caught.value) and str(wide) in str(caught.value)


def test_the_engine_prices_with_the_compilers_cost_model(wide):
    """The engine's refusal quotes exactly what min_fill_order and order_cost give for the group."""
    names = ["mug"] + [f"v{i}" for i in range(9)]
    scenario = fg.load_scenario("default_apartment")
    cards = {0: len(scenario.sites), **{i: 8 for i in range(1, 10)}}
    scopes = [(a, b) for a, b in itertools.combinations(range(1, 10), 2)] + [(1, 0)]
    order = min_fill_order(scopes, list(range(1, 10)), cards)
    width, largest = order_cost(scopes, order, [0], cards)
    assert (width, largest) == (8, 8 ** 9)
    with pytest.raises(InputError) as caught:
        build_graph(scenario, fg.load_model(wide))
    assert f"over {', '.join(names)} " in str(caught.value)
    assert f"{largest:,} entries (elimination width {width})" in str(caught.value)
    assert compiled.BUDGET is budget.BUDGET


SMALL = '''\
import fg_tea as fg
base = "factorised"

def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))
    m.variable("a", [0, 1, 2])
    m.variable("b", [0, 1, 2, 3])
    m.factor("a", "b", name="ab")(lambda a, b: 1.0 + a * b)
    m.factor("b", "mug", name="b mug")(lambda b, mug: 3.0 if mug.index % 4 == b else 0.5)
    m.factor("a", "kettle", "mug", name="a kettle mug")(
        lambda a, kettle, mug: 2.0 if (kettle.index + mug.index) % 3 == a else 1.0)
    return m
'''


def test_summing_out_within_the_budget_is_exact(tmp_path):
    """The engine's factor over the locations a group touches is the brute-force sum, to 1e-12."""
    path = tmp_path / "small_model.py"
    path.write_text(SMALL)
    scenario = fg.load_scenario("default_apartment")
    graph = build_graph(scenario, fg.load_model(path))
    (factor,) = [f for f in graph.extra if "summed out: a, b" in f.label]
    program = fg.model_program(scenario, fg.load_model(path))
    tables = {f.name: f.table for f in program.factors if f.name in ("ab", "b mug", "a kettle mug")}
    assert factor.variables == ("L[mug]", "L[kettle]")
    brute = np.einsum("ab,bm,akm->mk", tables["ab"], tables["b mug"], tables["a kettle mug"])
    expected = brute
    assert np.allclose(factor.table, expected / expected.max(), rtol=0, atol=1e-12)


def test_a_group_over_a_small_budget_is_refused_before_it_is_built():
    tables = [(("x", "y"), np.ones((10, 10))), (("y", "z"), np.ones((10, 10)))]
    cards = {"x": 10, "y": 10, "z": 10}
    with pytest.raises(InputError) as caught:
        budget.sum_out_group("p.py", "factor 'xy'", "xy * yz", tables, ["y"], ["x", "z"], cards, budget=999)
    assert "needs a table of 1,000 entries (elimination width 2), above the budget of 999" in str(caught.value)
    table = budget.sum_out_group("p.py", "factor 'xy'", "xy * yz", tables, ["y"], ["x", "z"], cards, budget=1000)
    assert np.array_equal(table, np.ones((10, 10)))
