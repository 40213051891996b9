"""Where a search may be given up (docs/design.md §7.8): eq. (58) and its inverse, in one place.

With a = ``absent_probability``, the prior chance that an object a task needs cannot be found at
all, and R_o the probability that a findable object would have given the misses so far, the
chance that o can still be found is

    F_o = R_o (1 - a) / (R_o (1 - a) + a)                                          (58)

The probability rule (``give_up = "probability"``) gives a search up once R_o < p, p being
``give_up_probability``. The cost rule (``give_up = "cost"``, fg_tea/agent/give_up.py) weighs the
next look's cost against the task's value with F_o, and its safety net gives the search up
whatever the cost once F_o < p, i.e. once R_o is below :func:`findable_below`'s inverse of (58).
The task executor asks :func:`remaining_below` for the bound of either rule; the agent weighs
with :func:`findable`: one formula, read both ways here.
"""

from __future__ import annotations

import math


def findable(remaining: float, absent: float) -> float:
    """F_o of eq. (58): the chance the object can still be found, from R_o and the absence prior."""
    present = remaining * (1.0 - absent)
    return present / (present + absent) if present + absent > 0 else 0.0


def findable_below(chance: float, absent: float) -> float:
    """The R_o below which F_o < `chance`: eq. (58) solved for R_o, p a / ((1 - p) (1 - a))."""
    return chance * absent / ((1.0 - chance) * (1.0 - absent))


def remaining_below(planning) -> float:
    """The R_o below which a search is given up whatever it costs: ``give_up_probability`` under
    the probability rule, the cost rule's safety net (F_o below it) under ``give_up = "cost"``.
    `planning` is a model's :class:`~fg_tea.model.spec.PlanningWeights`."""
    p = planning.give_up_probability
    return findable_below(p, planning.absent_probability) if planning.give_up == "cost" else p


def look_budget(planning, miss_likelihood: float, sites: int) -> int | None:
    """Looks that may miss one object before its search is given up (None: no budget):
    ``max_inspections_per_object``, or if 0, K x (ceil(log p / log mu) + 1) for K `sites`."""
    if planning.max_inspections_per_object > 0:
        return planning.max_inspections_per_object
    p, mu = planning.give_up_probability, miss_likelihood
    ok = 0.0 < p < 1.0 and 0.0 < mu < 1.0
    return sites * (math.ceil(math.log(p) / math.log(mu)) + 1) if ok else None
