"""Learned transitions: how often does an action's effect really happen, given what the agent saw?

This module answers *what success probability should an action's effect have, given the state
readings of the episodes the agent lived through?* (docs/design.md §12.5, eqs. 61-63). Each effect
of a transition (``boil``'s ``{object}.water_hot``) is one row with an unknown success probability
theta and a Beta prior Beta(S_t p0, S_t (1 - p0)) centred on the declared success p0, with S_t =
``transition_strength`` pseudo-trials.

A reading is not the state (the sensor is noisy, eqs. 23-24), so an episode does not give a count
of successes and failures: it gives a likelihood of theta. That likelihood is exactly a mixture

    (61)  P(readings of episode e | theta) = sum_t w_t theta^{s_t} (1 - theta)^{f_t}

over the numbers (s_t, f_t) of successes and failures of the row's *trials* (an action of that
transition, reported done, whose effect's requirements held and whose target did not already have
the value: the only case where theta matters, eq. 27), with weights w_t from a forward pass over the
agent's own model (:mod:`fg_tea.study.transition_counts`). The product of a Beta prior and such
mixtures is a mixture of Betas, so the posterior is exact:

    (62)  q(theta | logs) = sum_t W_t Beta(theta; a + s_t, b + f_t),
          W_t ∝ w_t B(a + s_t, b + f_t) / B(a, b),   a = S_t p0, b = S_t (1 - p0)

and the success the belief uses is its mean,

    (63)  theta_hat = sum_t W_t (a + s_t) / (a + b + s_t + f_t).

A mixture is held as its terms ``(successes, failures, log weight)``; the terms of two episodes
multiply (:func:`combine`). When every trial's outcome is certain from the readings, a mixture has
one term and eq. (63) is the Beta posterior mean of eq. (52). Forgetting (eq. 53) multiplies every
term's successes and failures by gamma.

Agent side: nothing here imports the simulator.
"""

from __future__ import annotations

import math
from dataclasses import replace
from types import MappingProxyType
from typing import Any, Mapping, Sequence

import numpy as np

from fg_tea.common.errors import InputError

#: Pseudo-trials S_t of a declared effect success (eq. 62): five, the same rule as the location
#: prior's S (eq. 50): the declared figure is worth as much as five observed trials. Not tuned.
DEFAULT_TRANSITION_STRENGTH = 5.0
#: A mixture: (successes, failures, log weight) per term.
Terms = tuple[tuple[float, float, float], ...]
#: Terms whose weight is below exp(-TERM_FLOOR) of the largest are dropped (they move eq. 63 by
#: less than 1e-30 of the posterior).
TERM_FLOOR = 70.0


def row_key(transition: str, effect: int) -> str:
    """The key of an effect's row: ``boil.effect0`` (transition name, effect position)."""
    return f"{transition}.effect{effect}"


def normalised(terms: Mapping[tuple[float, float], float] | Sequence[tuple[float, float, float]]) -> Terms:
    """Terms merged on (successes, failures) (log-sum-exp), the largest log weight 0, sorted."""
    items = terms.items() if isinstance(terms, Mapping) else (((s, f), w) for s, f, w in terms)
    merged: dict[tuple[float, float], float] = {}
    for (s, f), w in items:
        merged[(s, f)] = np.logaddexp(merged[(s, f)], w) if (s, f) in merged else float(w)
    if not merged:
        return ()
    top = max(merged.values())
    return tuple((float(s), float(f), round(float(w - top), 12)) for (s, f), w in sorted(merged.items())
                 if w - top > -TERM_FLOOR)


def combine(a: Terms, b: Terms) -> Terms:
    """The mixture of a product of two likelihoods (eq. 61 of two episodes); () is the constant 1."""
    if not a:
        return b
    if not b:
        return a
    out: dict[tuple[float, float], float] = {}
    for s1, f1, w1 in a:
        for s2, f2, w2 in b:
            key = (s1 + s2, f1 + f2)
            out[key] = np.logaddexp(out[key], w1 + w2) if key in out else w1 + w2
    return normalised(out)


