"""Planning interface: which object-site inspection is worth doing next? (docs/design.md §6)

A search policy is "inspect semantic site j for object o" (eqs. 8, 9). Every planner answers the
same question through one pure function,

    Planner.choose(belief, objects, relevance, distances, inspected, excluded_sites) -> Decision

and never writes the belief: only inference does (``BeliefEngine.observe_site``). Randomness comes
only from a ``numpy.random.Generator`` handed to a planner at construction.

The pieces defined here:

- :class:`DistanceModel` — travel distance in metres from the agent to a site's vantage point
  (d_j of eq. 12) and between two vantage points. The environment supplies geodesic distances on
  its occupancy grid; :func:`euclidean_distances` builds straight-line ones from the scenario's
  vantage coordinates (the Euclidean ablation, docs/design.md §11).
- :class:`Candidate` — one scored (object, site) pair with every term of eqs. 12 and 16.
- :class:`Decision` — the argmin of eq. 17 with all candidates, ready for the episode log.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Collection, Mapping, Protocol, Sequence, runtime_checkable

import numpy as np

from fg_tea.world.scenario import Scenario


# ---------------------------------------------------------------------------------- distances
@runtime_checkable
class DistanceModel(Protocol):
    """Travel distances in metres between the agent, and between sites' vantage points."""

    def from_agent(self, site: str) -> float:
        """Metres from the agent's current position to `site`'s vantage point (d_j, eq. 12)."""
        ...

    def between(self, a: str, b: str) -> float:
        """Metres from the vantage point of site `a` to that of site `b`."""
        ...


@dataclass(frozen=True)
class DistanceTable:
    """A :class:`DistanceModel` held as numbers: one row from the agent, one matrix between sites.

    Attributes:
        sites: site names, the order of `agent` and of both axes of `matrix`.
        agent: shape (K,), metres from the agent to each site's vantage point.
        matrix: shape (K, K), metres between vantage points (zero diagonal).
        kind: how the numbers were made, ``"euclidean"`` or ``"geodesic"`` (for the log).
    """

    sites: tuple[str, ...]
    agent: tuple[float, ...]
    matrix: tuple[tuple[float, ...], ...]
    kind: str = "euclidean"
    _index: Mapping[str, int] = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        k = len(self.sites)
        if len(self.agent) != k or len(self.matrix) != k or any(len(r) != k for r in self.matrix):
            raise ValueError(f"distance table for {k} sites needs {k} agent distances and a "
                             f"{k} x {k} matrix")
        values = list(self.agent) + [x for r in self.matrix for x in r]
        if any(not math.isfinite(x) or x < 0 for x in values):
            raise ValueError("distances must be finite and non-negative (metres)")
        object.__setattr__(self, "_index", {s: i for i, s in enumerate(self.sites)})

    def _i(self, site: str) -> int:
        try:
            return self._index[site]
        except KeyError:
            raise KeyError(f"no distances for site {site!r} (known: {', '.join(self.sites)})") from None

    def from_agent(self, site: str) -> float:
        return self.agent[self._i(site)]

    def between(self, a: str, b: str) -> float:
        return self.matrix[self._i(a)][self._i(b)]

    def matrix_for(self, sites: Sequence[str]) -> np.ndarray:
        """Metres between every two of `sites`, shape (K, K), zero diagonal."""
        idx = [self._i(s) for s in sites]
        out = np.asarray(self.matrix, dtype=float)[np.ix_(idx, idx)]
        np.fill_diagonal(out, 0.0)
        return out

    def moved_to(self, site: str) -> "DistanceTable":
        """The same house with the agent standing at `site`'s vantage point."""
        return DistanceTable(self.sites, self.matrix[self._i(site)], self.matrix, self.kind)


