"""Couplings through the user's own variables, and couplings of task states only, are exact
(docs/design.md §4.8, fg_tea/beliefs/graph.py, fg_tea/beliefs/coupling.py).

A program couples the kettle's water with its location through a variable of its own ("weather":
T1(water, weather) and T2(weather, kettle)), or couples the kettle's two states with each other
only. The brute force of tests/test_coupling_exact.py is given the equivalent coupling over
(states, kettle's site) — the own variable summed out by hand, or the states-only table constant
along the site axis — and random looks, readings and transitions agree to 1e-12; gtsam agrees.
"""

from __future__ import annotations

import numpy as np

import fg_tea as fg
from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.beliefs.graph import build_graph
from tests.test_coupling_exact import K, SCENARIO, SITES, STATES, _Brute, random_steps

PROGRAM = '''import numpy as np
import fg_tea as fg
base = {base!r}


def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))
    {body}
    return m
'''


def _write(tmp_path, n, body, arrays):
    for name, a in arrays.items():
        np.save(tmp_path / f"{name}{n}.npy", a)
    (tmp_path / "base_likelihood.toml").write_text(
        'extends = "factorised"\nname = "base_likelihood"\n[detection]\npositive_update = "likelihood"\n')
    base = str(tmp_path / "base_likelihood.toml")
    loads = {name: f"np.load({str(tmp_path / f'{name}{n}.npy')!r})" for name in arrays}
    path = tmp_path / f"p{n}.py"
    path.write_text(PROGRAM.format(base=base, body=body.format(**loads)))
    return fg.load_model(str(path)), base


def _programs(tmp_path, rng, n):
    """(model, base, states, table over (states..., kettle's site)) of one random program."""
    if n % 2 == 0:  # through an own variable of 3 values
        t1, t2 = rng.uniform(0.05, 3.0, (2, 3)), rng.uniform(0.05, 3.0, (3, K))
        body = ('m.variable("weather", ["dry", "wet", "windy"])\n'
                '    m.table(["kettle.contains_water", "weather"], {t1}, name="water by weather")\n'
                '    m.table(["weather", "kettle"], {t2}, name="kettle by weather")')
        model, base = _write(tmp_path, n, body, {"t1": t1, "t2": t2})
        return model, base, STATES[:1], np.einsum("sw,wk->sk", t1, t2)
    t = rng.uniform(0.05, 3.0, (2, 2))  # states only
    model, base = _write(tmp_path, n, 'm.table(["kettle.contains_water", "kettle.water_hot"], {t}, '
                         'name="hot with water")', {"t": t})
    return model, base, STATES, np.repeat(t[:, :, None], K, axis=2)


def test_hidden_and_states_only_couplings_match_brute_force(tmp_path):
    rng = np.random.default_rng(21)
    checked = 0
    for n in range(60):
        model, base, states, table = _programs(tmp_path, rng, n)
        engine = BeliefEngine(SCENARIO, model)
        graph = build_graph(SCENARIO, model)
        assert graph.couplings and not graph.extra  # held as a coupling, not summed into locations
        k = list(graph.objects).index("kettle")
        priors = {f.variables[0]: float(f.table[1] / f.table.sum()) for f in graph.state_priors
                  if f.variables[0] in states}
        joint = BeliefEngine(SCENARIO, fg.load_model(base)).location_joint()
        brute = _Brute(joint.ravel(), np.indices(joint.shape)[k].ravel(), priors, states, table)
        checked += random_steps(engine, brute, model, states, rng)
        if n < 6:
            assert engine.check_against_gtsam() < 1e-9
    assert checked >= 60


def test_a_reading_moves_the_location_through_an_own_variable(tmp_path):
    t1 = np.array([[30.0, 1.0], [1.0, 30.0]])  # water -> mostly "wet", none -> mostly "dry"
    t2 = np.ones((2, K))
    t2[1, SITES.index("dining_table")] = 30.0  # "wet" -> the kettle on the dining table
    body = ('m.variable("weather", ["dry", "wet"])\n'
            '    m.table(["kettle.contains_water", "weather"], {t1}, name="water by weather")\n'
            '    m.table(["weather", "kettle"], {t2}, name="kettle by weather")')
    model, _ = _write(tmp_path, 0, body, {"t1": t1, "t2": t2})
    engine = BeliefEngine(SCENARIO, model)
    before = engine.location_map("kettle")["dining_table"]
    engine.observe_state("kettle.contains_water", True, model.sensors["state"])
    assert engine.location_map("kettle")["dining_table"] > before + 0.05
