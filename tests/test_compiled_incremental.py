"""Evidence on a compiled program that has answered queries (docs/design.md §4.8).

A compiled model keeps its plan when evidence falls on single variables, carries the caches of
the components the evidence misses, and adds the evidence to the cached table of the component it
hits. These tests walk random programs (those of tests/test_program_exact.py, with and without
hard zeros) through a run of evidence, asking queries between steps so that every cache is
filled, carried and extended, and compare every step with brute-force enumeration of the whole
program and all evidence so far, to 1e-12. ``hypothetical_many`` is checked the same way.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_program_exact import TOL, brute_joint, random_program

from fg_tea.beliefs.compiled import compile_program
from fg_tea.common.errors import ContradictionError


def _marginals(joint: np.ndarray) -> list[np.ndarray]:
    n = joint.ndim
    return [joint.sum(axis=tuple(a for a in range(n) if a != i)) for i in range(n)]


@pytest.mark.parametrize("method", ["auto", "dense", "elimination"])
@pytest.mark.parametrize("zeros", [False, True])
def test_evidence_after_queries_agrees_with_brute_force_at_every_step(method, zeros):
    checked = 0
    for seed in range(70):
        rng = np.random.default_rng(70_000 + seed)
        m, _ = random_program(rng, zeros)
        names = [v.name for v in m.variables]
        model = compile_program(m, method=method)
        evidence: list[tuple[str, np.ndarray]] = []
        for _ in range(4):
            if brute_joint(m, evidence, normalise=False).sum() == 0:
                with pytest.raises(ContradictionError, match="probability zero"):
                    model.marginals()
                break
            joint = brute_joint(m, evidence)
            for name, expect in zip(names, _marginals(joint)):
                np.testing.assert_allclose(model.marginal(name), expect, rtol=0, atol=TOL)
            checked += 1
            batch = {str(v): rng.uniform(0.0, 1.0, size=m.var(str(v)).card)
                     for v in rng.choice(names, size=int(rng.integers(1, len(names) + 1)), replace=False)}
            for lik in batch.values():
                lik[int(rng.integers(lik.size))] = 1.0  # never zero everywhere
            model = model.observe_many(batch)
            evidence += list(batch.items())
    assert checked > 150


def test_hypothetical_many_agrees_with_brute_force_and_with_hypothetical():
    for seed in range(200):
        rng = np.random.default_rng(80_000 + seed)
        m, evidence = random_program(rng)
        names = [v.name for v in m.variables]
        model = compile_program(m)
        model.marginals()  # fill the caches, then add the evidence
        model = model.observe_many(dict(evidence)) if evidence else model
        joint = brute_joint(m, evidence)
        observed = [str(v) for v in rng.choice(names, size=int(rng.integers(1, len(names) + 1)), replace=False)]
        report = [str(v) for v in rng.choice(names, size=int(rng.integers(1, len(names) + 1)), replace=False)]
        liks = {x: rng.uniform(0.0, 1.0, size=(4, m.var(x).card)) for x in observed}
        many = model.hypothetical_many(liks, report=report)
        assert set(many) == set(observed)
        for x, lik in liks.items():
            a = names.index(x)
            assert set(many[x].marginals) == set(report)
            one = model.hypothetical(x, lik)
            for c in range(lik.shape[0]):
                shape = [1] * joint.ndim
                shape[a] = joint.shape[a]
                post = joint * lik[c].reshape(shape)
                np.testing.assert_allclose(many[x].probability[c], post.sum(), rtol=0, atol=TOL)
                post = post / post.sum()
                for y in report:
                    expect = _marginals(post)[names.index(y)]
                    np.testing.assert_allclose(many[x].marginals[y][c], expect, rtol=0, atol=TOL)
                    np.testing.assert_array_equal(many[x].marginals[y][c], one.marginals[y][c])


def test_a_hypothetical_the_program_rules_out_is_nan_and_the_belief_is_unchanged():
    rng = np.random.default_rng(5)
    m, _ = random_program(rng)
    model = compile_program(m)
    before = model.marginals()
    name = m.variables[0].name
    lik = np.zeros((2, m.variables[0].card))
    lik[1] = 1.0
    hyp = model.hypothetical_many({name: lik})[name]
    assert hyp.probability[0] == 0 and all(np.isnan(v[0]).all() for v in hyp.marginals.values())
    for v, p in model.marginals().items():
        np.testing.assert_array_equal(p, before[v])