def euclidean_distances(scenario: Scenario, agent_xy: Sequence[float]) -> DistanceTable:
    """Straight-line distances between the agent and every viewpoint's floor point (docs/design.md §11).

    Args:
        scenario: the house; only viewpoint coordinates (site and room vantages) are read.
        agent_xy: the agent's floor position (x, y) in metres.

    Returns:
        A :class:`DistanceTable` of kind ``"euclidean"``.
    """
    viewpoints = scenario.viewpoints  # every site's close vantage, then the room vantages
    pts = np.array([v.position for v in viewpoints], dtype=float)  # (K + R, 2)
    agent = np.asarray(agent_xy, dtype=float).reshape(2)
    to_agent = np.linalg.norm(pts - agent[None, :], axis=1)
    matrix = np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=2)
    return DistanceTable(tuple(v.name for v in viewpoints), tuple(float(x) for x in to_agent),
                         tuple(tuple(float(x) for x in row) for row in matrix), "euclidean")


def distance_vector(distances: DistanceModel, sites: Sequence[str]) -> np.ndarray:
    """d_j for each site in `sites`, shape (K,), metres."""
    return np.array([float(distances.from_agent(s)) for s in sites])


def distance_matrix(distances: DistanceModel, sites: Sequence[str]) -> np.ndarray:
    """Vantage-to-vantage distances, shape (K, K), metres, zero diagonal.

    A distance model may offer the whole matrix at once, ``matrix_for(sites)`` (the episode's
    holds it for the episode, since the floor plan does not change); otherwise it is asked pair
    by pair. Do not write into the result: it may be the model's own cached copy.
    """
    whole = getattr(distances, "matrix_for", None)
    if whole is not None:
        return np.asarray(whole(sites), dtype=float)
    return np.array([[float(distances.between(a, b)) if a != b else 0.0 for b in sites] for a in sites])


# ---------------------------------------------------------------------------------- decisions
@dataclass(frozen=True)
class Candidate:
    """One scored inspection "look from `viewpoint` for `object`" (eqs. 12, 16).

    Attributes:
        object: the object whose belief and relevance are scored.
        viewpoint: where to look from: a site's name (its close look) or a room vantage.
        distance: d_j, metres from the agent to the viewpoint's floor point.
        probability: q(L_o = j) in [0, 1] for a close look; for a viewpoint scored over what it
            sees, the chance the look finds o relative to a clear close look (docs/design.md,
            "Planning over viewpoints").
        information_gain: I(o, j) in nats (eq. 11, or the joint form of :mod:`.efe`).
        repeat: how many times `viewpoint` was already looked from with negative evidence in this
            search.
        relevance: r_o in [0, 1] (eq. 15).
        base: G_base(o, j) of eq. 12 (planners that are not EFE put their own score here).
        total: the score the planner minimises (eq. 16 for EFE); lower is better.
        kind: ``"site"`` (close look) or ``"room"`` (room glance).
        gain_bound: True when `information_gain` is an upper bound on the gain, not the gain
            (an EFE candidate pruned exactly, docs/design.md §6.2); then `base` and `total`
            are lower bounds on the scores, and above the chosen candidate's.
    """

    object: str
    viewpoint: str
    distance: float
    probability: float
    information_gain: float
    repeat: int
    relevance: float
    base: float
    total: float
    kind: str = "site"
    gain_bound: bool = False

    def to_json(self) -> dict:
        return {"object": self.object, "viewpoint": self.viewpoint,
                "viewpoint_kind": self.kind, "distance": float(self.distance),
                "probability": float(self.probability),
                "information_gain": float(self.information_gain), "repeat": int(self.repeat),
                "relevance": float(self.relevance), "base": float(self.base),
                "total": float(self.total)} | ({"information_gain_bound": "upper"}
                                               if self.gain_bound else {})


