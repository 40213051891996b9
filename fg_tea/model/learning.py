"""Learning across episodes: what has the agent's own experience taught it about this house?

This module answers *given the episodes the agent has lived through, what should it now assume?*
(docs/design.md §12). Everything is conjugate counting on the existing factor graph, so learning
is exact, and with no experience a model is exactly the model it started from:

- **where things live** (Dirichlet): counts N_cj of objects of category c found at site j. The
  location prior of eq. (2) becomes the posterior-predictive mean, eq. (50), with the declared
  prior q0 as S pseudo-counts (``prior_strength``);
- **how reliable the detector is** (Beta): hits and misses of category c in look band b
  (``close`` look, room ``glance_near`` under 2.5 m, ``glance_far``); the detection probability
  p_{o,j}(v) of eq. (33) becomes the posterior mean of a Beta prior centred on it, eq. (51);
- **how reliable the state sensor is** (Beta): readings whose value other readings settled,
  counted as true/false positives/negatives; sensitivity and specificity become posterior means,
  eq. (52);
- **which things are kept together** (Dirichlet): for two categories, how often the agent found
  one of each on the same site, in the same room on different sites, or apart. The relational
  factor of eq. (35) between them gets the weights under which the model predicts the
  posterior-predictive mean of those three frequencies, with the frequencies the hand-set
  weights predict as pseudo-counts, eqs. (54)-(55).

Counts come from logs, and only from what the agent itself observed (the counting rules,
:func:`counts_from_events`); ``episode_end.world_truth``, ``episode_end.yardstick`` and
``episode_start.world`` are never read. A forgetting factor gamma multiplies the counts held so far
by gamma before each new log is added, eq. (53).

Agent side: nothing here imports the simulator.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Iterable, Mapping, Sequence

import numpy as np

from fg_tea.errors import InputError

if TYPE_CHECKING:  # model imports this module; import it lazily to avoid a cycle
    from fg_tea.errors import Reader
    from fg_tea.model import Model, Sensor

#: Pseudo-count mass S of the declared location prior (eq. 50). The hand-written prior is worth
#: as much as five episodes: once an object has been found at one site in five episodes, that
#: site holds at least half of its prior mass, whatever the prior said. Not tuned on any house.
DEFAULT_PRIOR_STRENGTH = 5.0
#: Pseudo-looks S_d of the assumed detection probability per (category, band) cell (eq. 51): ten
#: looks, so that the data outweigh the assumed curve after about ten looks at a found object.
DEFAULT_DETECTION_STRENGTH = 10.0
#: Pseudo-readings S_s of the declared sensor sensitivity and specificity (eq. 52): twenty, as the
#: sensor's figures are a specification rather than a guess, and settled readings are rare.
DEFAULT_SENSOR_STRENGTH = 20.0
#: Forgetting factor gamma (eq. 53): 1 keeps every count forever.
DEFAULT_FORGETTING = 1.0
#: Pseudo-count mass S_r of the relation frequencies the hand-set co-location weights predict
#: (eq. 54). Same rule as S: each episode that finds one object of each category adds one count,
#: so the hand-set relation is worth as much as five episodes. Not tuned on any house.
DEFAULT_RELATION_STRENGTH = 5.0
#: The three relation classes of eq. (35), in the order of a co-location count.
RELATION_CLASSES = ("same_site", "same_room", "apart")

#: Look bands of the detector counts: a close look, or a room glance nearer or farther than
#: GLANCE_SPLIT_M from the viewpoint to the site's surface point.
BANDS = ("close", "glance_near", "glance_far")
#: Metres. Room glances in the bundled apartment and the generated houses are 1.3-2.3 m from most
#: sites of their room and 2.8-5.5 m from the far side of large rooms (measured from the
#: scenarios' geometry); 2.5 m separates the two groups.
GLANCE_SPLIT_M = 2.5
#: The keys of a sensor's counts.
SENSOR_KEYS = ("true_positive", "false_negative", "true_negative", "false_positive")
#: The sensor every state reading is counted for (the only one the bundled tasks use).
COUNTED_SENSOR = "state"


@dataclass(frozen=True)
class Source:
    """A log whose counts a learned model holds: its path as given and the sha256 of its bytes."""

    file: str
    sha256: str


@dataclass(frozen=True)
class Counts:
    """Counts from experience (floats, because forgetting scales them).

    Attributes:
        sites: category -> site -> N_cj, objects of category c found at site j (eq. 50).
        detection: category -> band -> (hits, misses) at the site where the object stood (eq. 51).
        sensors: sensor -> {true_positive, false_negative, true_negative, false_positive} (eq. 52).
        co_location: category a -> category b -> (same site, same room, apart), pairs of
            objects of categories a < b (alphabetical) found together (eq. 54).
    """

    sites: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    detection: Mapping[str, Mapping[str, tuple[float, float]]] = field(default_factory=dict)
    sensors: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    co_location: Mapping[str, Mapping[str, tuple[float, float, float]]] = field(default_factory=dict)

    def is_empty(self) -> bool:
        return not (any(v for c in self.sites.values() for v in c.values())
                    or any(h or m for c in self.detection.values() for h, m in c.values())
                    or any(v for s in self.sensors.values() for v in s.values())
                    or self.relations_active)

    @property
    def relations_active(self) -> bool:
        """True when some co-location cell has a count (eq. 55 changes some weight)."""
        return any(any(n) for row in self.co_location.values() for n in row.values())

    def relation(self, a: str, b: str) -> tuple[float, float, float] | None:
        """The (same site, same room, apart) counts of categories `a` and `b` (either order),
        or None without any count."""
        first, second = sorted((a, b))
        cell = self.co_location.get(first, {}).get(second)
        return cell if cell is not None and any(cell) else None

    def scaled(self, gamma: float) -> "Counts":
        """Every count multiplied by gamma (forgetting, eq. 53)."""
        if gamma == 1.0:
            return self
        return Counts({c: {s: n * gamma for s, n in row.items()} for c, row in self.sites.items()},
                      {c: {b: (h * gamma, m * gamma) for b, (h, m) in row.items()}
                       for c, row in self.detection.items()},
                      {s: {k: n * gamma for k, n in row.items()} for s, row in self.sensors.items()},
                      {a: {b: tuple(n * gamma for n in v) for b, v in row.items()}  # type: ignore[misc]
                       for a, row in self.co_location.items()})

    def plus(self, other: "Counts") -> "Counts":
        """The sum of two sets of counts (keys sorted, so the result does not depend on order)."""
        sites: dict[str, dict[str, float]] = {}
        for table in (self.sites, other.sites):
            for c, row in table.items():
                for s, n in row.items():
                    sites.setdefault(c, {})[s] = sites.get(c, {}).get(s, 0.0) + float(n)
        det: dict[str, dict[str, tuple[float, float]]] = {}
        for dtable in (self.detection, other.detection):
            for c, drow in dtable.items():
                for b, (h, m) in drow.items():
                    h0, m0 = det.get(c, {}).get(b, (0.0, 0.0))
                    det.setdefault(c, {})[b] = (h0 + float(h), m0 + float(m))
        sensors: dict[str, dict[str, float]] = {}
        for stable in (self.sensors, other.sensors):
            for s, srow in stable.items():
                for k, n in srow.items():
                    sensors.setdefault(s, {})[k] = sensors.get(s, {}).get(k, 0.0) + float(n)
        rel: dict[str, dict[str, tuple[float, float, float]]] = {}
        for rtable in (self.co_location, other.co_location):
            for a, rrow in rtable.items():
                for b, cell in rrow.items():
                    old = rel.get(a, {}).get(b, (0.0, 0.0, 0.0))
                    rel.setdefault(a, {})[b] = tuple(x + float(y) for x, y in zip(old, cell))  # type: ignore[assignment]
        return Counts(_sorted(sites), _sorted(det), _sorted(sensors), _sorted(rel))

    def without_relations(self) -> "Counts":
        """These counts without the co-location counts (hand-set correlations, learned sites)."""
        return replace(self, co_location={})

    def to_json(self) -> dict:
        out = {"sites": {c: dict(r) for c, r in self.sites.items()},
               "detection": {c: {b: list(v) for b, v in r.items()} for c, r in self.detection.items()},
               "sensors": {s: dict(r) for s, r in self.sensors.items()}}
        if self.co_location:
            out["co_location"] = {a: {b: list(v) for b, v in r.items()} for a, r in self.co_location.items()}
        return out


def _sorted(table: dict) -> dict:
    return {k: (_sorted(v) if isinstance(v, dict) else v) for k, v in sorted(table.items())}


@dataclass(frozen=True)
class Learning:
    """A model's experience and how much its declared assumptions weigh against it.

    Attributes:
        prior_strength: S, pseudo-count mass of the declared location prior (eq. 50).
        detection_strength: S_d, pseudo-looks of the assumed detection probability (eq. 51).
        sensor_strength: S_s, pseudo-readings of the declared sensor (eq. 52).
        forgetting: gamma in (0, 1], applied to held counts before each new log (eq. 53).
        counts: the experience.
        house: the site names of the house the counts were gathered in (empty: none yet).
        sources: the logs counted, in the order they were added.
        relation_strength: S_r, pseudo-counts of the hand-set relation frequencies (eq. 54).
    """

    prior_strength: float = DEFAULT_PRIOR_STRENGTH
    detection_strength: float = DEFAULT_DETECTION_STRENGTH
    sensor_strength: float = DEFAULT_SENSOR_STRENGTH
    forgetting: float = DEFAULT_FORGETTING
    counts: Counts = field(default_factory=Counts)
    house: tuple[str, ...] = ()
    sources: tuple[Source, ...] = ()
    relation_strength: float = DEFAULT_RELATION_STRENGTH

    @property
    def active(self) -> bool:
        """True when some count is non-zero (a model without experience is its base model)."""
        return not self.counts.is_empty()

    @property
    def detection_active(self) -> bool:
        """True when some detector cell has a count (eq. 51 changes some p)."""
        return any(h or m for c in self.counts.detection.values() for h, m in c.values())

    def to_json(self) -> dict:
        return {"prior_strength": self.prior_strength,
                "detection_strength": self.detection_strength,
                "sensor_strength": self.sensor_strength, "forgetting": self.forgetting,
                "relation_strength": self.relation_strength,
                "sources": [{"file": s.file, "sha256": s.sha256} for s in self.sources],
                **self.counts.to_json()}


# ---------------------------------------------------------------------------------------------
# The learned quantities (eqs. 50-52)


def learned_prior(declared: np.ndarray, counts: np.ndarray, strength: float) -> np.ndarray:
    """Eq. 50: the posterior-predictive mean of a Dirichlet with S * q0 as pseudo-counts.

        q(L_o = j | N) = (S q0_j + N_cj) / (S + sum_k N_ck)

    Args:
        declared: q0 over the K sites (eq. 2, normalised, floor applied).
        counts: N_cj over the same sites.
        strength: S > 0.
    """
    q0 = np.asarray(declared, dtype=float)
    n = np.asarray(counts, dtype=float)
    return (strength * q0 + n) / (strength + float(n.sum()))


def learned_probability(assumed: float, hits: float, misses: float, strength: float) -> float:
    """Eqs. 51-52: the posterior mean of Beta(S p, S (1 - p)) after `hits` and `misses`."""
    return (strength * assumed + hits) / (strength + hits + misses)


def beta_interval(alpha: float, beta: float, level: float = 0.95) -> tuple[float, float]:
    """The central `level` interval of Beta(alpha, beta)."""
    from scipy.stats import beta as beta_dist

    lo, hi = beta_dist.ppf([(1 - level) / 2, (1 + level) / 2], alpha, beta)
    return float(lo), float(hi)


def band_of(kind: str, distance: float) -> str:
    """The look band of a look of `kind` (``site``/``room``) from `distance` metres."""
    if kind != "room":
        return "close"
    return "glance_near" if distance < GLANCE_SPLIT_M else "glance_far"


def location_weights(learning: Learning | None, category: str, sites: Sequence[str],
                     declared_weights: np.ndarray, floor: float, where: str = "") -> np.ndarray:
    """The weights the location prior of one object is built from (eq. 2's a_ic, or eq. 50).

    Without counts for `category` the declared weights come back unchanged (so eq. 2 is applied
    to exactly the numbers it always was). With counts, eq. 50 over q0 = eq. 2 of the declared
    weights; eq. 2's floor is then applied to the result by the caller.

    Raises:
        InputError: the counts name a site that the house does not have.
    """
    if learning is None:
        return declared_weights
    row = learning.counts.sites.get(category)
    if not row or not any(row.values()):
        return declared_weights
    index = {s: i for i, s in enumerate(sites)}
    n = np.zeros(len(sites))
    for site, count in row.items():
        if site not in index:
            raise InputError(where or "<model>", f"$.learning.sites.{category}.{site}",
                             f"site {site!r} is not a site of this house; the counts were "
                             "learned in another house")
        n[index[site]] = count
    q0 = np.maximum(np.asarray(declared_weights, dtype=float), floor)
    q0 = q0 / q0.sum()
    return learned_prior(q0, n, learning.prior_strength)


def learned_detection(learning: Learning | None, category: str, band: str,
                      assumed: np.ndarray) -> np.ndarray:
    """Eq. 51 applied to the assumed detection probabilities of one object's looks in one band
    (unchanged without counts for that cell)."""
    if learning is None:
        return assumed
    cell = learning.counts.detection.get(category, {}).get(band)
    if cell is None or not (cell[0] or cell[1]):
        return assumed
    h, m = cell
    s = learning.detection_strength
    return (s * np.asarray(assumed, dtype=float) + h) / (s + h + m)


def learned_sensor(sensor: "Sensor", counts: Mapping[str, float], strength: float) -> "Sensor":
    """Eq. 52: sensitivity and specificity as posterior means under the settled readings."""
    from fg_tea.model import Sensor

    tp, fn = counts.get("true_positive", 0.0), counts.get("false_negative", 0.0)
    tn, fp = counts.get("true_negative", 0.0), counts.get("false_positive", 0.0)
    return Sensor(learned_probability(sensor.sensitivity, tp, fn, strength),
                  learned_probability(sensor.specificity, tn, fp, strength))


def relation_base_rates(q_a: np.ndarray, q_b: np.ndarray, rooms: Sequence[str]) -> np.ndarray:
    """(p_S, p_R, p_A): how often two independent objects with location priors `q_a` and `q_b`
    share a site, share a room on two different sites, or are apart (eq. 55's base rates)."""
    qa, qb = np.asarray(q_a, dtype=float), np.asarray(q_b, dtype=float)
    qa, qb = qa / qa.sum(), qb / qb.sum()
    room = np.asarray([[x == y for y in rooms] for x in rooms])
    joint = np.outer(qa, qb)
    same_site = float(np.trace(joint))
    same_room = float(joint[room].sum()) - same_site
    apart = float(joint[~room].sum())
    return np.array([same_site, max(same_room, 0.0), apart])


def predicted_relation(base_rates: np.ndarray, same_site: float, same_room: float) -> np.ndarray:
    """The relation frequencies (same site, same room, apart) predicted by the pair model
    q_a(L_a) q_b(L_b) psi(L_a, L_b) of eq. (35) with weights `same_site`, `same_room`."""
    w = np.asarray(base_rates, dtype=float) * np.array([same_site, same_room, 1.0])
    return w / w.sum()


def learned_relation_weights(q_a: np.ndarray, q_b: np.ndarray, rooms: Sequence[str],
                             same_site: float, same_room: float,
                             counts: Sequence[float] | None, strength: float) -> tuple[float, float]:
    """Eqs. (54)-(55): the co-location weights learned from relation counts.

    The hand-set weights (s0, r0) over the location priors predict relation frequencies pi0
    (:func:`predicted_relation`); with S_r = `strength` pseudo-counts of pi0 and counts n of
    (same site, same room, apart), the posterior-predictive mean is

        (54)  pi = (S_r pi0 + n) / (S_r + n_S + n_R + n_A)

    and the weights under which the pair model predicts exactly pi are the odds ratios

        (55)  s = (pi_S / pi_A) (p_A / p_S),     r = (pi_R / pi_A) (p_A / p_R)

    with p the base rates of two independent objects (:func:`relation_base_rates`). Without
    counts the hand-set weights come back unchanged (the same floats). A class the priors make
    impossible (p = 0: no two sites share a room) keeps its hand-set weight, and so do both when
    no two sites are apart (p_A = 0, a one-room house: the reference class is missing).

    Args:
        q_a, q_b: the two objects' location priors over the K sites (eq. 2 or eq. 50).
        rooms: room of each site (K).
        same_site, same_room: the hand-set weights s0, r0 of eq. (35).
        counts: (n_S, n_R, n_A), or None.
        strength: S_r > 0.
    """
    if counts is None or not any(counts):
        return same_site, same_room
    p = relation_base_rates(q_a, q_b, rooms)
    if p[2] <= 0.0:
        return same_site, same_room
    pi0 = predicted_relation(p, same_site, same_room)
    n = np.asarray(counts, dtype=float)
    pi = (strength * pi0 + n) / (strength + float(n.sum()))
    s = float(pi[0] / pi[2] * p[2] / p[0]) if p[0] > 0 else same_site
    r = float(pi[1] / pi[2] * p[2] / p[1]) if p[1] > 0 else same_room
    return s, r


# ---------------------------------------------------------------------------------------------
# Reading the [learning] table of a model file


def read_learning(r: "Reader") -> Learning:
    """Parse a model's ``[learning]`` table (every key is checked; unknown keys are errors)."""
    strength = r.positive("prior_strength", DEFAULT_PRIOR_STRENGTH)
    d_strength = r.positive("detection_strength", DEFAULT_DETECTION_STRENGTH)
    s_strength = r.positive("sensor_strength", DEFAULT_SENSOR_STRENGTH)
    r_strength = r.positive("relation_strength", DEFAULT_RELATION_STRENGTH)
    for key, value in (("prior_strength", strength), ("detection_strength", d_strength),
                       ("sensor_strength", s_strength), ("relation_strength", r_strength)):
        if value <= 0:
            raise r.fail("must be positive (the declared assumption's weight in pseudo-counts)", key)
    forgetting = r.probability("forgetting", DEFAULT_FORGETTING)
    if forgetting <= 0:
        raise r.fail("must be in (0, 1]; 1 keeps every count", "forgetting")
    house = r.opt("house", list, [])
    for i, name in enumerate(house):
        if not isinstance(name, str):
            raise InputError(r.file, f"{r.path}.house[{i}]", "expected a site name")
    sources = []
    for s in r.items("sources", required=False):
        sha = s.req("sha256", str)
        if len(sha) != 64 or any(ch not in "0123456789abcdef" for ch in sha):
            raise s.fail("expected 64 lower-case hex digits", "sha256")
        sources.append(Source(s.req("file", str), sha))
    sites: dict[str, dict[str, float]] = {}
    sites_r = r.child("sites", required=False)
    if sites_r is not None:
        for cat in sites_r.names():
            row = sites_r.child(cat)
            for site in row.names():
                sites.setdefault(cat, {})[site] = row.positive(site, allow_zero=True)
            if house and (bad := [s for s in sites.get(cat, {}) if s not in house]):
                raise row.fail(f"site {bad[0]!r} is not in learning.house", bad[0])
    detection: dict[str, dict[str, tuple[float, float]]] = {}
    det_r = r.child("detection", required=False)
    if det_r is not None:
        for cat in det_r.names():
            row = det_r.child(cat)
            for band in row.names():
                if band not in BANDS:
                    raise row.fail(f"unknown band; expected one of {', '.join(BANDS)}", band)
                cell = row.child(band)
                detection.setdefault(cat, {})[band] = (cell.positive("hits", allow_zero=True),
                                                       cell.positive("misses", allow_zero=True))
    sensors: dict[str, dict[str, float]] = {}
    sens_r = r.child("sensors", required=False)
    if sens_r is not None:
        for name in sens_r.names():
            row = sens_r.child(name)
            sensors[name] = {k: row.positive(k, 0.0, allow_zero=True) for k in SENSOR_KEYS}
    co_location: dict[str, dict[str, tuple[float, float, float]]] = {}
    rel_r = r.child("co_location", required=False)
    if rel_r is not None:
        for first in rel_r.names():
            row = rel_r.child(first)
            for second in row.names():
                if not first < second:
                    raise row.fail(f"a pair is written once, under the alphabetically first "
                                   f"category: [learning.co_location.{second}] {first} = ...", second)
                cell = row.child(second)
                co_location.setdefault(first, {})[second] = tuple(  # type: ignore[assignment]
                    cell.positive(k, allow_zero=True) for k in RELATION_CLASSES)
    return Learning(prior_strength=strength, detection_strength=d_strength,
                    sensor_strength=s_strength, forgetting=forgetting,
                    counts=Counts(_sorted(sites), _sorted(detection), _sorted(sensors),
                                  _sorted(co_location)),
                    house=tuple(house), sources=tuple(sources), relation_strength=r_strength)


def apply_to_sensors(learning: Learning, sensors: Mapping[str, "Sensor"], r: "Reader") -> dict:
    """The model's sensors with eq. 52 applied where there are counts."""
    out = dict(sensors)
    for name, counts in learning.counts.sensors.items():
        if name not in out:
            raise InputError(r.file, f"{r.path}.sensors.{name}",
                             f"the model declares no sensor {name!r}")
        if not any(counts.values()):
            continue
        out[name] = learned_sensor(out[name], counts, learning.sensor_strength)
        if out[name].sensitivity + out[name].specificity <= 1.0:
            raise InputError(r.file, f"{r.path}.sensors.{name}",
                             "the learned sensitivity + specificity do not exceed 1: the "
                             "readings carry no information")
    return out


# ---------------------------------------------------------------------------------------------
# Counting from logs


def _fail(file: str, where: str, fault: str) -> InputError:
    return InputError(file, where, fault)


def read_log(path: str | Path) -> tuple[list[dict], str]:
    """The events of a log file and the sha256 of its bytes.

    Raises:
        InputError: the file cannot be read, a line is not a JSON object, or the log has no
            ``episode_start``.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except IsADirectoryError:
        raise _fail(str(path), "$", "is a folder, not a log file") from None
    except FileNotFoundError:
        raise _fail(str(path), "$", "no such log file") from None
    except OSError as exc:
        raise _fail(str(path), "$", f"cannot be read: {exc.strerror}") from None
    events = []
    for n, line in enumerate(data.decode("utf-8", errors="replace").splitlines(), 1):
        if not line.strip():
            continue
        try:
            event = json.loads(line)
        except ValueError:
            raise _fail(str(path), f"line {n}", "not a JSON line") from None
        if not isinstance(event, dict) or not isinstance(event.get("event"), str):
            raise _fail(str(path), f"line {n}", "not an event (a JSON object with 'event')")
        events.append(event)
    if not events or events[0]["event"] != "episode_start":
        raise _fail(str(path), "line 1", "a log starts with an episode_start event")
    return events, hashlib.sha256(data).hexdigest()


def house_of(events: Sequence[Mapping], file: str = "<log>") -> tuple[str, ...]:
    """The site names of the house a log was recorded in (from ``episode_start.sites``)."""
    sites = events[0].get("sites")
    if not isinstance(sites, list) or not sites or not all(
            isinstance(s, dict) and isinstance(s.get("name"), str) for s in sites):
        raise _fail(file, "line 1: $.sites", "expected the list of the house's sites")
    return tuple(s["name"] for s in sites)


def counts_from_events(events: Sequence[Mapping], file: str = "<log>") -> Counts:
    """The counts of one episode, by the counting rules below (docs/design.md §12.2).

    Only what the agent observed is read; ``world_truth``, ``yardstick`` and
    ``episode_start.world`` are not.

    1. **Sites.** The first ``confirm_search`` of each object names the site where the agent
       found it, i.e. where it stood when the episode began (eq. 3): N_{c(o), site} += 1. Later
       confirmations of the same object (after a recovery moved it) are not counted.
    2. **Detector.** For an object found at site j*, every ``observation`` up to and including the
       one that found it, that considered the object and had j* in view, is one trial at the site
       where the object stood: a hit if it was seen there (``found_at``), else a miss, in the band
       of the look (close, or a glance nearer or farther than 2.5 m from j*). Looks without j* in
       view, and every look for an object never found, carry no count (where the object stood is
       unknown to the agent).
    3. **State sensor.** A reading is settled when its state's time slice (the readings between two
       actions whose transitions touch the state) holds at least two *other* readings and they all
       agree; their value is the settled value. The reading is then a true/false
       positive/negative of the sensor ``state``.
    4. **Co-location.** For every two objects of different categories that were both found (rule
       1's sites, where each stood at the start), one count of their relation: the same site,
       the same room on different sites (``episode_start.sites[].room``), or apart; keyed by the
       two categories in alphabetical order. A pair with an object never found carries no count.

    Raises:
        InputError: the log lacks a field a rule needs (file and event named).
    """
    start = events[0]
    cats = start.get("categories") or {}
    if not isinstance(cats, dict):
        raise _fail(file, "line 1: $.categories", "expected object -> category")
    sites = house_of(events, file)
    site_pos = {s["name"]: s.get("position") for s in start["sites"]}
    views = {v["name"]: v for v in start.get("viewpoints") or [] if isinstance(v, dict)}

    def category(obj: str) -> str:  # logs before categories were logged: names are categories
        return str(cats.get(obj, obj))

    found: dict[str, tuple[str, int]] = {}  # object -> (site, index of its first confirmation)
    for i, e in enumerate(events):
        if e["event"] == "confirm_search":
            obj, site = e.get("object"), e.get("site")
            if not isinstance(obj, str) or site not in sites:
                raise _fail(file, f"event {i}: confirm_search", "expected an object and a site of the house")
            found.setdefault(obj, (site, i))
    site_counts: dict[str, dict[str, float]] = {}
    for obj, (site, _) in found.items():
        row = site_counts.setdefault(category(obj), {})
        row[site] = row.get(site, 0.0) + 1.0

    det: dict[str, dict[str, tuple[float, float]]] = {}
    for i, e in enumerate(events):
        if e["event"] != "observation":
            continue
        try:
            considered = list(e["objects"]) if "objects" in e else list(e["detections"])
            in_view = list(e.get("sites_in_view") or [e["site"]])
            found_at = dict(e.get("found_at") or {})
            detections = dict(e["detections"])
            kind = e.get("viewpoint_kind", "site")
            vp_name = e.get("viewpoint", e["site"])
        except (KeyError, TypeError):
            raise _fail(file, f"event {i}: observation", "expected objects, detections and site") from None
        for obj in considered:
            if obj not in found:
                continue
            site, first = found[obj]
            if i > first or site not in in_view:
                continue
            if detections.get(obj) and obj not in found_at and kind == "site":
                found_at[obj] = e["site"]  # logs before found_at: a close look sees its own site
            distance = _distance(views.get(vp_name), site_pos.get(site))
            band = band_of(kind, distance)
            hit = bool(detections.get(obj)) and found_at.get(obj) == site
            h, m = det.setdefault(category(obj), {}).get(band, (0.0, 0.0))
            det[category(obj)][band] = (h + 1.0, m) if hit else (h, m + 1.0)

    sensor: dict[str, float] = {}
    slices: dict[tuple[str, int], list[bool]] = {}
    serial: dict[str, int] = {}
    for e in events:
        if e["event"] == "action" and isinstance(e.get("transition"), dict):
            for eff in e["transition"].get("effects") or []:
                if isinstance(eff, dict) and isinstance(eff.get("state"), str):
                    serial[eff["state"]] = serial.get(eff["state"], 0) + 1
        elif e["event"] == "state_reading" and isinstance(e.get("state"), str) \
                and isinstance(e.get("value"), bool):
            key = (e["state"], serial.get(e["state"], 0))
            slices.setdefault(key, []).append(e["value"])
    for values in slices.values():
        if len(values) < 3:
            continue
        for k, value in enumerate(values):
            others = values[:k] + values[k + 1:]
            if all(v == others[0] for v in others):
                name = ("true_positive" if value else "false_negative") if others[0] else \
                       ("false_positive" if value else "true_negative")
                sensor[name] = sensor.get(name, 0.0) + 1.0
    sensors = {COUNTED_SENSOR: {k: sensor.get(k, 0.0) for k in SENSOR_KEYS}} if sensor else {}

    room_of = {s["name"]: s.get("room") for s in start["sites"]}
    rel: dict[str, dict[str, list[float]]] = {}
    names = sorted(found)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            ca, cb = category(a), category(b)
            if ca == cb:
                continue
            (sa, _), (sb, _) = found[a], found[b]
            k = 0 if sa == sb else 1 if room_of.get(sa) is not None and room_of.get(sa) == room_of.get(sb) else 2
            cat_lo, cat_hi = sorted((ca, cb))
            cell = rel.setdefault(cat_lo, {}).setdefault(cat_hi, [0.0, 0.0, 0.0])
            cell[k] += 1.0
    co_location = {a: {b: tuple(v) for b, v in row.items()} for a, row in rel.items()}
    return Counts(_sorted(site_counts), _sorted(det), sensors, _sorted(co_location))


def _distance(view: Mapping | None, site_position: Any) -> float:
    if view is None or not site_position:
        return 0.0
    (x, y), (sx, sy) = view["position"][:2], site_position[:2]
    return math.hypot(float(x) - float(sx), float(y) - float(sy))


def learn(logs: Iterable[tuple[Sequence[Mapping], Source]], base: Learning | None = None,
          forgetting: float | None = None) -> Learning:
    """Add the counts of `logs`, one after another, to `base` (eq. 53 between logs).

    Args:
        logs: (events, source) per log, in the order they are added.
        base: the base model's learning (None: no experience, default strengths).
        forgetting: gamma; None keeps the base's.

    Raises:
        InputError: a log was recorded in another house than the counts held so far, or is
            already counted (same sha256).
    """
    state = base or Learning()
    if forgetting is not None:
        state = replace(state, forgetting=forgetting)
    gamma = state.forgetting
    counts, house, sources = state.counts, state.house, list(state.sources)
    seen = {s.sha256: s.file for s in sources}
    for events, source in logs:
        log_house = house_of(events, source.file)
        if house and log_house != house:
            raise InputError(source.file, "line 1: $.sites",
                             f"recorded in another house ({len(log_house)} sites) than the "
                             f"counts held so far ({len(house)} sites"
                             f"{', from ' + sources[0].file if sources else ''})")
        if source.sha256 in seen:
            raise InputError(source.file, "$", f"this log is already counted (as {seen[source.sha256]})")
        counts = counts.scaled(gamma).plus(counts_from_events(events, source.file))
        house = log_house
        seen[source.sha256] = source.file
        sources.append(source)
    return replace(state, counts=counts, house=house, sources=tuple(sources))


# ---------------------------------------------------------------------------------------------
# Writing a learned model file


def _toml_key(key: str) -> str:
    if key and all(ch.isalnum() or ch in "_-" for ch in key):
        return key
    return json.dumps(key)


def _num(x: float) -> str:
    x = float(x)
    return str(int(x)) + ".0" if x.is_integer() else repr(x)


def model_text(learning: Learning, base_ref: str, name: str, base_name: str) -> str:
    """The TOML of a learned model that ``extends`` `base_ref` and holds every count."""
    lines = [
        "# Written by `fg-tea learn`: the base model plus counts from the agent's own logs",
        "# (docs/design.md §12). Counts are totals over every source log listed below.",
        f"extends = {json.dumps(base_ref)}",
        f"name = {json.dumps(name)}",
        f"description = {json.dumps(f'{base_name} with location, detector, sensor and co-location counts learned from {len(learning.sources)} episode log(s)')}",
        "",
        "[learning]",
        f"prior_strength = {_num(learning.prior_strength)}          # S, eq. 50",
        f"detection_strength = {_num(learning.detection_strength)}      # S_d, eq. 51",
        f"sensor_strength = {_num(learning.sensor_strength)}         # S_s, eq. 52",
        f"relation_strength = {_num(learning.relation_strength)}       # S_r, eq. 54",
        f"forgetting = {_num(learning.forgetting)}              # gamma, eq. 53",
        "house = [" + ", ".join(json.dumps(s) for s in learning.house) + "]",
        "sources = [",
        *[f"  {{ file = {json.dumps(s.file)}, sha256 = \"{s.sha256}\" }}," for s in learning.sources],
        "]",
    ]
    c = learning.counts
    for cat, row in c.sites.items():
        lines += ["", f"[learning.sites.{_toml_key(cat)}]   # objects found per site (rule 1)"]
        lines += [f"{_toml_key(site)} = {_num(n)}" for site, n in row.items()]
    for cat, drow in c.detection.items():
        lines += ["", f"[learning.detection.{_toml_key(cat)}]   # looks at the site where it stood (rule 2)"]
        lines += [f"{band} = {{ hits = {_num(h)}, misses = {_num(m)} }}" for band, (h, m) in drow.items()]
    for sensor, srow in c.sensors.items():
        lines += ["", f"[learning.sensors.{_toml_key(sensor)}]   # settled readings (rule 3)"]
        lines += [f"{k} = {_num(srow.get(k, 0.0))}" for k in SENSOR_KEYS]
    for first, rrow in c.co_location.items():
        lines += ["", f"[learning.co_location.{_toml_key(first)}]   # pairs found together: same site, same room, apart (rule 4)"]
        lines += [f"{_toml_key(second)} = {{ " + ", ".join(f"{k} = {_num(n)}" for k, n in zip(RELATION_CLASSES, cell)) + " }"
                  for second, cell in rrow.items()]
    return "\n".join(lines) + "\n"


def base_reference(base_path: Path, out: Path, bundled_name: str | None) -> str:
    """How `out` names its base in ``extends``: a bundled name, or a path relative to `out`'s
    folder without the ``.toml`` suffix (as the ``extends`` resolver expects)."""
    import os

    if bundled_name is not None:
        return bundled_name
    rel = os.path.relpath(base_path.resolve(), out.resolve().parent)
    return rel[:-5] if rel.endswith(".toml") else rel


def summary(learning: Learning) -> dict:
    """What was learned, as numbers: per category the learned site shares (without the declared
    prior) and per detector cell the posterior interval of the hit rate under a flat prior."""
    out: dict[str, Any] = {"sources": len(learning.sources), "sites": {}, "detection": {},
                           "co_location": {}}
    for first, rrow in learning.counts.co_location.items():
        for second, cell in rrow.items():
            total = sum(cell)
            out["co_location"][f"{first}~{second}"] = (
                {k: round(n / total, 3) for k, n in zip(RELATION_CLASSES, cell)} if total else {})
    for cat, row in learning.counts.sites.items():
        total = sum(row.values())
        out["sites"][cat] = {s: round(n / total, 3) for s, n in row.items() if n} if total else {}
    for cat, drow in learning.counts.detection.items():
        out["detection"][cat] = {
            band: {"hits": h, "misses": m, "rate": round(h / (h + m), 3) if h + m else None,
                   "interval_95": [round(x, 3) for x in beta_interval(h + 1, m + 1)]}
            for band, (h, m) in drow.items()}
    return out


def apply_learning(model: "Model", learning: Learning) -> "Model":
    """`model` with `learning` as its experience (sensors updated by eq. 52), for code that learns
    in memory (the lifelong sweep) rather than through files."""
    from fg_tea.errors import Reader

    sensors = apply_to_sensors(learning, _declared_sensors(model), Reader({}, model.source, "$.learning"))
    return replace(model, learning=learning, sensors=MappingProxyType(sensors))


def _declared_sensors(model: "Model") -> Mapping[str, "Sensor"]:
    """The sensors before any learning was applied (kept on the model for in-memory learning)."""
    return model.declared_sensors if model.declared_sensors is not None else model.sensors


__all__ = ["BANDS", "Counts", "Learning", "RELATION_CLASSES", "Source", "apply_learning", "band_of",
           "beta_interval", "counts_from_events", "learn", "learned_detection", "learned_prior",
           "learned_probability", "learned_relation_weights", "learned_sensor", "location_weights",
           "model_text", "predicted_relation", "read_learning", "read_log", "relation_base_rates",
           "summary"]


def learn_files(logs: Sequence[str | Path], base: str | Path, out: str | Path,
                name: str | None = None, forgetting: float | None = None,
                prior_strength: float | None = None) -> tuple[Path, Learning]:
    """``fg-tea learn``: write a model that extends `base` and holds the counts of `logs`.

    The out path is checked before any log is read; the file is written atomically, and it is
    loaded (every model check) before it replaces anything.

    Raises:
        InputError: a bad log, base, out path or option (one line: file, field, fault).
    """
    from fg_tea.files import atomic_path
    from fg_tea.model import load_model
    from fg_tea.resources import _exists, resolve_model

    out = Path(out)
    if out.is_dir():
        raise InputError("<command line>", "--out", f"{out} is a folder; name a file")
    if out.suffix != ".toml":
        raise InputError("<command line>", "--out", f"{out} must end in .toml (a model file)")
    if out.exists() and not out.is_file():
        raise InputError("<command line>", "--out", f"{out} is not a regular file")
    folder = out.parent if str(out.parent) else Path(".")
    import os

    if folder.exists() and not folder.is_dir():
        raise InputError("<command line>", "--out", f"{folder} is not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError("<command line>", "--out", f"cannot create folder {folder}: "
                         f"{exc.strerror or exc}") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError("<command line>", "--out", f"cannot write into folder {folder}")
    base_path = Path(resolve_model(base))
    base_model = load_model(base)
    try:
        same = out.exists() and out.resolve() == base_path.resolve()
    except OSError:
        same = False
    if same:
        raise InputError("<command line>", "--out", "would overwrite its own base model; "
                         "write the learned model to another file")
    if forgetting is not None and not 0.0 < forgetting <= 1.0:
        raise InputError("<command line>", "--forgetting", f"expected a value in (0, 1], got {forgetting}")
    if prior_strength is not None and not (math.isfinite(prior_strength) and prior_strength > 0):
        raise InputError("<command line>", "--prior-strength", f"expected a positive number, got {prior_strength}")
    read = []
    for log in logs:
        events, sha = read_log(log)
        read.append((events, Source(str(log), sha)))
    state = base_model.learning or Learning()
    if prior_strength is not None:
        state = replace(state, prior_strength=prior_strength)
    learning = learn(read, state, forgetting)
    bare = str(base)
    bundled = bare if (not _exists(Path(bare)) and not Path(bare).suffix
                       and len(Path(bare).parts) == 1) else None
    ref = base_reference(base_path, out, bundled)
    shadow = folder / f"{ref}.toml"
    if bundled is not None and (shadow.exists() or shadow.name == out.name):
        raise InputError("<command line>", "--out", f"{shadow} would shadow the bundled base "
                         f"model {bundled!r} (extends looks beside the file first); write the "
                         "learned model under another name or folder")
    stem = base_model.name if base_model.name.endswith("_learned") else f"{base_model.name}_learned"
    text = model_text(learning, ref, name or stem, base_model.name)
    try:
        with atomic_path(out) as tmp:
            tmp.write_text(text, encoding="utf-8")
            try:
                load_model(tmp)
            except InputError as exc:
                raise InputError(out, exc.path, exc.fault) from None
    except OSError as exc:
        raise InputError("<command line>", "--out", f"cannot write {out}: {exc.strerror or exc}") from None
    return out, learning
