"""The clairvoyant yardstick: how short could the search have been, had the truth been known?

A yardstick that exists in every house, however large (docs/design.md §11): the shortest route
from the agent's start pose that looks from viewpoints which, between them, see every searched
object where it truly stood at the start. It is a metric for evaluating an episode after it
ends — the world truth it needs is known only to the environment — and is never given to a
planner.

**Which looks "see" an object.** A viewpoint v sees object o when o's true start site is one of
the sites in view of v and v is one of the viewpoints the episode's model may look from: a close
look at o's site always; a room glance covering o's site only when the model searches with room
glances (``[viewpoints] room_glances``). Detection is taken as perfect from every such viewpoint
(as in the Bayes-optimal search of eq. (43)), so the route is a lower bound on the travel of any
search that looks only from those viewpoints, however lucky its detector.

**Which distances.** The length of each leg is the length of the path the agent would actually
walk (the navigator's string-pulled path, the same measure as the logged ``distance`` of an
observation and so as ``search_distance``), not the planner's grid estimate d_j, which runs 5-20 %
longer; a yardstick in the planner's units could be longer than the route the agent walks along
it.

**Solved exactly** by Dijkstra's algorithm over the states (objects seen so far, viewpoint
standing at): at most 2^N · M states for N searched objects and M viewpoints that see one of
them (M <= N close looks plus the glances covering their sites), so a few thousand at N = 8.
Moving through a viewpoint that sees nothing new is allowed, so the answer is exact even where
walked path lengths break the triangle inequality.

**What it does not bound.** Search travel (``search_distance``) sums the walks to each look;
practical actions between searches (carrying the mug to the preparation site...) move the agent
too, and that travel is not search travel. A later search may therefore start nearer its object
than the clairvoyant route does, and an episode's search travel can fall below the clairvoyant
route; SPL (:func:`spl`) then saturates at 1.
"""

from __future__ import annotations

import heapq
import math
from typing import Callable, Mapping, Sequence


def sees_table(viewpoints: Sequence[Mapping], true_sites: Mapping[str, str | None],
               objects: Sequence[str]) -> dict[str, tuple[str, ...]]:
    """Which searched objects each viewpoint would see, given where they truly stand.

    Args:
        viewpoints: the episode's viewpoints as logged (``{"name", "sites", ...}``), in order.
        true_sites: object -> its true start site (None: on no site).
        objects: the searched objects.

    Returns:
        viewpoint name -> the objects (in `objects` order) standing at a site in its view; only
        viewpoints that see at least one object are listed, in `viewpoints` order.
    """
    out: dict[str, tuple[str, ...]] = {}
    for v in viewpoints:
        in_view = set(v["sites"])
        seen = tuple(o for o in objects if true_sites.get(o) in in_view)
        if seen:
            out[str(v["name"])] = seen
    return out