@dataclass(frozen=True)
class Decision:
    """The chosen inspection (eq. 17) and every candidate that competed for it.

    Attributes:
        object: the chosen object o*.
        viewpoint: the chosen viewpoint j* (a site's name for its close look, or a room vantage).
        total: the chosen candidate's score.
        candidates: every candidate, objects in the caller's order, then sites in belief order.
        planner: the planner's registry name.
        info: planner-specific scalars for the log (weights, expected cost...).
    """

    object: str
    viewpoint: str
    total: float
    candidates: tuple[Candidate, ...]
    planner: str
    info: Mapping[str, float | str] = field(default_factory=dict)

    @property
    def chosen(self) -> Candidate:
        for c in self.candidates:
            if c.object == self.object and c.viewpoint == self.viewpoint:
                return c
        raise LookupError(f"decision ({self.object}, {self.viewpoint}) is not among its candidates")

    @property
    def kind(self) -> str:
        """``"site"`` (close look) or ``"room"`` (room glance)."""
        return self.chosen.kind

    def to_json(self) -> dict:
        """A JSON-serialisable record: the choice, planner info and every candidate with every term."""
        return {"planner": self.planner, "object": self.object,
                "viewpoint": self.viewpoint, "viewpoint_kind": self.kind,
                "total": float(self.total), "info": dict(self.info),
                "candidates": [c.to_json() for c in self.candidates]}


@runtime_checkable
class Planner(Protocol):
    """Chooses the next inspection; a pure function of its inputs (no belief mutation).

    This is the whole contract a planner of your own must meet (plug it in by entry point or
    ``module:attribute``, :mod:`fg_tea.planning.plugins`). The runner calls :meth:`choose` once
    before every look of a SEARCH action (docs/design.md §6.1), always with the six positional
    arguments; ``views`` is passed by keyword only when the model searches over viewpoints (room
    glances and the visibility detector, docs/design.md §5), so ``choose`` must accept it.

    What ``choose`` may read: the belief through its query methods (``location``,
    ``location_map``, ``sites``, ``objects``, ``hypothetical``, ``hypothetical_all``, ``state``...);
    distances through ``distances.from_agent(site)`` and ``distances.between(a, b)`` (metres);
    ``views.names``, ``views.view(name)`` and ``views.probabilities(name)`` when given. It must
    not call the belief's update methods (``observe_site``, ``observe_viewpoint``, ``observe_state``,
    ``apply_effects``); only inference writes beliefs. Randomness must come from a Generator the
    planner was built with (a plug-in factory that names ``rng`` receives one seeded from the
    episode seed), so that the same seed gives the same log.

    What it must return: a :class:`Decision` whose (``object``, ``site``) is one of its
    ``candidates``; ``object`` is in `objects`, ``site`` is a site name of ``belief.sites`` (a
    close look) or, when `views` is given, any of ``views.names``, and not in `excluded_sites`.
    ``planner`` is the name written to the decision event; ``info`` holds extra scalars for the
    log. Candidates need every field of :class:`Candidate` (put your own score in ``base`` and
    ``total``; lower is better by convention, but the runner only reads the chosen pair), and no
    number of a decision may be NaN. :func:`accept_decision` checks all of this for every decision:
    ``TypeError`` for anything that is not a :class:`Decision`, ``ValueError`` for a choice outside
    its candidates, no candidates, a NaN, or a viewpoint or object it does not know; ``fg-tea run``
    and ``compare`` report either in one line, with exit status 2.

    Attributes:
        name: the planner's name, as written to the log (built-in planners: their registry
            name). Optional for plug-ins, which are logged under the spec that named them.
    """

    name: str

    def check(self, belief, objects: Sequence[str]) -> None:
        """Refuse, before the first decision, a problem this planner cannot plan for.

        Called once per episode, by the agent, with the prior belief and the objects the task
        searches for; the CLI and the sweeps call the same method before any episode starts.
        Planners without limits do nothing (:class:`PlannerBase`); a plug-in without a ``check``
        method is given this no-op when it is loaded.

        Raises:
            fg_tea.PlannerRefused: with ``kind`` ``"size"`` or ``"belief"``.
        """
        ...

    def choose(self, belief, objects: Sequence[str], relevance: Mapping[str, float],
               distances: DistanceModel, inspected: Mapping[str, int],
               excluded_sites: frozenset[str] = frozenset(), views=None) -> Decision:
        """Pick the next (object, viewpoint).

        Args:
            belief: a :class:`~fg_tea.beliefs.engine.BeliefEngine` (read only).
            objects: the unresolved objects on the task frontier, in priority order of ties.
            relevance: object -> r_o in [0, 1] (eq. 15) for every object in `objects`.
            distances: travel distances from the agent's current position (metres).
            inspected: site -> times inspected with negative evidence in the current search.
            excluded_sites: sites and viewpoints that must not be chosen (e.g. unreachable).
            views: the agent's :class:`~fg_tea.beliefs.detection.ViewModel` (viewpoints and
                detection probabilities), or None for one close look per site with the
                threshold detector. Planners that search by site may choose only close looks.

        Returns:
            The :class:`Decision`.
        """
        ...