def scaled(terms: Terms, gamma: float) -> Terms:
    """Forgetting (eq. 53): every term's successes and failures times gamma."""
    return terms if gamma == 1.0 else normalised([(s * gamma, f * gamma, w) for s, f, w in terms])


def is_constant(terms: Terms) -> bool:
    """True when the mixture does not depend on theta (the readings said nothing about the row)."""
    if not terms:
        return True
    grid = np.linspace(0.02, 0.98, 49)
    values = [float(np.sum(np.exp([w + s * math.log(x) + f * math.log1p(-x) for s, f, w in terms])))
              for x in grid]
    return max(values) - min(values) <= 1e-9 * max(values)


def _weights(prior: float, strength: float, terms: Terms) -> tuple[np.ndarray, float, float]:
    from scipy.special import betaln

    a, b = strength * prior, strength * (1.0 - prior)
    if not terms:
        return np.ones(1), a, b
    s = np.array([t[0] for t in terms])
    f = np.array([t[1] for t in terms])
    logw = np.array([t[2] for t in terms]) + betaln(a + s, b + f)
    w = np.exp(logw - logw.max())
    return w / w.sum(), a, b


def posterior_mean(prior: float, strength: float, terms: Terms) -> float:
    """Eq. (63): the posterior mean of theta (the declared `prior` when there are no terms)."""
    if not terms:
        return float(prior)
    w, a, b = _weights(prior, strength, terms)
    s = np.array([t[0] for t in terms])
    f = np.array([t[1] for t in terms])
    return float(np.sum(w * (a + s) / (a + b + s + f)))


def expected_counts(prior: float, strength: float, terms: Terms) -> tuple[float, float]:
    """The posterior expectation of the successes and failures observed (eq. 62's weights)."""
    if not terms:
        return 0.0, 0.0
    w, _, _ = _weights(prior, strength, terms)
    return float(sum(wi * t[0] for wi, t in zip(w, terms))), float(sum(wi * t[1] for wi, t in zip(w, terms)))


def interval(prior: float, strength: float, terms: Terms, level: float = 0.95) -> tuple[float, float]:
    """The central `level` interval of eq. (62)'s mixture (its CDF solved by bisection)."""
    from scipy.optimize import brentq
    from scipy.special import betainc

    w, a, b = _weights(prior, strength, terms)
    parts = [(t[0], t[1]) for t in terms] or [(0.0, 0.0)]

    def cdf(x: float) -> float:
        return float(sum(wi * betainc(a + s, b + f, x) for wi, (s, f) in zip(w, parts)))

    lo_q, hi_q = (1 - level) / 2, (1 + level) / 2
    return (float(brentq(lambda x: cdf(x) - lo_q, 0.0, 1.0, xtol=1e-10)),
            float(brentq(lambda x: cdf(x) - hi_q, 0.0, 1.0, xtol=1e-10)))


def read_transition_counts(r: Any) -> dict[str, dict[str, Any]]:
    """``[learning.transitions.<name>.effect<k>]`` tables: ``state`` (the effect's state template,
    checked against the model) and ``terms`` ([successes, failures, log weight] per term)."""
    out: dict[str, dict[str, Any]] = {}
    table = r.child("transitions", required=False)
    if table is None:
        return out
    for name in table.names():
        per = table.child(name)
        for key in per.names():
            if not key.startswith("effect") or not key[6:].isdigit():
                raise per.fail("expected effect<k>, the effect's position in the transition", key)
            row = per.child(key)
            state = row.req("state", str)
            terms = []
            for i, term in enumerate(row.req("terms", list)):
                if (not isinstance(term, list) or len(term) != 3
                        or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in term)
                        or not all(math.isfinite(x) for x in term) or term[0] < 0 or term[1] < 0
                        or term[2] > 0):
                    raise InputError(row.file, f"{row.path}.terms[{i}]", "expected [successes >= 0, "
                                     "failures >= 0, log weight <= 0]")
                terms.append((float(term[0]), float(term[1]), float(term[2])))
            out[row_key(name, int(key[6:]))] = {"state": state, "terms": normalised(terms)}
    return out