def clairvoyant_route(objects: Sequence[str], sees: Mapping[str, Sequence[str]],
                      from_start: Callable[[str], float], between: Callable[[str, str], float],
                      positions: Mapping[str, Sequence[float]] | None = None,
                      start_xy: Sequence[float] | None = None) -> tuple[float, tuple[str, ...]] | None:
    """The shortest route from the start through viewpoints that together see every object.

    Dijkstra's algorithm over (objects seen, viewpoint), with lazily evaluated legs: given floor
    positions, a leg first enters the queue at its straight-line length (never more than the
    walked length) and is walked (``from_start``/``between`` called) only when it reaches the
    front, so most legs of a large house are never computed. The answer is the same either way.

    Args:
        objects: the searched objects (N of them; the state space is 2^N times the viewpoints).
        sees: viewpoint -> the objects it sees (from :func:`sees_table`).
        from_start: metres walked from the start pose to a viewpoint (inf if unreachable).
        between: metres walked from viewpoint a to viewpoint b (inf if unreachable).
        positions: viewpoint -> its floor point (x, y) in metres, for the straight-line bounds.
        start_xy: the start floor point (x, y) in metres; both or neither with `positions`.

    Returns:
        (metres, viewpoints in visiting order), or None when some object is seen from no
        reachable viewpoint. With no objects, (0.0, ()).
    """
    index = {o: i for i, o in enumerate(objects)}
    full = (1 << len(objects)) - 1
    if full == 0:
        return 0.0, ()
    names = list(sees)
    masks = [sum(1 << index[o] for o in sees[v] if o in index) for v in names]
    xy: list[tuple[float, ...]] = []
    start_pt: tuple[float, ...] = ()
    lazy = positions is not None and start_xy is not None
    if positions is not None and start_xy is not None:
        xy = [tuple(map(float, positions[v][:2])) for v in names]
        start_pt = tuple(map(float, start_xy[:2]))
    START = -1
    walked: dict[tuple[int, int], float] = {}

    def leg(a: int, b: int) -> float:
        if (a, b) not in walked:
            walked[(a, b)] = float(from_start(names[b]) if a == START else between(names[a], names[b]))
        return walked[(a, b)]

    def bound(a: int, b: int) -> float:
        if not lazy:
            return leg(a, b)
        p = start_pt if a == START else xy[a]
        return math.hypot(xy[b][0] - p[0], xy[b][1] - p[1])

    best: dict[tuple[int, int], float] = {}
    parent: dict[tuple[int, int], tuple[int, int] | None] = {}
    # Entries: (cost, mask, viewpoint, exact, previous mask, previous viewpoint). An inexact
    # entry's cost is a lower bound: its previous cost plus the straight-line leg.
    heap: list[tuple[float, int, int, bool, int, int]] = []
    for v in range(len(names)):
        heapq.heappush(heap, (bound(START, v), masks[v], v, not lazy, 0, START))
    while heap:
        d, mask, v, exact, pmask, pv = heapq.heappop(heap)
        state = (mask, v)
        if not exact:
            base = 0.0 if pv == START else best[(pmask, pv)]
            d = base + leg(pv, v)
            if math.isfinite(d) and d < best.get(state, math.inf):
                best[state], parent[state] = d, (None if pv == START else (pmask, pv))
                heapq.heappush(heap, (d, mask, v, True, pmask, pv))
            continue
        if pv == START and not lazy:
            if not math.isfinite(d) or d >= best.get(state, math.inf):
                continue
            best[state], parent[state] = d, None
        if d > best.get(state, math.inf):
            continue
        if mask == full:
            route = []
            node: tuple[int, int] | None = state
            while node is not None:
                route.append(names[node[1]])
                node = parent[node]
            return d, tuple(reversed(route))
        for u in range(len(names)):
            if u == v:
                continue
            nxt = (mask | masks[u], u)
            if lazy:
                lb = d + bound(v, u)
                if lb < best.get(nxt, math.inf):
                    heapq.heappush(heap, (lb, nxt[0], u, False, mask, v))
                continue
            du = d + leg(v, u)
            if math.isfinite(du) and du < best.get(nxt, math.inf):
                best[nxt], parent[nxt] = du, state
                heapq.heappush(heap, (du, nxt[0], u, True, mask, v))
    return None


def clairvoyant_report(viewpoints: Sequence[Mapping], true_sites: Mapping[str, str | None],
                       objects: Sequence[str], from_start: Callable[[str], float],
                       between: Callable[[str, str], float],
                       start_xy: Sequence[float] | None = None) -> dict:
    """The record the episode log carries in ``episode_end.yardstick``.

    Args:
        viewpoints: the episode's viewpoints as logged (``name``, ``sites``, ``position``).
        true_sites: object -> its true start site.
        objects: the searched objects.
        from_start, between: walked metres, as for :func:`clairvoyant_route`.
        start_xy: the start floor point; given, legs are walked lazily (same answer, faster).

    Returns:
        ``{"clairvoyant_search_travel": metres or None, "route": [viewpoints], "sees": {object:
        [viewpoints that see it]}, "distance": "walked", "detection": "perfect"}``.
    """
    sees = sees_table(viewpoints, true_sites, objects)
    positions = {str(v["name"]): v["position"] for v in viewpoints} if start_xy is not None else None
    found = clairvoyant_route(objects, sees, from_start, between, positions, start_xy)
    by_object = {o: [v for v, seen in sees.items() if o in seen] for o in objects}
    return {"clairvoyant_search_travel": None if found is None else found[0],
            "route": [] if found is None else list(found[1]), "sees": by_object,
            "distance": "walked", "detection": "perfect"}


def spl(search_found_all: bool, search_travel: float, clairvoyant: float | None) -> float | None:
    """Success weighted by (inverse normalised) path length, for search.

    ``clairvoyant / max(search_travel, clairvoyant)`` when every searched object was found, 0
    when one was not, None when the yardstick is unknown (an old log). 1 when both are 0.

    Args:
        search_found_all: every searched object was found (the search succeeded).
        search_travel: metres walked to look (``search_distance``).
        clairvoyant: the clairvoyant route's length in metres, or None.
    """
    if clairvoyant is None:
        return None
    if not search_found_all:
        return 0.0
    longest = max(float(search_travel), float(clairvoyant))
    return 1.0 if longest <= 0.0 else float(clairvoyant) / longest


__all__ = ["sees_table", "clairvoyant_route", "clairvoyant_report", "spl"]