class PlannerBase:
    """What every built-in planner shares: no limit to check unless it says otherwise."""

    name: str = "planner"

    def check(self, belief, objects: Sequence[str]) -> None:
        """No limit (see :meth:`Planner.check`)."""
        return None


def parse_settings(family: str, spec: str, kinds: Mapping[str, type]) -> dict:
    """``"key=value,..."`` of a planner family spec (``lookahead:depth=3``) as typed values.

    Raises:
        ValueError: an unknown key, a key given twice, a malformed pair or a value of the wrong
            type, each naming the family.
    """
    values: dict = {}
    for part in filter(None, (p.strip() for p in spec.split(","))):
        key, sep, raw = part.partition("=")
        key = key.strip()
        if not sep or key not in kinds:
            raise ValueError(f"{family}: bad setting {part!r} (known keys: {', '.join(kinds)})")
        if key in values:
            raise ValueError(f"{family}: {key} is given twice in {spec!r}; give it once")
        try:
            values[key] = kinds[key](raw.strip())
        except ValueError:
            raise ValueError(f"{family}: {key} must be {kinds[key].__name__}, got {raw!r}") from None
    return values


# ---------------------------------------------------------------------------------- accepting a decision
#: Candidate fields that must be numbers (NaN is refused: the log cannot hold it).
_NUMBER_FIELDS = ("distance", "probability", "information_gain", "relevance", "base", "total")


def _nan(value) -> bool:
    try:
        return math.isnan(float(value))
    except (TypeError, ValueError):
        return True  # not a number at all: refused with the NaNs


def accept_decision(decision, planner: str, viewpoints: Collection[str],
                    objects: Sequence[str]) -> Decision:
    """`decision` if it keeps the :class:`Planner` contract; else an error naming `planner`.

    The one place a decision is checked before it is used or logged (the agent calls it for every
    decision of every planner, built-in or plug-in: ``fg-tea run``, ``compare`` and
    :class:`fg_tea.Agent` alike).

    Args:
        decision: what ``choose`` returned.
        planner: the planner's name or spec, for the message.
        viewpoints: the viewpoints the house has (site names, then room vantages).
        objects: the objects the planner was asked about.

    Raises:
        TypeError: not a :class:`Decision`, or a candidate that is not a :class:`Candidate`.
        ValueError: no candidates; the chosen (object, viewpoint) not among them; an object not
            asked about or a viewpoint the house does not have; a NaN (or non-number) total,
            candidate term or ``info`` value.
    """
    who = f"planner {planner!r}"
    if not isinstance(decision, Decision):
        raise TypeError(f"{who} returned a {type(decision).__name__}, not a fg_tea.planning.Decision")
    if not isinstance(decision.candidates, tuple | list) or not decision.candidates:
        raise ValueError(f"{who} returned a decision with no candidates (it must list the "
                         "candidate it chose, at least)")
    for i, c in enumerate(decision.candidates):
        if not isinstance(c, Candidate):
            raise TypeError(f"{who}: candidate {i} is a {type(c).__name__}, not a "
                            "fg_tea.planning.Candidate")
        bad = next((f for f in _NUMBER_FIELDS if _nan(getattr(c, f))), None)
        if bad is not None:
            raise ValueError(f"{who}: candidate ({c.object}, {c.viewpoint}) has a NaN {bad} "
                             f"({getattr(c, bad)!r}); every term must be a number")
    if not any(c.object == decision.object and c.viewpoint == decision.viewpoint
               for c in decision.candidates):
        raise ValueError(f"{who} chose ({decision.object}, {decision.viewpoint}), which is not "
                         f"among its {len(decision.candidates)} candidates")
    if _nan(decision.total):
        raise ValueError(f"{who} returned a decision with a NaN total ({decision.total!r})")
    if decision.object not in objects:
        raise ValueError(f"{who} chose object {decision.object!r}, which is not one it was asked "
                         f"about ({', '.join(objects)})")
    if decision.viewpoint not in viewpoints:
        raise ValueError(f"{who} chose viewpoint {decision.viewpoint!r}, which this house does not "
                         f"have (known: {', '.join(viewpoints)})")
    for key, value in dict(decision.info).items():
        if isinstance(value, float) and math.isnan(value):
            raise ValueError(f"{who}: decision info {key!r} is NaN")
    return decision


