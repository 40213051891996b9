"""Vectorised factor functions: one call over every assignment of a scope (docs/design.md §4.8).

With ``vectorised=True`` a factor function is called once, with one array per scope variable,
broadcast against each other over the scope's assignments (axis i belongs to the i-th variable):

- a location gets a :class:`SiteArray` (``.name``, ``.room``, ``.furniture``, ``.capacity``,
  ``.position``, ``.index`` as arrays, ``.distance(...)``, and ``==`` between two locations meaning
  "the same site");
- a state gets a bool array; a variable of one's own an array of its values (numbers stay
  numeric, anything else is an object array, so ``weather == "wet"`` works elementwise).

The function must return weights broadcastable to the scope's shape; the result is checked as a
table (finite, non-negative, not all zero) exactly like a looped function's.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np


class SiteArray:
    """The values of a location variable over a vectorised factor's assignments.

    Attributes:
        index: int array, the site's position in the scenario's site order.
    """

    def __init__(self, sites: Sequence[Any], index: np.ndarray) -> None:
        self._sites = tuple(sites)
        self.index = index

    def _take(self, attribute: str) -> np.ndarray:
        return np.array([getattr(s, attribute) for s in self._sites], dtype=object)[self.index]

    @property
    def name(self) -> np.ndarray:
        """Site names (object array)."""
        return self._take("name")

    @property
    def room(self) -> np.ndarray:
        """Rooms (object array)."""
        return self._take("room")

    @property
    def furniture(self) -> np.ndarray:
        """Furniture names, None where a site has none (object array)."""
        return self._take("furniture")

    @property
    def capacity(self) -> np.ndarray:
        """Capacities as floats, ``inf`` where unlimited."""
        caps = np.array([math.inf if s.capacity is None else float(s.capacity) for s in self._sites])
        return caps[self.index]

    @property
    def position(self) -> np.ndarray:
        """Surface positions, shape (..., 3), metres."""
        return np.array([s.position for s in self._sites], dtype=float)[self.index]

    def distance(self, other: Any) -> np.ndarray:
        """Horizontal distance (m) to a site, to another location's sites, or to an (x, y) point."""
        here = self.position[..., :2]
        if isinstance(other, SiteArray):
            there = other.position[..., :2]
        elif hasattr(other, "position"):
            there = np.asarray(other.position[:2], dtype=float)
        else:
            there = np.asarray(tuple(other)[:2], dtype=float)
        return np.hypot(here[..., 0] - there[..., 0], here[..., 1] - there[..., 1])

    def __eq__(self, other: object) -> Any:  # "the same site", elementwise
        if isinstance(other, SiteArray):
            return self.index == other.index
        if hasattr(other, "index") and hasattr(other, "room"):
            return self.index == getattr(other, "index")
        return self.name == other

    def __ne__(self, other: object) -> Any:
        return np.logical_not(self.__eq__(other))

    __hash__ = None  # type: ignore[assignment]


def arguments(variables: Sequence[Any]) -> list[Any]:
    """One broadcastable array per variable (axis i for the i-th), as a vectorised function gets."""
    grids = np.indices(tuple(v.card for v in variables), sparse=True)
    out: list[Any] = []
    for v, grid in zip(variables, grids):
        if v.kind == "location":
            out.append(SiteArray(v.values, grid))
        elif v.kind == "state":
            out.append(grid.astype(bool))
        else:
            values = np.array(v.values)
            if values.dtype.kind not in "biuf":
                values = np.array(v.values, dtype=object)
            out.append(values[grid])
    return out


def broadcast_weights(result: Any, shape: tuple[int, ...]) -> np.ndarray | str:
    """`result` as a float table of `shape`, or a one-line reason it is not one."""
    try:
        table = np.asarray(result, dtype=float)
    except (TypeError, ValueError) as exc:
        return f"returned weights that are not numbers ({exc})"
    try:
        return np.array(np.broadcast_to(table, shape), dtype=float)
    except ValueError:
        return f"returned weights of shape {table.shape}, not broadcastable to {shape}"
