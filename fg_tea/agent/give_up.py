"""A give-up that weighs the cost (docs/design.md §7.8, ``[planning] give_up = "cost"``).

The probability rule ends a search once the misses are improbable enough; it never asks what one
more look would cost against what the task is worth, so two misses at the right site can end the
task. This rule asks exactly that. With a = ``absent_probability``, the prior chance that an object
a task needs cannot be found at all (not in the house, out of reach), and R_o the probability that
a findable object would have given the misses so far (eq. 2's prior through eqs. 5-6), the chance
that o can still be found is

    F_o = R_o (1 - a) / (R_o (1 - a) + a),

and a look from viewpoint v finds it with probability F_o sum_j q(L_o = j) p_{o,j}(v), q being the
belief given that o is findable. The search for o goes on while the best look's cost (travel plus
the look cost per image) divided by that chance is at most the value of finishing the task,
``task_value`` sweeps of the house; a sweep is the nearest-neighbour walk from the start through
every viewpoint, so the value scales with the house and is fixed before any look. Eq. (58)
and the safety net's bound, its inverse, live in :mod:`fg_tea.model.give_up`.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from fg_tea.model.give_up import findable
from fg_tea.planning.base import DistanceModel
from fg_tea.planning.problem import LOOK_COST


def sweep_length(names: Sequence[str], distances: DistanceModel) -> float:
    """Metres of the nearest-neighbour walk from the agent through every viewpoint in `names`."""
    left = list(names)
    if not left:
        return 0.0
    here = min(left, key=lambda v: (distances.from_agent(v), v))
    total = distances.from_agent(here)
    left.remove(here)
    while left:
        nxt = min(left, key=lambda v: (distances.between(here, v), v))
        total += distances.between(here, nxt)
        left.remove(nxt)
        here = nxt
    return total


def weigh(belief, obj: str, views, distances: DistanceModel, excluded: frozenset[str],
          remaining: float, absent: float, value: float) -> dict:
    """The best next look for `obj` and what it costs per chance of finding it.

    Returns:
        ``findable`` (F_o), ``viewpoint`` (the look of least cost per find), ``cost`` (its travel
        and look cost, m), ``chance`` (its chance of finding o), ``cost_per_find`` (m; inf when no
        look can find o), ``value`` (m) and ``give_up`` (cost_per_find > value).
    """
    chance_findable = findable(remaining, absent)
    q = np.asarray(belief.marginal(obj), dtype=float)
    index = list(belief.objects).index(obj)
    best = (np.inf, None, 0.0, 0.0)
    for name in views.names:
        if name in excluded:
            continue
        view = views.view(name)
        chance = chance_findable * float(np.dot(q[list(view.sites)], view.probability[index]))
        if chance <= 0:
            continue
        cost = float(distances.from_agent(name)) + LOOK_COST * len(view.sites)
        if cost / chance < best[0]:
            best = (cost / chance, name, cost, chance)
    per_find, viewpoint, cost, chance = best
    return {"object": obj, "findable": chance_findable, "viewpoint": viewpoint, "cost": cost,
            "chance": chance, "cost_per_find": per_find, "value": value,
            "give_up": bool(per_find > value)}


def probability_rule(executor, planning) -> tuple[str, dict, str] | None:
    """The search the probability rule gives up, as (object, outlook, why), or None: the first
    searched object whose R_o is below :func:`~fg_tea.model.give_up.remaining_below` (under the
    cost rule, its safety net) or whose look budget is spent (docs/design.md §7.8). Asked before
    a SEARCH is marked active, whichever rule the model gives up by."""
    budget = executor.search_budget()
    for obj in executor.pending_search_objects():
        outlook = executor.search_outlook(obj)
        remaining = outlook["remaining_probability"]
        low = remaining is not None and remaining < outlook["threshold"]
        if not low and (budget is None or outlook["looks"] < budget):
            continue
        if not low:
            return obj, outlook, f"search budget of {budget} looks spent"
        why = f"remaining probability {remaining:.3g} < {outlook['threshold']:.3g}"
        if planning.give_up == "cost":
            why += " (the safety net of the cost rule)"
        return obj, outlook, why
    return None
