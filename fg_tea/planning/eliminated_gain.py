"""The exact joint information gain on beliefs answered by variable elimination (docs/design.md §4.6).

The EFE planner's joint gain (eqs. 10-11's exact form, :mod:`fg_tea.planning.efe`) reads the dense
joint P(L_U) or the subset program. A belief with extra factors beyond the dense limit has
neither, so here the gain of a look comes from the elimination method itself: for each object o
and each look, P(L_o, D_U) — o's location and every unresolved object's outcome, with the outcome
models P(D_u | L_u) as factors — is one elimination
(:meth:`~fg_tea.beliefs.eliminated.EliminatedLocationModel.outcome_joint`), and

    I(o, look) = H(L_o) + H(D_U) - H(L_o, D_U),

the same quantity :func:`~fg_tea.planning.efe.joint_information_gain` (a close look at one site)
and :func:`~fg_tea.planning.efe.view_joint_information_gain` (a look over several sites) compute
from the dense joint. One decision costs |U| eliminations per look.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from fg_tea.beliefs.eliminated import EliminationRefused
from fg_tea.beliefs.graph import DENSE_LIMIT
from fg_tea.common.errors import PlannerRefused
from fg_tea.common.stats import entropy


def eliminated_gain_model(belief):
    """The belief's elimination queries when the joint gain must come from them (the dense joint
    exceeds :data:`DENSE_LIMIT` and the belief is answered by elimination), else None."""
    model = belief.eliminated_model() if hasattr(belief, "eliminated_model") else None
    if model is None or len(belief.sites) ** len(belief.objects) <= DENSE_LIMIT:
        return None
    return model


def check_gain(model, unresolved: Sequence[int], planner: str = "efe") -> None:
    """Refuse, before a search, the joint gain of close looks whose elimination exceeds the budget.

    Raises:
        PlannerRefused: kind ``"belief"``, one line naming the planner, the table and the width.
    """
    try:
        for o in unresolved:
            model.plan.outcome_order(o, {u: 2 for u in unresolved})
    except EliminationRefused as exc:
        raise _refused(exc, planner) from None


def _refused(exc: EliminationRefused, planner: str) -> PlannerRefused:
    return PlannerRefused(f"{planner} planner: no exact joint information gain: {exc}; use information "
                          "= 'factorised'", "belief", planner)


def _outcome_joint(model, o: int, tables: dict[int, np.ndarray]) -> np.ndarray:
    try:
        return model.outcome_joint(o, tables)
    except EliminationRefused as exc:
        raise _refused(exc, "efe") from None


def _information(table: np.ndarray) -> float:
    """I(L; D) from P(L, D_1, ..., D_n), L on axis 0."""
    outcomes = tuple(range(1, table.ndim))
    return float(entropy(table.sum(axis=outcomes)) + entropy(table.sum(axis=0)) - entropy(table))


def site_information_gain(model, unresolved: Sequence[int], mu: float, fp: float) -> np.ndarray:
    """I(o, j) for a close look at every site j, shape (|U|, K): as
    :func:`~fg_tea.planning.efe.joint_information_gain` (seen at j with 1 - mu, elsewhere fp)."""
    k = model.plan.k
    out = np.empty((len(unresolved), k))
    for j in range(k):
        table = np.empty((k, 2))
        table[:, 1], table[:, 0] = fp, 1.0 - fp
        table[j, 1], table[j, 0] = 1.0 - mu, mu
        tables = {u: table for u in unresolved}
        for i, o in enumerate(unresolved):
            out[i, j] = _information(_outcome_joint(model, o, tables))
    return out


def view_information_gain(model, unresolved: Sequence[int], sites: Sequence[int], prob: np.ndarray,
                          fp: float) -> np.ndarray:
    """I(L_o; D_v) for one look over `sites`, shape (|U|,): as
    :func:`~fg_tea.planning.efe.view_joint_information_gain` (D_u = "seen at in-view site c" with
    p_{u,c} where u stands at s_c, fp per in-view site elsewhere, or "not seen")."""
    k, m = model.plan.k, len(sites)
    tables = {}
    for row, u in enumerate(unresolved):
        f = np.zeros((k, m + 1))
        f[:, 1:] = fp
        for c, s in enumerate(sites):
            f[s, 1 + c] = prob[row, c]
        f[:, 0] = 1.0 - f[:, 1:].sum(axis=1)
        tables[u] = np.clip(f, 0.0, 1.0)
    return np.array([_information(_outcome_joint(model, o, tables)) for o in unresolved])


__all__ = ["check_gain", "eliminated_gain_model", "site_information_gain", "view_information_gain"]