def call_planner(planner: str, method, *args, **kwargs):
    """``method(*args, **kwargs)`` of a planner, with an exit of its own made an error.

    ``Exception`` and ``SystemExit`` pass as they are (the episode runner reports both);
    a ``KeyboardInterrupt`` stays an interrupt. Any other ``BaseException`` a plug-in raises
    would end the program unreported; it becomes a ``RuntimeError`` naming `planner`.
    """
    try:
        return method(*args, **kwargs)
    except (Exception, SystemExit, KeyboardInterrupt):
        raise
    except BaseException as exc:
        first = (str(exc).splitlines() or [""])[0]
        raise RuntimeError(f"planner {planner!r} raised {type(exc).__name__}"
                           + (f": {first}" if first else "")) from exc


# ---------------------------------------------------------------------------------- shared checks
def check_inputs(belief, objects: Sequence[str], relevance: Mapping[str, float],
                 excluded_sites: frozenset[str], views=None) -> tuple[list[int], list[int]]:
    """Validate a planner call; return object indices (caller's order) and eligible site indices.

    Raises:
        ValueError: no objects, an unknown or repeated object, a missing or out-of-range
            relevance, an unknown excluded site, or every site excluded.
    """
    if not objects:
        raise ValueError("planner: no unresolved objects to search for")
    known = list(belief.objects)
    if len(set(objects)) != len(objects):
        raise ValueError(f"planner: objects repeated in {list(objects)}")
    obj_idx = []
    for o in objects:
        if o not in known:
            raise ValueError(f"planner: unknown object {o!r} (known: {', '.join(known)})")
        if o not in relevance:
            raise ValueError(f"planner: no relevance r_o given for object {o!r}")
        r = float(relevance[o])
        if not 0.0 <= r <= 1.0:
            raise ValueError(f"planner: relevance of {o!r} is {r}, outside [0, 1] (eq. 15)")
        obj_idx.append(known.index(o))
    sites = list(belief.sites)
    viewpoints = set(views.names) if views is not None else set()
    for s in excluded_sites:
        if s not in sites and s not in viewpoints:
            raise ValueError(f"planner: unknown excluded site {s!r}")
    eligible = [j for j, s in enumerate(sites) if s not in excluded_sites]
    if not eligible:
        raise ValueError("planner: every site is excluded")
    return obj_idx, eligible


def repeat_counts(inspected: Mapping[str, int], sites: Sequence[str]) -> np.ndarray:
    """Negative inspections per site so far, shape (K,), integers >= 0."""
    counts = np.array([int(inspected.get(s, 0)) for s in sites])
    if np.any(counts < 0):
        raise ValueError("planner: inspection counts must be non-negative")
    return counts


def most_relevant(objects: Sequence[str], relevance: Mapping[str, float]) -> str:
    """The object with the largest r_o; ties go to the first in `objects`."""
    best = objects[0]
    for o in objects[1:]:
        if float(relevance[o]) > float(relevance[best]):
            best = o
    return best


__all__ = ["DistanceModel", "DistanceTable", "euclidean_distances", "distance_vector",
           "distance_matrix", "Candidate", "Decision", "Planner", "PlannerBase", "check_inputs",
           "repeat_counts", "most_relevant", "accept_decision", "call_planner"]
