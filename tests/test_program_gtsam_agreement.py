"""Compiled programs agree with gtsam on at least 200 random programs (docs/design.md §4.8).

The same random programs as tests/test_program_exact.py (1-6 variables of 1-8 values, factors over
random scopes of 1-3 variables with random positive tables, random evidence), 200 of them from a
seed range of their own, each compiled by the automatic route and by variable elimination and
answered by gtsam's ``DiscreteFactorGraph`` (``DiscreteMarginals``, ``DiscreteSearch``): every
marginal, the hypothetical posteriors of two candidates on every variable, and the 5 best
arrangements agree to 1e-12. test_program_exact.py checks all of these against brute-force
enumeration to 1e-12; this file is the cross-check with the engine of record.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fg_tea.beliefs.compiled_gtsam import gtsam_hypothetical, gtsam_kbest, gtsam_marginals
from test_program_exact import _no_near_tie, brute_joint, compiled, random_program

TOL = 1e-12
PROGRAMS = 200
K = 5


def check_against_gtsam(seed: int, method: str) -> None:
    rng = np.random.default_rng(20_000 + seed)
    m, evidence = random_program(rng)
    model = compiled(m, evidence, method)
    theirs = gtsam_marginals(model)
    for name, ours in model.marginals().items():
        np.testing.assert_allclose(ours, theirs[name], rtol=0, atol=TOL, err_msg=f"seed {seed} {name}")
    for variable in m.variables:
        lik = rng.uniform(0.1, 1.0, size=(2, variable.card))
        hyp = model.hypothetical(variable.name, lik)
        for c, row in enumerate(gtsam_hypothetical(model, variable.name, lik)):
            for name, expect in row.items():
                np.testing.assert_allclose(hyp.marginals[name][c], expect, rtol=0, atol=TOL,
                                           err_msg=f"seed {seed} {variable.name} -> {name}")
    best, found = model.kbest(K), gtsam_kbest(model, K)
    assert len(best) == len(found)
    # gtsam's weights are unnormalised: compare each arrangement's ratio to the best's.
    for arrangement, (_, log_weight) in zip(best, found):
        ratio = arrangement.probability / best[0].probability
        assert ratio == pytest.approx(math.exp(log_weight - found[0][1]), abs=TOL)
    joint = brute_joint(m, evidence).ravel()
    if all(_no_near_tie(joint, i) for i in np.argsort(-joint)[:K]):  # ties may come in either order
        for arrangement, (values, _) in zip(best, found):
            assert {v: model.values(v).index(x) for v, x in arrangement.values.items()} == values


@pytest.mark.slow
@pytest.mark.parametrize("method", ["auto", "elimination"])
def test_two_hundred_random_programs_agree_with_gtsam(method):
    for seed in range(PROGRAMS):
        check_against_gtsam(seed, method)


def test_a_disagreement_with_gtsam_would_be_seen():
    """The check can fail: evidence gtsam does not see moves a marginal by more than the tolerance."""
    for seed in range(PROGRAMS):
        m, evidence = random_program(np.random.default_rng(20_000 + seed))
        wide = [v for v in m.variables if v.card > 1]
        if wide:
            break
    model = compiled(m, evidence, "elimination")
    name = wide[0].name
    skewed = model.observe(name, np.linspace(1.0, 2.0, wide[0].card))
    with pytest.raises(AssertionError):
        np.testing.assert_allclose(skewed.marginal(name), gtsam_marginals(model)[name], rtol=0, atol=TOL)