def apply_to_transitions(counts: Mapping[str, Mapping[str, Any]], strength: float,
                         transitions: Mapping[str, Any], r: Any) -> Mapping[str, Any]:
    """The model's transitions with eq. (63) as the success of every effect that has terms.

    Raises:
        InputError: the counts name a transition or effect the model does not declare, or an
            effect whose state template differs from the model's.
    """
    if not counts:
        return transitions
    out = dict(transitions)
    for key, row in counts.items():
        name, _, effect = key.rpartition(".effect")
        where = f"{r.path}.transitions.{name}.effect{effect}"
        spec = out.get(name)
        k = int(effect)
        if spec is None or k >= len(spec.effects):
            raise InputError(r.file, where, f"the model declares no transition {name!r} with an effect {k}")
        declared = transitions[name].effects[k]
        if declared.state != row["state"]:
            raise InputError(r.file, where, f"counted for state {row['state']!r}, but the model's "
                             f"effect {k} of {name!r} sets {declared.state!r}")
        if not row["terms"]:
            continue
        learned = posterior_mean(declared.success, strength, row["terms"])
        effects = list(spec.effects)
        effects[k] = replace(declared, success=learned)
        out[name] = replace(spec, effects=tuple(effects))
    return MappingProxyType(out)


def _is_term(t: Any) -> bool:
    """[successes >= 0, failures >= 0, log weight <= 0], finite numbers."""
    return (isinstance(t, (list, tuple)) and len(t) == 3
            and all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in t)
            and t[0] >= 0 and t[1] >= 0 and t[2] <= 0)


def with_transition_terms(model: Any, rows: Any, strength: Any, source: str = "<learned>") -> Any:
    """`model` with eq. (63) as the success of every effect in `rows` (docs/design.md §12.5): a
    learned program's ``transition_terms`` (``{"boil.effect0": {"state": template, "terms":
    [[successes, failures, log weight], ...]}}``), applied by
    :func:`fg_tea.model.learned_transitions.apply_to_transitions`; the declared transitions are kept
    in ``declared_transitions``.

    Raises:
        InputError: a malformed row, a strength that is not positive, or a row naming a transition
            or effect the model does not declare (one line naming `source` and the row).
    """
    from types import SimpleNamespace

    if isinstance(strength, bool) or not isinstance(strength, (int, float)) or not (
            math.isfinite(strength) and strength > 0):
        raise InputError(source, "transition_strength", f"expected a positive number, got {strength!r}")
    if not isinstance(rows, Mapping):
        raise InputError(source, "transition_terms",
                         "expected a mapping of effect rows (boil.effect0 = {state, terms})")
    counts = {}
    for key, row in rows.items():
        name, dot, effect = str(key).rpartition(".effect")
        terms = row.get("terms") if isinstance(row, Mapping) else None
        if not (dot and name and effect.isdigit() and isinstance(row.get("state"), str)
                and isinstance(terms, (list, tuple)) and all(map(_is_term, terms))):
            raise InputError(source, f"transition_terms[{key!r}]", "expected <transition>.effect<k> = {state: "
                             "the effect's template, terms: [[successes >= 0, failures >= 0, log weight <= 0], "
                             "...]}")
        counts[key] = {"state": row["state"],
                       "terms": normalised([(float(t[0]), float(t[1]), float(t[2])) for t in terms])}
    declared = model.declared_transitions if model.declared_transitions is not None else model.transitions
    learned = apply_to_transitions(counts, float(strength), declared, SimpleNamespace(file=source, path="$"))
    return replace(model, transitions=learned, declared_transitions=declared)


__all__ = ["DEFAULT_TRANSITION_STRENGTH", "apply_to_transitions", "combine", "expected_counts",
           "interval", "is_constant", "normalised", "posterior_mean", "read_transition_counts",
           "row_key", "scaled", "with_transition_terms"]
