"""CompiledModel.observe_many is the model observe gives one by one (fg_tea/beliefs/compiled.py,
docs/design.md §4.8), and it checks each likelihood as observe does."""

from __future__ import annotations

import numpy as np
import pytest

import fg_tea as fg
from fg_tea.common.errors import ContradictionError, InputError


def _program(rng):
    scenario = fg.load_scenario("default_apartment")
    m = fg.Program.from_scenario(scenario)
    for o in ("mug", "kettle", "teabag"):
        m.location(o)
    k = len(scenario.site_names)
    m.table(["mug", "kettle"], rng.uniform(0.1, 2.0, (k, k)), name="a")
    m.table(["kettle", "teabag"], rng.uniform(0.1, 2.0, (k, k)), name="b")
    return m, k


def test_observe_many_equals_observing_in_turn():
    rng = np.random.default_rng(3)
    for _ in range(10):
        program, k = _program(rng)
        compiled = fg.compile_program(program)
        evidence = {o: rng.uniform(0.0, 1.0, k) for o in ("mug", "teabag", "kettle")}
        one_by_one = compiled
        for name, lik in evidence.items():
            one_by_one = one_by_one.observe(name, lik)
        many = compiled.observe_many(evidence)
        for v in ("mug", "kettle", "teabag"):
            np.testing.assert_allclose(many.marginal(v), one_by_one.marginal(v), rtol=0, atol=1e-14)


def test_observe_many_checks_each_likelihood():
    program, k = _program(np.random.default_rng(4))
    compiled = fg.compile_program(program)
    with pytest.raises(InputError, match="evidence on 'kettle'"):
        compiled.observe_many({"mug": np.ones(k), "kettle": np.ones(k - 1)})
    with pytest.raises(ContradictionError):
        compiled.observe_many({"mug": np.zeros(k)})
