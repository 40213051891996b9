"""Objects kept together: a placement rule over several objects at once (docs/design.md §11).

A world distribution's ``placement.together`` rule draws its objects jointly, exactly, from

    P(s_1, ..., s_n) ∝ Π_i base_i(s_i) · w^[every two of the n sites within d metres] · [capacity],

where ``base_i`` is object i's own placement distribution (its affordance prior, mixed with the
violation distribution by ``prior_violation``, as for every object), ``w`` the rule's ``weight``,
``d`` its ``within`` (horizontal distance between the sites' surfaces, as
:meth:`fg_tea.model.program.SiteValue.distance` measures it; one site is 0 m from itself), and the
capacity indicator says no site holds more than its capacity, counting the objects already
placed. For three or more objects this is a relation no pairwise rule draws: an arrangement with
two of them close and the third far weighs the same as one with all of them apart. The weight and
distance are the ones a model program's factor states (``experiments/programs/kept_together.py``),
so the worlds are drawn from the program's own relation; the program's location priors are the
model's (eq. 2, with its floor) and its capacity penalty is soft, the only differences, as between
every world and its models.

The draw enumerates the K^n arrangements (at most :data:`MAX_ARRANGEMENTS`) and takes one with a
single uniform number from the world's random stream: same world seed, same arrangement.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

#: Most arrangements (K^n) a rule may enumerate.
MAX_ARRANGEMENTS = 1 << 22


@dataclass(frozen=True)
class Together:
    """Objects drawn jointly; an arrangement with every two of them within `within` metres weighs
    `weight` times one without."""

    objects: tuple[str, ...]
    within: float
    weight: float


def together_table(rule: Together, positions: Sequence[Sequence[float]], bases: Sequence[np.ndarray],
                   capacity_left: np.ndarray) -> np.ndarray:
    """The exact probabilities of the rule's arrangements: one axis per object, in rule order.

    Args:
        rule: the rule.
        positions: each site's (x, y[, z]) position in metres.
        bases: each object's placement distribution over the sites (rule order).
        capacity_left: how many more objects each site holds.

    Raises:
        ValueError: more than :data:`MAX_ARRANGEMENTS` arrangements, or none within capacity.
    """
    k, n = len(positions), len(rule.objects)
    if k ** n > MAX_ARRANGEMENTS:
        raise ValueError(f"placement.together {', '.join(rule.objects)}: {k}^{n} = {k ** n:,} arrangements, "
                         f"more than the {MAX_ARRANGEMENTS:,} it enumerates")
    grids = np.indices((k,) * n, sparse=True)
    table = np.ones((k,) * n)
    for i, base in enumerate(bases):
        table = table * np.asarray(base, dtype=float)[grids[i]]
    xy = np.array([[float(p[0]), float(p[1])] for p in positions])
    close = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1]) <= rule.within
    together = np.ones((k,) * n, dtype=bool)
    for a in range(n):
        for b in range(a + 1, n):
            together = together & close[grids[a], grids[b]]
    table = table * np.where(together, float(rule.weight), 1.0)
    for j in range(k):
        count = sum((g == j).astype(int) for g in grids)
        table = table * (count <= capacity_left[j])
    total = table.sum()
    if not total > 0:
        raise ValueError(f"placement.together {', '.join(rule.objects)}: no arrangement fits the sites' capacity")
    return table / total


def draw_together(rule: Together, positions: Sequence[Sequence[float]], bases: Sequence[np.ndarray],
                  capacity_left: np.ndarray, rng: np.random.Generator) -> tuple[int, ...]:
    """One arrangement (a site index per object, rule order) drawn exactly from :func:`together_table`."""
    table = together_table(rule, positions, bases, capacity_left)
    flat = np.cumsum(table.ravel())
    index = min(int(np.searchsorted(flat, rng.random() * flat[-1], side="right")), flat.size - 1)
    while table.ravel()[index] == 0:  # never an impossible arrangement (a rounding edge)
        index -= 1
    return tuple(int(i) for i in np.unravel_index(index, table.shape))


def check_positive(value: float) -> str | None:
    """Why `value` is not a usable weight or distance, or None."""
    if not (math.isfinite(value) and value > 0):
        return f"must be a positive finite number, got {value!r}"
    return None
