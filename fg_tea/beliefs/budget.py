"""The budget of exact inference over a program, and its one-line refusal (docs/design.md §4.8).

A program whose exact inference would build a table above :data:`BUDGET` entries is refused, in
one line naming its variables, the elimination width and the table size, before any table is
built. The compiler (:mod:`fg_tea.beliefs.compiled`) and the belief engine's graph
(:func:`fg_tea.beliefs.graph.graph_from_program`, which sums the program's own variables out)
both refuse here, with the same cost model: a min-fill order
(:func:`~fg_tea.beliefs.elimination.min_fill_order`) priced by
:func:`~fg_tea.beliefs.elimination.order_cost`.

:func:`sum_out_program_variables` is that sum-out: each connected group of factors over variables
the task never reads, with those variables eliminated exactly in log space along the priced order.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from fg_tea.beliefs.elimination import LogFactor, log_product, min_fill_order, order_cost, sum_out
from fg_tea.common.errors import InputError

#: Largest table (entries) exact inference may build; above it a program is refused.
BUDGET = 50_000_000
#: Most variable names a refusal lists (the rest are counted).
SHOWN = 12


def refusal(source: str, names: Sequence[str], width: int, size: int, how: str,
            budget: int = BUDGET, path: str = "inference") -> InputError:
    """The one-line refusal of exact inference over `names` by `how`: the table of `size` entries
    it needs and the elimination width, against `budget`."""
    shown = ", ".join(names[:SHOWN]) + (f" and {len(names) - SHOWN} more" if len(names) > SHOWN else "")
    return InputError(source, path,
                      f"exact inference over {shown} by {how} needs a table of {size:,} entries "
                      f"(elimination width {width}), above the budget of {budget:,}; "
                      "refused (no approximation is made)")


def priced_order(scopes: Sequence[Sequence[int]], eliminate: Sequence[int], keep: Sequence[int],
                 cards: Mapping[int, int]) -> tuple[list[int], int, int]:
    """The min-fill order eliminating `eliminate` and its (induced width, largest table), which
    the caller compares with the budget before building anything."""
    order = min_fill_order(scopes, eliminate, cards)
    width, largest = order_cost(scopes, order, keep, cards)
    return order, width, largest


def sum_out_group(source: str, path: str, label: str, factors: Sequence[tuple[Sequence[str], np.ndarray]],
                  eliminate: Sequence[str], keep: Sequence[str], cards: Mapping[str, int],
                  budget: int = BUDGET) -> np.ndarray:
    """The product of `factors` (scope names, non-negative table) with `eliminate` summed out,
    as a table over `keep` (in that order) scaled to a maximum of 1.

    Raises:
        InputError: at `path` of `source`: the elimination would build a table above `budget`
            (checked before any table is built), or the sum is zero everywhere.
    """
    names = list(dict.fromkeys([*keep, *eliminate, *(s for scope, _ in factors for s in scope)]))
    ids = {n: i for i, n in enumerate(names)}
    by_id = {ids[n]: cards[n] for n in names}
    scopes = [tuple(ids[s] for s in scope) for scope, _ in factors]
    keep_ids = [ids[s] for s in keep]
    order, width, largest = priced_order(scopes, [ids[s] for s in eliminate], keep_ids, by_id)
    if largest > budget:
        raise refusal(source, names, width, largest, "summing out the program's own variables", budget, path)
    logs: list[LogFactor] = []
    with np.errstate(divide="ignore"):
        for scope, (_, table) in zip(scopes, factors):
            logs.append((scope, np.log(np.asarray(table, dtype=float))))
    log = log_product(sum_out(logs, order, by_id), keep_ids, by_id)
    top = np.max(log) if log.size else -np.inf
    if not np.isfinite(top):
        raise InputError(source, path, f"summing out {label} gives zero everywhere (the program is impossible)")
    return np.exp(log - top)


__all__ = ["BUDGET", "priced_order", "refusal", "sum_out_group"]
