"""Hypothetical posteriors of a compiled program: what each candidate observation would make of
every variable, without changing the belief (docs/design.md §4.8).

An observation touches one variable x, so for any variable y

    P(y | l_c) = sum_x P(x, y) l_c(x) / sum_x P(x) l_c(x),

read from the pairwise joint P(x, y): the product of the two marginals when x and y are in
different components (then y's posterior is its prior), one contraction of the component's
dense table for all candidates and variables at once, or an elimination per pair otherwise.
:func:`hypothetical_many` answers several observed variables in one call, each with its own
candidates, and reports only the variables asked for; ``CompiledModel.hypothetical`` and
``CompiledModel.hypothetical_many`` call it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from fg_tea.common.errors import InputError


@dataclass(frozen=True)
class Hypothetical:
    """Posteriors under each of C candidate likelihoods on one variable.

    Attributes:
        probability: (C,) the probability of each candidate's evidence, sum_x P(x) l_c(x).
        marginals: variable name -> (C, values) posterior marginals; rows of candidates whose
            evidence has probability zero are NaN.
    """

    probability: np.ndarray
    marginals: dict[str, np.ndarray]


def hypothetical_many(model: Any, likelihoods: Mapping[str, Any],
                      report: Sequence[str] | None = None) -> dict[str, Hypothetical]:
    """Posterior marginals of the `report` variables (default: every variable) under each
    candidate likelihood on each observed variable (observed name -> (C, values) or (values,)),
    for `model`, a :class:`fg_tea.beliefs.compiled.CompiledModel`.

    Raises:
        InputError: an unknown variable, or likelihoods that are not finite, non-negative and
            of shape (C, values).
    """
    shown = list(model.variables if report is None else report)
    ids = [model._id(n) for n in shown]
    prior = {i: model._marginal_id(i) for i in ids}
    answers: dict[str, Hypothetical] = {}
    for name, likelihood in likelihoods.items():
        x = model._id(name)
        lik = _checked(model, name, x, likelihood)
        p = prior[x] if x in prior else model._marginal_id(x)
        prob = lik @ p
        possible = prob > 0
        scale = (1.0 / np.where(possible, prob, 1.0))[:, None]
        comp = model._component_of[x]
        out = _same_component(model, comp, x, lik, [i for i in ids if i != x], scale)
        out[x] = lik * p * scale
        marginals: dict[str, np.ndarray] = {}
        for n, i in zip(shown, ids):
            table = out[i] if i in out else np.repeat(prior[i][None, :], len(prob), axis=0)
            if not possible.all():
                table[~possible] = np.nan  # evidence the program rules out: no posterior
            marginals[n] = table
        answers[name] = Hypothetical(prob, marginals)
    return answers


def _checked(model: Any, name: str, x: int, likelihood: Any) -> np.ndarray:
    lik = np.atleast_2d(np.asarray(likelihood, dtype=float))
    card = model._cards[x]
    if lik.ndim != 2 or lik.shape[1] != card or not np.isfinite(lik).all() or (lik < 0).any():
        raise InputError(model.source, f"hypothetical {name!r}",
                         f"likelihoods must be finite, non-negative, shape (C, {card})")
    return lik


def _same_component(model: Any, comp: Any, x: int, lik: np.ndarray, others: list[int],
                    scale: np.ndarray) -> dict[int, np.ndarray]:
    """The posteriors of the `others` that share x's component (the rest keep their prior)."""
    mine = [i for i in others if i in comp.ids]
    if not mine:
        return {}
    out: dict[int, np.ndarray] = {}
    if comp.method == "dense joint":
        full, axes = model._dense_prob(comp)            # reported variables' joint, their ids
        weighted = np.tensordot(lik, full, axes=([1], [axes.index(x)]))  # (C, other axes...)
        rest = [i for i in axes if i != x]
        for a, i in enumerate(rest):
            if i in mine:
                out[i] = weighted.sum(axis=tuple(b + 1 for b in range(len(rest)) if b != a)) * scale
        return out
    with np.errstate(invalid="ignore"):
        for i in mine:
            out[i] = (lik @ model._joint_ids([x, i])) * scale
    return out


__all__ = ["Hypothetical", "hypothetical_many"]
