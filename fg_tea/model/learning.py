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

from dataclasses import dataclass, field, replace
from typing import Any, Mapping, Sequence

import numpy as np

from fg_tea.common.errors import InputError
from fg_tea.common.inputs import Reader
from fg_tea.model import learned_transitions as lt

#: A sensor's (sensitivity, specificity) record: :class:`fg_tea.model.spec.Sensor`, which imports
#: this module; the equations below only read and replace its two fields.
Sensor = Any

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
    """A log whose counts a learned model holds: its path as given and the sha256 of its episode's
    content (:func:`fg_tea.episode.log.episode_digest`; models learned before held that of its bytes)."""

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
        transitions: row (``boil.effect0``) -> the mixture of eq. (61) over the episodes counted
            (:mod:`fg_tea.model.learned_transitions`).
    """

    sites: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    detection: Mapping[str, Mapping[str, tuple[float, float]]] = field(default_factory=dict)
    sensors: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    co_location: Mapping[str, Mapping[str, tuple[float, float, float]]] = field(default_factory=dict)
    transitions: Mapping[str, lt.Terms] = field(default_factory=dict)

    def is_empty(self) -> bool:
        return not (any(v for c in self.sites.values() for v in c.values())
                    or any(h or m for c in self.detection.values() for h, m in c.values())
                    or any(v for s in self.sensors.values() for v in s.values())
                    or self.relations_active or any(self.transitions.values()))

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
                       for a, row in self.co_location.items()},
                      {k: lt.scaled(t, gamma) for k, t in self.transitions.items()})

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
                    summed = tuple(x + float(y) for x, y in zip(old, cell))
                    rel.setdefault(a, {})[b] = summed  # type: ignore[assignment]
        trans = {k: lt.combine(self.transitions.get(k, ()), other.transitions.get(k, ()))
                 for k in set(self.transitions) | set(other.transitions)}
        return Counts(_sorted(sites), _sorted(det), _sorted(sensors), _sorted(rel), _sorted(trans))

    def without_relations(self) -> "Counts":
        """These counts without the co-location counts (hand-set correlations, learned sites)."""
        return replace(self, co_location={})

    def to_json(self) -> dict:
        out = {"sites": {c: dict(r) for c, r in self.sites.items()},
               "detection": {c: {b: list(v) for b, v in r.items()} for c, r in self.detection.items()},
               "sensors": {s: dict(r) for s, r in self.sensors.items()}}
        if self.co_location:
            out["co_location"] = {a: {b: list(v) for b, v in r.items()} for a, r in self.co_location.items()}
        if self.transitions:
            out["transitions"] = {k: [list(t) for t in terms] for k, terms in self.transitions.items()}
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
        transition_strength: S_t, pseudo-trials of a declared effect success (eq. 62).
        transition_states: row -> the effect's state template the file's counts were written
            for (checked against the model; empty for counts learned in memory).
    """

    prior_strength: float = DEFAULT_PRIOR_STRENGTH
    detection_strength: float = DEFAULT_DETECTION_STRENGTH
    sensor_strength: float = DEFAULT_SENSOR_STRENGTH
    forgetting: float = DEFAULT_FORGETTING
    counts: Counts = field(default_factory=Counts)
    house: tuple[str, ...] = ()
    sources: tuple[Source, ...] = ()
    relation_strength: float = DEFAULT_RELATION_STRENGTH
    transition_strength: float = lt.DEFAULT_TRANSITION_STRENGTH
    transition_states: Mapping[str, str] = field(default_factory=dict)

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
                **({"transition_strength": self.transition_strength} if self.counts.transitions else {}),
                **self.counts.to_json()}


# ---------------------------------------------------------------------------------------------
# The learned quantities (eqs. 50-52)


def posterior_mean(prior_mean: Any, counts: Any, strength: float, others: Any = None) -> Any:
    """The posterior-predictive mean of a Dirichlet (or Beta) prior with `strength` pseudo-counts
    centred on `prior_mean`, after `counts` (in the style of pymdp's ``dirichlet_expected_value``);
    every learning rule, eqs. 50-54, is this one formula.

        Dirichlet (eqs. 50, 54):  (S m_k + n_k) / (S + sum_j n_j)   for every outcome k
        Beta (eqs. 51, 52):       (S p + n) / (S + n + n_other)     for the one outcome p is of

    Args:
        prior_mean: m over the outcomes (Dirichlet), or p of one outcome (Beta; an array applies
            the same counts to several p).
        counts: n over the same outcomes (Dirichlet), or the count n of p's outcome (Beta).
        strength: S > 0.
        others: None for the Dirichlet; for the Beta, the count of the other outcome.
    """
    m = np.asarray(prior_mean, dtype=float)
    if others is None:
        n = np.asarray(counts, dtype=float)
        return (strength * m + n) / (strength + float(n.sum()))
    return (strength * m + counts) / (strength + counts + others)


