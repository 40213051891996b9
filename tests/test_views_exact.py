"""Looks from viewpoints stay exact: multi-site evidence and the information gain of a glance.

A room glance adds, for every considered object, a miss factor over every site in view
(l(a) = 1 - p_{o,a}) or a detection at the site seen (docs/design.md eq. 30). These tests check
the engine against the independent brute-force reference of ``test_beliefs_exact`` after chains
of such looks (both backends, both positive-update modes), and the exact mutual information of a
look's joint outcome against enumeration of every outcome.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fg_tea.beliefs.detection import View
from fg_tea.beliefs.factors import Factor
from fg_tea.common.errors import ContradictionError
from fg_tea.planning.efe import (entropies, factorised_information_gain,
    view_factorised_information_gain, view_joint_information_gain)
from test_beliefs_exact import Reference, assert_agrees, engine_for, model_for, problems

SETTINGS = settings(max_examples=20, derandomize=True, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


@st.composite
def looks(draw, p):
    """A chain of looks: random sites in view, random p_{o,j}, random outcomes per object."""
    k, n = len(p.sites), len(p.objects)
    chain = []
    for _ in range(draw(st.integers(1, 4))):
        sites = tuple(sorted(draw(st.lists(st.integers(0, k - 1), min_size=1, max_size=min(3, k),
                                           unique=True))))
        prob = np.array([[draw(st.floats(0.0, 0.97)) for _ in sites] for _ in range(n)])
        found = {}
        for o in range(n):
            outcome = draw(st.sampled_from(["miss", "miss", "none"] + ["seen"] * len(sites)))
            if outcome == "miss":
                found[p.objects[o]] = None
            elif outcome == "seen":
                c = draw(st.integers(0, len(sites) - 1))
                if prob[o, c] > 0:
                    found[p.objects[o]] = p.sites[sites[c]]
        view = View("glance", "room", "room0", sites, prob, 1.0 - prob, np.full(prob.shape, np.nan))
        chain.append((view, found))
    return chain


def reference_look(ref: Reference, view: View, found: dict) -> None:
    """The same look written out by hand on the brute-force reference."""
    p, model = ref.p, ref.model
    k = len(p.sites)
    for o, obj in enumerate(p.objects):                   # misses first: 1 - p on every in-view site
        if obj in found and found[obj] is None:
            table = np.ones(k)
            for c, j in enumerate(view.sites):
                table[j] = 1.0 - view.probability[o, c]
            ref.loc_factors.append(Factor((ref.var(obj),), table))
    seen = [(o, obj, p.sites.index(found[obj])) for o, obj in enumerate(p.objects)
            if found.get(obj) is not None]
    if model.positive_update != "collapse":
        for o, obj, j in seen:
            pj = view.probability[o, view.sites.index(j)]
            table = np.array([pj if i == j else model.false_positive_rate for i in range(k)])
            ref.loc_factors.append(Factor((ref.var(obj),), table))
        return
    # then eq. 4 for every seen object at once (eq. 32a): Jeffrey's rule in sweeps until every
    # seen marginal is its target (iterative proportional fitting)
    eps = model.prior_floor
    targets = {o: np.array([1.0 if i == j else eps for i in range(k)]) for o, _, j in seen}
    targets = {o: t / t.sum() for o, t in targets.items()}
    for _ in range(500):
        for o, obj, _ in seen:
            q = ref.locations()[o]
            ref.loc_factors.append(Factor((ref.var(obj),), targets[o] / q))
        locs = ref.locations()
        if not seen or max(np.abs(locs[o] - targets[o]).max() for o, _, _ in seen) <= 1e-13:
            break


def check_look_chain(engine, ref, chain) -> None:
    """Apply each (view, found) look to the engine and the brute-force reference; they agree after
    every look. Evidence of probability zero leaves the belief unchanged; the reference skips it."""
    for view, found in chain:
        before = engine.location_matrix()
        try:
            engine.observe_viewpoint(view, found)
        except ContradictionError:
            np.testing.assert_array_equal(engine.location_matrix(), before)
            continue
        reference_look(ref, view, found)
        assert_agrees(engine, ref)


@pytest.mark.parametrize("backend, solver", [("numpy", "auto"), ("numpy", "structured"),
                                             ("gtsam", "auto")])
@SETTINGS
@given(data=st.data())
def test_glances_match_brute_force(data, backend, solver):
    p = data.draw(problems(max_objects=3, max_sites=5))
    model = model_for(p)
    engine = engine_for(p, model, backend, solver)
    ref = Reference(p, model)
    check_look_chain(engine, ref, data.draw(looks(p)))


@pytest.mark.parametrize("backend", ["numpy", "gtsam"])
@SETTINGS
@given(data=st.data())
def test_factorised_glances_match_brute_force(data, backend):
    """The same chains of glances on factorised beliefs (independent locations, no relations)."""
    import dataclasses
    from pathlib import Path

    from fg_tea.model.spec import load_model

    p = dataclasses.replace(data.draw(problems(max_objects=3, max_sites=5)), relations=())
    factorised = load_model(Path(__file__).resolve().parents[1] / "models" / "factorised.toml")
    model = factorised.with_overrides(positive_update=p.positive_update, false_positive_rate=p.fp)
    assert model.structure == "factorised"
    engine = engine_for(p, model, backend)
    assert not engine.correlated
    ref = Reference(p, model)
    check_look_chain(engine, ref, data.draw(looks(p)))


def brute_force_view_gain(joint, unresolved, sites, prob, fp):
    """I(L_o; D) by listing every joint outcome d of the look (object by object)."""
    k, n, m = joint.shape[0], len(unresolved), len(sites)
    others = tuple(a for a in range(joint.ndim) if a not in unresolved)
    p_u = joint.sum(axis=others) if others else joint
    order = sorted(unresolved)
    p_u = np.transpose(p_u, [order.index(u) for u in unresolved])

    def lik(u, d, a):
        seen = [fp] * m
        if a in sites:
            seen[sites.index(a)] = prob[u, sites.index(a)]
        return 1.0 - sum(seen) if d == 0 else seen[d - 1]

    out = []
    for o in range(n):
        p_od = np.zeros((k,) + (m + 1,) * n)
        for locs in itertools.product(range(k), repeat=n):
            w = p_u[locs]
            if w == 0:
                continue
            for d in itertools.product(range(m + 1), repeat=n):
                p_od[(locs[o],) + d] += w * np.prod([lik(u, d[u], locs[u]) for u in range(n)])
        h_o = entropies(p_od.sum(axis=tuple(range(1, n + 1))))
        h_d = entropies(p_od.sum(axis=0).ravel())
        out.append(h_o + h_d - entropies(p_od.ravel()))
    return np.array(out)


@settings(max_examples=25, derandomize=True, deadline=None)
@given(data=st.data())
def test_view_gain_equals_enumeration_of_every_outcome(data):
    n_all = data.draw(st.integers(1, 3))
    k = data.draw(st.integers(2, 4))
    raw = np.array(data.draw(st.lists(st.floats(0.0, 1.0), min_size=k ** n_all, max_size=k ** n_all)))
    raw[0] += 1e-3
    joint = (raw / raw.sum()).reshape((k,) * n_all)
    unresolved = data.draw(st.permutations(range(n_all)))[:data.draw(st.integers(1, n_all))]
    sites = sorted(data.draw(st.lists(st.integers(0, k - 1), min_size=1, max_size=k, unique=True)))
    prob = np.array([[data.draw(st.floats(0.0, 0.99)) for _ in sites] for _ in unresolved])
    fp = data.draw(st.sampled_from([0.0, 1e-4, 0.01]))
    got = view_joint_information_gain(joint, unresolved, sites, prob, fp)
    want = brute_force_view_gain(joint, list(unresolved), sites, prob, fp)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)


def test_close_look_gain_reduces_to_eqs_10_11():
    rng = np.random.default_rng(0)
    q = rng.dirichlet(np.ones(6), size=3)
    mu = 0.05
    want = factorised_information_gain(q, mu)
    for j in range(6):
        prob = np.zeros((3, 6))
        prob[:, j] = 1.0 - mu
        miss = np.ones((3, 6))
        miss[:, j] = mu
        find, gain = view_factorised_information_gain(q, prob, miss, 1.0 - mu)
        np.testing.assert_allclose(find, q[:, j], rtol=0, atol=1e-15)
        np.testing.assert_allclose(gain, want[:, j], rtol=0, atol=1e-12)


def test_a_blurry_glance_is_worth_less_than_a_sharp_one():
    # The same sites in view: lowering p lowers both the chance of finding and the information.
    q = np.array([[0.4, 0.3, 0.2, 0.1]])
    sharp, blurry = np.zeros((1, 4)), np.zeros((1, 4))
    sharp[0, :2], blurry[0, :2] = 0.9, 0.2
    f_sharp, g_sharp = view_factorised_information_gain(q, sharp, 1 - sharp, 0.95)
    f_blurry, g_blurry = view_factorised_information_gain(q, blurry, 1 - blurry, 0.95)
    assert f_blurry[0] < f_sharp[0] and g_blurry[0] < g_sharp[0]
    joint = q[0]
    i_sharp = view_joint_information_gain(joint, [0], [0, 1], sharp[:, :2], 0.0)
    i_blurry = view_joint_information_gain(joint, [0], [0, 1], blurry[:, :2], 0.0)
    assert i_blurry[0] < i_sharp[0]


def test_the_old_name_of_a_viewpoint_look_warns_and_gives_the_same_update():
    """``observe_view`` is the deprecated name of ``observe_viewpoint`` (CHANGELOG.md)."""
    import pytest

    import fg_tea as fg
    from fg_tea.beliefs.detection import ViewModel
    from fg_tea.beliefs.engine import BeliefEngine

    scenario, model = fg.load_scenario("default_apartment"), fg.load_model("factorised_close")
    view = ViewModel(scenario, model).view(scenario.site_names[0])
    found = {o: None for o in scenario.object_names}
    new = BeliefEngine(scenario, model).observe_viewpoint(view, found)
    with pytest.warns(DeprecationWarning, match="observe_viewpoint"):
        old = BeliefEngine(scenario, model).observe_view(view, found)
    assert old.viewpoint == new.viewpoint == view.name
    assert all(np.array_equal(old.after[o], new.after[o]) for o in new.after)
