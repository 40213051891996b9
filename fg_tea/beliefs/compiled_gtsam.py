"""gtsam's DiscreteFactorGraph on a compiled program: the engine of record and the cross-check.

Builds the same graph as :class:`~fg_tea.beliefs.compiled.CompiledModel` (every factor, evidence
and transition included, tables in gtsam's order: first variable most significant) and answers
with gtsam's own algorithms: ``DiscreteMarginals`` for marginals and ``DiscreteSearch`` (gtsam
4.3's K-best search over an elimination tree) for the K best arrangements.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def gtsam_graph(model: Any, extra: list | None = None):
    """(graph, keys) for `model` (name -> (key, card)); `extra` adds (names, table) factors.

    A variable of one value is left out (its axis squeezed away: it changes no weight), because
    gtsam 4.3's decision trees report "Product factor is 0.0" for a factor over one.
    """
    import gtsam

    cards = model.cards()
    keys = {name: (i, card) for i, (name, card) in enumerate(cards.items()) if card > 1}
    graph = gtsam.DiscreteFactorGraph()
    for key in keys.values():  # every variable is in the graph, even one no factor names
        graph.add([key], [1.0] * key[1])
    for _, scope, table in list(model.factor_tables()) + [("extra", s, t) for s, t in (extra or [])]:
        table = np.asarray(table, dtype=float)
        kept = [v for v in scope if v in keys]
        table = table.reshape([cards[v] for v in kept]) if kept else table.reshape(())
        if kept:
            graph.add([keys[v] for v in kept], [float(x) for x in table.ravel()])
    return graph, keys


def _marginal(marginals: Any, keys: dict, name: str) -> np.ndarray:
    if name not in keys:
        return np.ones(1)
    p = np.asarray(marginals.marginalProbabilities(keys[name]), dtype=float)
    return p / p.sum()


def gtsam_marginals(model: Any) -> dict[str, np.ndarray]:
    """Every reported variable's marginal, by gtsam's ``DiscreteMarginals``."""
    import gtsam

    graph, keys = gtsam_graph(model)
    marginals = gtsam.DiscreteMarginals(graph)
    return {name: _marginal(marginals, keys, name) for name in model.variables}


def gtsam_hypothetical(model: Any, name: str, likelihoods: np.ndarray) -> list[dict[str, np.ndarray]]:
    """Posterior marginals under each candidate likelihood, re-solving the graph each time."""
    import gtsam

    out = []
    for lik in np.atleast_2d(likelihoods):
        graph, keys = gtsam_graph(model, [((name,), lik)])
        marginals = gtsam.DiscreteMarginals(graph)
        out.append({v: _marginal(marginals, keys, v) for v in model.variables})
    return out


def gtsam_kbest(model: Any, k: int) -> list[tuple[dict[str, int], float]]:
    """The k best (value indices, unnormalised log weight) by gtsam's ``DiscreteSearch``.

    Only for models without hidden copies (gtsam's search maximises over every variable).
    """
    import gtsam

    graph, keys = gtsam_graph(model)
    if set(keys) - set(model.variables):
        raise ValueError("gtsam_kbest: the model has hidden copies left by transitions")
    ordering = gtsam.Ordering()
    for name in keys:
        ordering.push_back(keys[name][0])
    search = gtsam.DiscreteSearch.FromFactorGraph(graph, ordering)
    solutions = search.run(K=k)
    return [({v: int(s.assignment[keys[v][0]]) if v in keys else 0 for v in model.variables}, -float(s.error))
            for s in solutions]


def gtsam_agreement(model: Any) -> float:
    """The largest difference between `model`'s marginals and gtsam's (about 1e-16 when exact)."""
    theirs = gtsam_marginals(model)
    return max((float(np.max(np.abs(model.marginal(v) - theirs[v]))) for v in model.variables), default=0.0)
