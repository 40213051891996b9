"""Compiled programs are exact (docs/design.md §4.8): random programs against brute force and gtsam.

Each random program has 1-6 variables of 1-8 values and random factors over random scopes of
1-3 variables with random positive tables, then random evidence. Brute force here is explicit
enumeration: every assignment of every variable is listed (``np.indices``) and its weight is the
product of the factor entries it picks, in linear space — no elimination, no log space. Every
method the compiler has (dense joint, variable elimination, closed forms) must agree with it to
1e-12 on marginals, joints of random sets, hypothetical posteriors and the K best arrangements;
a subset is also solved by gtsam (DiscreteMarginals, DiscreteSearch) and must agree to 1e-9.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from fg_tea.beliefs.compiled import compile_program
from fg_tea.beliefs.compiled_gtsam import gtsam_hypothetical, gtsam_kbest, gtsam_marginals
from fg_tea.common.errors import ContradictionError, InputError
from fg_tea.model.program import Program

TOL = 1e-12
QUICK = 210
SLOW = 1000


def random_program(rng: np.random.Generator,
                   zeros: bool = False) -> tuple[Program, list[tuple[str, np.ndarray]]]:
    """A random program and random evidence (variable, likelihood) on some of its variables;
    with `zeros`, about a third of the table entries are zero (hard constraints)."""
    n = int(rng.integers(1, 7))
    m = Program(source="<random>")
    names = [f"x{i}" for i in range(n)]
    for name in names:
        m.variable(name, [f"v{j}" for j in range(int(rng.integers(1, 9)))])
    for f in range(int(rng.integers(1, 2 * n + 2))):
        scope = list(rng.choice(names, size=int(rng.integers(1, min(3, n) + 1)), replace=False))
        shape = [m.var(v).card for v in scope]
        table = rng.uniform(0.05, 1.0, size=shape)
        if zeros:
            table = np.where(rng.uniform(size=shape) < 0.35, 0.0, table)
            table.flat[int(rng.integers(table.size))] = 1.0  # never all zero
        m.table(scope, table, name=f"f{f}")
    evidence = []
    for name in rng.choice(names, size=int(rng.integers(0, n + 1)), replace=False):
        evidence.append((str(name), rng.uniform(0.01, 1.0, size=m.var(str(name)).card)))
    return m, evidence


def brute_joint(m: Program, evidence, normalise: bool = True) -> np.ndarray:
    """The (normalised) joint over every variable, by enumerating every assignment."""
    shape = [v.card for v in m.variables]
    position = {v.name: i for i, v in enumerate(m.variables)}
    grid = np.indices(shape).reshape(len(shape), -1)  # one column per assignment
    weight = np.ones(grid.shape[1])
    for f in m.factors:
        weight = weight * f.table[tuple(grid[position[v]] for v in f.scope)]
    for name, lik in evidence:
        weight = weight * lik[grid[position[name]]]
    return (weight / weight.sum() if normalise else weight).reshape(shape)


def compiled(m: Program, evidence, method: str):
    model = compile_program(m, method=method)
    for name, lik in evidence:
        model = model.observe(name, lik)
    return model


def check_program(seed: int, method: str, zeros: bool = False) -> None:
    rng = np.random.default_rng(seed)
    m, evidence = random_program(rng, zeros)
    model = compiled(m, evidence, method)
    if brute_joint(m, evidence, normalise=False).sum() == 0:  # the constraints rule everything out
        with pytest.raises(ContradictionError, match="probability zero"):
            model.marginal(m.variables[0].name)
        with pytest.raises(ContradictionError, match="probability zero"):
            model.kbest(2)
        return
    joint = brute_joint(m, evidence)
    names = [v.name for v in m.variables]
    n = len(names)
    # Marginals.
    for i, name in enumerate(names):
        expect = joint.sum(axis=tuple(a for a in range(n) if a != i))
        np.testing.assert_allclose(model.marginal(name), expect, rtol=0, atol=TOL)
    # The joint of a random set of variables, in a random order.
    chosen = list(rng.permutation(n)[:int(rng.integers(1, n + 1))])
    expect = joint.sum(axis=tuple(a for a in range(n) if a not in chosen)) if len(chosen) < n else joint
    kept = sorted(chosen)
    expect = np.transpose(expect, [kept.index(a) for a in chosen])
    np.testing.assert_allclose(model.joint([names[a] for a in chosen]), expect, rtol=0, atol=TOL)
    # Hypothetical posteriors: all candidates on one variable at once.
    x = int(rng.integers(n))
    lik = rng.uniform(0.0, 1.0, size=(3, m.variables[x].card))
    lik[0] = 0.0
    lik[0, 0] = 1.0  # a hard observation
    hyp = model.hypothetical(names[x], lik)
    for c in range(lik.shape[0]):
        shape = [1] * n
        shape[x] = lik.shape[1]
        post = joint * lik[c].reshape(shape)
        assert hyp.probability[c] == pytest.approx(post.sum(), abs=TOL)
        if post.sum() == 0:  # evidence the program rules out: NaN rows, never a made-up belief
            assert all(np.isnan(hyp.marginals[name][c]).all() for name in names)
            continue
        post = post / post.sum()
        for i, name in enumerate(names):
            expect = post.sum(axis=tuple(a for a in range(n) if a != i))
            np.testing.assert_allclose(hyp.marginals[name][c], expect, rtol=0, atol=TOL)
    # K best: the K largest entries of the brute-force joint, in order.
    k = int(rng.integers(1, 8))
    best = model.kbest(k)
    flat = joint.ravel()
    ranked = np.lexsort((np.arange(flat.size), -flat))[:k]
    assert len(best) == min(k, int(np.count_nonzero(flat)))  # never an impossible arrangement
    for arrangement, index in zip(best, ranked):
        assignment = np.unravel_index(index, joint.shape)
        assert arrangement.probability == pytest.approx(flat[index], abs=TOL)
        got = [m.variables[i].values.index(arrangement.values[name]) for i, name in enumerate(names)]
        if _no_near_tie(flat, index):
            assert got == [int(a) for a in assignment]
        else:  # an exact-enough tie: the arrangement must still weigh what the rank says
            assert flat[np.ravel_multi_index(got, joint.shape)] == pytest.approx(flat[index], abs=TOL)


def _no_near_tie(flat: np.ndarray, index: int) -> bool:
    others = np.delete(flat, index)
    return others.size == 0 or float(np.min(np.abs(others - flat[index]))) > 1e-9


@pytest.mark.parametrize("method", ["auto", "dense", "elimination"])
def test_random_programs_agree_with_brute_force(method):
    for seed in range(QUICK):
        check_program(seed, method)


@pytest.mark.parametrize("method", ["dense", "elimination"])
def test_random_programs_with_hard_zeros_agree_with_brute_force(method):
    for seed in range(60):
        check_program(50_000 + seed, method, zeros=True)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["dense", "elimination"])
def test_more_random_programs_agree_with_brute_force(method):
    for seed in range(QUICK, SLOW):
        check_program(seed, method)


def test_random_programs_agree_with_gtsam():
    for seed in range(40):
        rng = np.random.default_rng(10_000 + seed)
        m, evidence = random_program(rng)
        model = compiled(m, evidence, "elimination")
        ours = model.marginals()
        theirs = gtsam_marginals(model)
        for name in ours:
            np.testing.assert_allclose(ours[name], theirs[name], rtol=0, atol=1e-9)
        name = m.variables[0].name
        lik = rng.uniform(0.1, 1.0, size=(2, m.variables[0].card))
        hyp = model.hypothetical(name, lik)
        for c, row in enumerate(gtsam_hypothetical(model, name, lik)):
            for v in row:
                np.testing.assert_allclose(hyp.marginals[v][c], row[v], rtol=0, atol=1e-9)
        k = 5
        best = model.kbest(k)
        found = gtsam_kbest(model, k)
        assert len(found) == len(best)
        joint = brute_joint(m, evidence).ravel()
        if all(_no_near_tie(joint, i) for i in np.argsort(-joint)[:k]):
            for arrangement, (values, log_weight) in zip(best, found):
                assert {v: model.values(v).index(x) for v, x in arrangement.values.items()} == values
            # gtsam's weights are unnormalised: compare ratios to the best.
            for arrangement, (_, log_weight) in zip(best, found):
                ratio = arrangement.probability / best[0].probability
                assert ratio == pytest.approx(math.exp(log_weight - found[0][1]), abs=1e-9)


def test_transitions_and_hidden_copies_are_exact():
    rng = np.random.default_rng(7)
    for _ in range(30):
        m, evidence = random_program(rng)
        names = [v.name for v in m.variables]
        name = str(rng.choice(names))
        card = m.var(name).card
        step = rng.uniform(0.05, 1.0, size=(card, card))
        for method in ("dense", "elimination"):
            model = compiled(m, evidence, method).transition(name, step)
            # Brute force: P(new) = sum_old P(old, rest) step(old, new).
            joint = brute_joint(m, evidence)
            axis = names.index(name)
            moved = np.moveaxis(np.tensordot(joint, step, axes=([axis], [0])), -1, axis)
            moved = moved / moved.sum()
            for i, v in enumerate(names):
                expect = moved.sum(axis=tuple(a for a in range(len(names)) if a != i))
                np.testing.assert_allclose(model.marginal(v), expect, rtol=0, atol=TOL)
            flat = moved.ravel()
            best = model.kbest(3)
            for arrangement, index in zip(best, np.lexsort((np.arange(flat.size), -flat))[:3]):
                assert arrangement.probability == pytest.approx(flat[index], abs=TOL)
            theirs = gtsam_marginals(model)
            for v in names:
                np.testing.assert_allclose(model.marginal(v), theirs[v], rtol=0, atol=1e-9)


def test_a_long_run_of_evidence_does_not_underflow():
    m = Program(source="<misses>")
    m.variable("x", ["a", "b", "c"])
    m.table("x", [0.2, 0.3, 0.5])
    model = compile_program(m)
    for _ in range(2000):
        model = model.observe("x", [0.5, 0.6, 1.0])
    # P(x) ∝ prior · lik^2000, computed in log space: a = 0.2 * 0.5^2000, ...
    logs = np.log([0.2, 0.3, 0.5]) + 2000 * np.log([0.5, 0.6, 1.0])
    expect = np.exp(logs - logs.max())
    np.testing.assert_allclose(model.marginal("x"), expect / expect.sum(), rtol=0, atol=TOL)


def test_over_budget_program_is_refused_in_one_line():
    m = Program(source="big.py")
    names = [f"x{i}" for i in range(12)]
    for name in names:
        m.variable(name, list(range(8)))
    for a, b in itertools.combinations(names, 2):  # a clique: elimination width 11
        m.table([a, b], np.ones((8, 8)), name=f"{a}-{b}")
    with pytest.raises(InputError) as exc:
        compile_program(m, budget=1_000_000)
    message = str(exc.value)
    assert "\n" not in message
    assert message.startswith("big.py: inference: exact inference over x0, x1, x2")
    assert "elimination width 11" in message and "68,719,476,736 entries" in message
    assert "budget of 1,000,000" in message


def test_a_joint_query_over_budget_is_refused_while_marginals_are_answered():
    m = Program(source="chain.py")
    names = [f"x{i}" for i in range(10)]
    for name in names:
        m.variable(name, list(range(8)))
    for a, b in zip(names, names[1:]):
        m.table([a, b], np.full((8, 8), 0.5), name=f"{a}-{b}")
    model = compile_program(m, budget=10_000, dense_states=1)
    assert model.components[0].method == "elimination" and model.components[0].width == 1
    np.testing.assert_allclose(model.marginal("x5"), np.full(8, 1 / 8), rtol=0, atol=TOL)
    assert model.joint(["x0", "x3", "x6", "x9"]).shape == (8,) * 4  # 4,096 entries: within budget
    with pytest.raises(InputError, match="needs a table of 32,768 entries"):
        model.joint(["x0", "x2", "x4", "x6", "x9"])


def test_a_transition_with_a_parent_is_exact():
    rng = np.random.default_rng(11)
    for _ in range(20):
        m, evidence = random_program(rng)
        names = [v.name for v in m.variables]
        if len(names) < 2:
            continue
        child, parent = (str(x) for x in rng.choice(names, size=2, replace=False))
        cc, cp = m.var(child).card, m.var(parent).card
        step = rng.uniform(0.05, 1.0, size=(cc, cp, cc))
        joint = brute_joint(m, evidence)
        a, b = names.index(child), names.index(parent)
        # P(new child = c', rest) = sum_c P(c, rest) step(c, parent, c')
        letters = "abcdefgh"[:len(names)]
        out = letters.replace(letters[a], "z")
        moved = np.einsum(f"{letters},{letters[a]}{letters[b]}z->{out}", joint, step)
        moved /= moved.sum()
        for method in ("dense", "elimination"):
            model = compiled(m, evidence, method).transition(child, step, parents=[parent])
            for i, v in enumerate(names):
                expect = moved.sum(axis=tuple(x for x in range(len(names)) if x != i))
                np.testing.assert_allclose(model.marginal(v), expect, rtol=0, atol=TOL)
            pair = model.joint([parent, child])
            expect = moved.sum(axis=tuple(x for x in range(len(names)) if x not in (a, b)))
            np.testing.assert_allclose(pair, expect if b < a else expect.T, rtol=0, atol=TOL)


def test_auto_picks_the_dense_joint_when_elimination_would_be_as_large():
    m = Program(source="clique.py")
    for name in ("a", "b", "c"):
        m.variable(name, list(range(50)))
    rng = np.random.default_rng(3)
    m.table(["a", "b", "c"], rng.uniform(0.1, 1.0, size=(50, 50, 50)), name="abc")
    assert compile_program(m, dense_states=1000).components[0].method == "dense joint"
    m2 = Program(source="chain.py")
    for name in ("a", "b", "c", "d"):
        m2.variable(name, list(range(50)))
    for x, y in (("a", "b"), ("b", "c"), ("c", "d")):
        m2.table([x, y], rng.uniform(0.1, 1.0, size=(50, 50)), name=x + y)
    comp = compile_program(m2, dense_states=1000).components[0]
    assert (comp.method, comp.width, comp.largest) == ("elimination", 1, 2500)
