"""Planning reads a coupled belief, not the uncoupled one (docs/design.md §4.8): the engine's
hypothetical posteriors of every look (what EFE and the lookahead score, hypothetical_all) equal
the posterior the engine reaches by making that look, after a state reading has moved the coupled
object's location; and they differ from an uncoupled engine's given the same evidence."""

from __future__ import annotations

import numpy as np

import fg_tea as fg
from fg_tea.beliefs.engine import BeliefEngine
from tests.test_coupling_exact import K, SCENARIO, SITES, STATES, _program_file


def test_hypothetical_looks_carry_the_coupling(tmp_path):
    rng = np.random.default_rng(5)
    for n, base in enumerate(["factorised", "joint", "factorised", "joint"]):
        table = rng.uniform(0.05, 3.0, (2, K))
        table[1, SITES.index("dining_table")] = 25.0
        model = fg.load_model(str(_program_file(tmp_path, base, STATES[:1], table, n)))
        engine = BeliefEngine(SCENARIO, model)
        plain = BeliefEngine(SCENARIO, fg.load_model(str(tmp_path / f"{base}_likelihood.toml")))
        for e in (engine, plain):
            e.observe_state("kettle.contains_water", True, model.sensors["state"])
            e.observe_site("kitchen_counter", {"mug": False})
        miss, seen = engine.hypothetical_all()
        objects = list(engine.objects)
        for o, obj in enumerate(objects):
            for j in range(K):
                for outcome, table_ in ((False, miss), (True, seen)):
                    after = engine.copy().observe_site(SITES[j], {obj: outcome}).after
                    for p, other in enumerate(objects):
                        if other in after:
                            np.testing.assert_allclose(table_[o, j, p], after[other], rtol=0, atol=1e-10)
        k = objects.index("kettle")
        assert not np.allclose(miss[k, 2, k], plain.hypothetical_all()[0][k, 2, k], atol=1e-3)
