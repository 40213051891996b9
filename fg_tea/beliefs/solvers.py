"""Exact solvers over a list of :class:`~fg_tea.beliefs.factors.Factor`: gtsam, numpy, brute force.

All three answer the same questions — marginals, a joint over a few variables, and summing a set
of variables out of a graph — and must agree to 1e-9 (tests check it):

- :class:`GtsamSolver` is the engine of record: a ``gtsam.DiscreteFactorGraph`` solved with
  ``DiscreteMarginals`` (multifrontal elimination) and ``eliminatePartialSequential``.
- :class:`NumpySolver` contracts the factor tables densely with ``einsum``; fast on small graphs.
- :func:`brute_force_marginals` enumerates every assignment; the reference in tests.
"""

from __future__ import annotations

import itertools
from typing import Iterable, Mapping, Sequence

import numpy as np

from fg_tea.beliefs.factors import Factor
from fg_tea.common.errors import ContradictionError


def _variables(factors: Iterable[Factor]) -> list[str]:
    return list(dict.fromkeys(v for f in factors for v in f.variables))


def _zero_evidence(exc: RuntimeError, what: str) -> Exception:
    """Turn gtsam's "product factor is 0" error into a ContradictionError; keep others."""
    if "is 0" in str(exc) or "zero" in str(exc).lower():
        return ContradictionError(f"evidence has probability zero under the model ({what}): {exc}")
    return exc


def _normalise(table: np.ndarray, what: str) -> np.ndarray:
    total = float(table.sum())
    if not np.isfinite(total) or total <= 0.0:
        raise ContradictionError(f"evidence has probability zero under the model ({what})")
    return table / total


class NumpySolver:
    """Dense exact contraction of factor tables with ``numpy.einsum``."""

    name = "numpy"

    def joint(self, factors: Sequence[Factor], variables: Sequence[str],
              cards: Mapping[str, int]) -> np.ndarray:
        """P(variables) ∝ sum over the other variables of the product of `factors` (normalised)."""
        table = self.contract(factors, variables, cards)
        return _normalise(table, ", ".join(variables))

    def contract(self, factors: Sequence[Factor], keep: Sequence[str],
                 cards: Mapping[str, int]) -> np.ndarray:
        """The unnormalised product of `factors`, summed over every variable not in `keep`."""
        index = {v: i for i, v in enumerate(dict.fromkeys(list(keep) + _variables(factors)))}
        operands: list = []
        for f in factors:
            operands += [f.table, [index[v] for v in f.variables]]
        # Variables in `keep` that no factor mentions are uniform.
        for v in keep:
            if not any(v in f.variables for f in factors):
                operands += [np.ones(cards[v]), [index[v]]]
        if not operands:
            return np.ones(())
        return np.einsum(*operands, [index[v] for v in keep], optimize="greedy")

    def marginals(self, factors: Sequence[Factor], variables: Sequence[str],
                  cards: Mapping[str, int]) -> dict[str, np.ndarray]:
        every = _variables(factors)
        joint = self.joint(factors, every, cards)
        out = {}
        for v in variables:
            axes = tuple(i for i, w in enumerate(every) if w != v)
            out[v] = joint.sum(axis=axes) if v in every else np.full(cards[v], 1.0 / cards[v])
        return out

    def sum_out(self, factors: Sequence[Factor], eliminate: Sequence[str],
                cards: Mapping[str, int], label: str) -> Factor:
        keep = [v for v in _variables(factors) if v not in set(eliminate)]
        table = self.contract(factors, keep, cards)
        return Factor(tuple(keep), _normalise(table, label), label)


class GtsamSolver:
    """The gtsam discrete module as the exact engine of record.

    Args:
        keys: variable name -> integer gtsam key (built with ``gtsam.symbol``).
    """

    name = "gtsam"

    def __init__(self, keys: Mapping[str, int]) -> None:
        import gtsam

        self._gtsam = gtsam
        self.keys = keys

    def graph(self, factors: Sequence[Factor], cards: Mapping[str, int]):
        g = self._gtsam.DiscreteFactorGraph()
        for f in factors:
            dkeys = [(self.keys[v], cards[v]) for v in f.variables]
            g.add(dkeys, [float(x) for x in f.table.ravel()])
        return g

    def marginals(self, factors: Sequence[Factor], variables: Sequence[str],
                  cards: Mapping[str, int]) -> dict[str, np.ndarray]:
        present = set(_variables(factors))
        g = self.graph(factors, cards)
        if any(float(np.max(f.table)) <= 0 for f in factors):
            raise ContradictionError("a factor is zero everywhere")
        try:
            marg = self._gtsam.DiscreteMarginals(g)
        except RuntimeError as exc:
            raise _zero_evidence(exc, "marginals") from exc
        out = {}
        for v in variables:
            if v not in present:
                out[v] = np.full(cards[v], 1.0 / cards[v])
                continue
            p = np.asarray(marg.marginalProbabilities((self.keys[v], cards[v])), dtype=float)
            if not np.all(np.isfinite(p)) or p.sum() <= 0:
                raise ContradictionError(f"evidence has probability zero under the model ({v})")
            out[v] = p / p.sum()
        return out

    def joint(self, factors: Sequence[Factor], variables: Sequence[str],
              cards: Mapping[str, int]) -> np.ndarray:
        rest = [v for v in _variables(factors) if v not in set(variables)]
        reduced = self.sum_out(factors, rest, cards, "joint") if rest else None
        kept = [reduced] if reduced is not None else list(factors)
        return NumpySolver().joint(kept, variables, cards)

    def sum_out(self, factors: Sequence[Factor], eliminate: Sequence[str],
                cards: Mapping[str, int], label: str) -> Factor:
        """Eliminate `eliminate` with gtsam; the product of what remains, as one table."""
        gtsam = self._gtsam
        g = self.graph(factors, cards)
        keep = [v for v in _variables(factors) if v not in set(eliminate)]
        if eliminate:
            ordering = gtsam.Ordering()
            for v in eliminate:
                ordering.push_back(self.keys[v])
            try:
                _, remaining = g.eliminatePartialSequential(ordering)
            except RuntimeError as exc:
                raise _zero_evidence(exc, label) from exc
        else:
            remaining = g
        table = np.zeros([cards[v] for v in keep])
        product = remaining.product()
        for assignment in itertools.product(*(range(cards[v]) for v in keep)):
            values = gtsam.DiscreteValues()
            for v, x in zip(keep, assignment):
                values[self.keys[v]] = x
            table[assignment] = product(values)
        return Factor(tuple(keep), _normalise(table, label), label)

    def map_assignment(self, factors: Sequence[Factor], cards: Mapping[str, int]) -> dict[str, int]:
        """The most probable joint assignment (max-product elimination)."""
        try:
            values = self.graph(factors, cards).optimize()
        except RuntimeError as exc:
            raise _zero_evidence(exc, "most probable assignment") from exc
        return {v: int(values[self.keys[v]]) for v in _variables(factors)}


def brute_force_marginals(factors: Sequence[Factor], cards: Mapping[str, int]) -> dict[str, np.ndarray]:
    """Marginals by enumerating every joint assignment (exponential; for tests on small graphs)."""
    every = _variables(factors)
    sums = {v: np.zeros(cards[v]) for v in every}
    for assignment in itertools.product(*(range(cards[v]) for v in every)):
        value = dict(zip(every, assignment))
        weight = 1.0
        for f in factors:
            weight *= f.table[tuple(value[v] for v in f.variables)]
        for v, x in value.items():
            sums[v][x] += weight
    return {v: _normalise(s, v) for v, s in sums.items()}