def learned_prior(declared: np.ndarray, counts: np.ndarray, strength: float) -> np.ndarray:
    """Eq. 50: the posterior-predictive mean of a Dirichlet with S * q0 as pseudo-counts.

        q(L_o = j | N) = (S q0_j + N_cj) / (S + sum_k N_ck)

    Args:
        declared: q0 over the K sites (eq. 2, normalised, floor applied).
        counts: N_cj over the same sites.
        strength: S > 0.
    """
    return posterior_mean(declared, counts, strength)


def learned_probability(assumed: float, hits: float, misses: float, strength: float) -> float:
    """Eqs. 51-52: the posterior mean of Beta(S p, S (1 - p)) after `hits` and `misses`."""
    return float(posterior_mean(assumed, hits, strength, others=misses))


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
    hits, misses = cell
    return posterior_mean(assumed, hits, learning.detection_strength, others=misses)


def learned_sensor(sensor: Sensor, counts: Mapping[str, float], strength: float) -> Sensor:
    """Eq. 52: sensitivity and specificity as posterior means under the settled readings."""
    tp, fn = counts.get("true_positive", 0.0), counts.get("false_negative", 0.0)
    tn, fp = counts.get("true_negative", 0.0), counts.get("false_positive", 0.0)
    return replace(sensor, sensitivity=learned_probability(sensor.sensitivity, tp, fn, strength),
                   specificity=learned_probability(sensor.specificity, tn, fp, strength))


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
    pi = posterior_mean(pi0, counts, strength)
    s = float(pi[0] / pi[2] * p[2] / p[0]) if p[0] > 0 else same_site
    r = float(pi[1] / pi[2] * p[2] / p[1]) if p[1] > 0 else same_room
    return s, r


# ---------------------------------------------------------------------------------------------
# Reading the [learning] table of a model file


def read_learning(r: Reader) -> Learning:
    """Parse a model's ``[learning]`` table (every key is checked; unknown keys are errors)."""
    strength = r.positive("prior_strength", DEFAULT_PRIOR_STRENGTH)
    d_strength = r.positive("detection_strength", DEFAULT_DETECTION_STRENGTH)
    s_strength = r.positive("sensor_strength", DEFAULT_SENSOR_STRENGTH)
    r_strength = r.positive("relation_strength", DEFAULT_RELATION_STRENGTH)
    t_strength = r.positive("transition_strength", lt.DEFAULT_TRANSITION_STRENGTH)
    for key, value in (("transition_strength", t_strength),
                       ("prior_strength", strength), ("detection_strength", d_strength),
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
    rows = lt.read_transition_counts(r)
    return Learning(prior_strength=strength, detection_strength=d_strength,
                    sensor_strength=s_strength, forgetting=forgetting,
                    counts=Counts(_sorted(sites), _sorted(detection), _sorted(sensors),
                                  _sorted(co_location), {k: v["terms"] for k, v in sorted(rows.items())}),
                    house=tuple(house), sources=tuple(sources), relation_strength=r_strength,
                    transition_strength=t_strength,
                    transition_states={k: v["state"] for k, v in rows.items()})


def apply_to_transitions(learning: Learning, transitions: Mapping[str, Any],
                         r: Reader) -> Mapping[str, Any]:
    """The model's transitions with eq. (63) applied where there are counts (the file's state
    templates checked against the model's)."""
    rows = {k: {"state": learning.transition_states.get(k) or _declared_state(transitions, k),
                "terms": t} for k, t in learning.counts.transitions.items()}
    return lt.apply_to_transitions(rows, learning.transition_strength, transitions, r)


def _declared_state(transitions: Mapping[str, Any], key: str) -> str | None:
    name, _, k = key.rpartition(".effect")
    spec = transitions.get(name)
    return spec.effects[int(k)].state if spec is not None and int(k) < len(spec.effects) else None


def apply_to_sensors(learning: Learning, sensors: Mapping[str, Sensor], r: Reader) -> dict:
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


# ---------------------------------------------------------------------------------------------
# Writing a learned model file


__all__ = ["BANDS", "Counts", "Learning", "RELATION_CLASSES", "Source", "band_of", "beta_interval",
           "learned_detection", "learned_prior", "learned_probability", "learned_relation_weights",
           "learned_sensor", "location_weights", "posterior_mean", "predicted_relation",
           "read_learning", "relation_base_rates"]


