"""One home for the information gain of a look (fg_tea/planning/look_gain.py).

The EFE planner builds one :class:`LookGain` per decision, which picks the route the belief
allows (dense joint, structured subset program, elimination, one object, factorised) and answers
every look of the decision by it; every joint route gives the dense route's numbers.
"""

from __future__ import annotations

import numpy as np
import pytest

from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.planning import efe, look_gain
from fg_tea.planning.efe import EFEPlanner
from fg_tea.planning.look_gain import (LookGain, factorised_information_gain, joint_information_gain,
                                       view_joint_information_gain)
from test_beliefs_structured import joint_graph
from test_planning_joint_gain import _distances, _views_of


def _belief(n=4, k=8, seed=3):
    graph, model = joint_graph(n, k, rooms_of=4, seed=seed)
    belief = BeliefEngine(graph, model)
    belief.observe_site(belief.sites[1], {belief.objects[0]: False})
    return belief, model


def test_site_gains_by_every_joint_route_equal_the_dense_joint(monkeypatch):
    belief, model = _belief()
    idx = [0, 2, 3]
    dense = LookGain(belief, idx, "joint", views=False)
    assert dense.route == "dense"
    expected = joint_information_gain(belief.location_joint(), idx, model.miss_likelihood,
                                      model.false_positive_rate)
    assert np.array_equal(dense.site_gains(), expected)
    monkeypatch.setattr(look_gain, "DENSE_GAIN_LIMIT", 0)    # the subset program beyond the limit
    structured = LookGain(belief, idx, "joint", views=False)
    assert structured.route == "structured" and structured.info()["gain_solver"] == "structured"
    assert np.allclose(structured.site_gains(), expected, atol=1e-10)
    flat = LookGain(belief, idx, "factorised", views=False)
    assert flat.route == "factorised" and flat.info() == {}
    q = belief.location_matrix()[idx]
    assert np.array_equal(flat.site_gains(), factorised_information_gain(q, model.miss_likelihood))


def test_view_gains_one_object_and_structured_equal_the_dense_joint(monkeypatch):
    belief, _ = _belief()
    rng = np.random.default_rng(0)
    views = _views_of(belief, rng, twin=False)
    p_max, fp = views.max_probability, belief.model.false_positive_rate
    joint = belief.location_joint()
    one = LookGain(belief, [2], "joint", views=True)
    assert one.route == "one_object" and one.batched
    got, bound = one.view_gains(views.views, p_max)
    for c, v in enumerate(views.views):
        dense = view_joint_information_gain(joint, [2], v.sites, v.probability[[2]], fp)
        assert got[0, c] == pytest.approx(dense[0], abs=1e-10)
    assert not bound.any()
    idx = [0, 1, 3]
    dense_gains, _ = LookGain(belief, idx, "joint", views=True).view_gains(views.views, p_max)
    monkeypatch.setattr(look_gain, "DENSE_GAIN_LIMIT", 0)
    structured = LookGain(belief, idx, "joint", views=True)
    assert structured.route == "structured"
    gains, bound = structured.view_gains(views.views, p_max)
    assert np.allclose(gains, dense_gains, atol=1e-10) and not bound.any()
    # Pruning: what the caller does not need is its upper bound, flagged.
    need = np.zeros(gains.shape, dtype=bool)
    need[:, 0] = True
    pruned, bound = structured.view_gains(views.views, p_max, lambda lower, upper: need)
    assert np.array_equal(bound, ~need)
    assert np.allclose(pruned[:, 0], gains[:, 0]) and np.all(pruned[bound] >= gains[bound] - 1e-12)


def test_the_efe_planner_asks_one_look_gain_per_decision(monkeypatch):
    belief, model = _belief()
    built = []

    class Counted(LookGain):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            built.append(self.route)

    monkeypatch.setattr(efe, "LookGain", Counted)
    names = list(belief.objects)
    rng = np.random.default_rng(1)
    views = _views_of(belief, rng, twin=False)
    relevance = {o: 1.0 for o in names}
    planner = EFEPlanner(model.planning, information="joint")
    decision = planner.choose(belief, names, relevance, _distances(views.names, rng, None), {}, views=views)
    assert built == ["dense"] and decision.info["information"] == "joint"
    sites = {s: float(i) for i, s in enumerate(belief.sites)}

    class Dist:
        def from_agent(self, name):
            return sites[name]

    planner.choose(belief, names, relevance, Dist(), {})
    assert built == ["dense", "dense"]
