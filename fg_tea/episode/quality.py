"""Belief quality: how good were the agent's location beliefs, step by step? (docs/design.md §11)

Search cost (travel, inspections) says how well the agent *acted*; this module says how well it
*believed*. Every measure is a pure function of an episode's events plus the world's truth (the
true start site of each object), so any old log can be re-scored, like
:mod:`fg_tea.episode.metrics`. Nothing here runs the environment or changes a live belief.

Steps. Every per-step list has one entry for the prior (step 0, before any inspection) and one
after each logged inspection (``observation`` event) in order: ``1 + inspections`` entries. Only
inspections move location beliefs (actions and state readings touch the state block alone), so
these are all the location beliefs an episode ever held.

Measures:

- **Replay** (:func:`replay_location_evidence`): the inspections re-fed, site and detections in
  order, into a fresh :class:`~fg_tea.beliefs.engine.BeliefEngine` of any model — the posterior
  that model would have held on the same evidence.
- **KL of the factorised belief from the joint posterior** (:func:`kl_factorised_from_joint`):
  sum over objects of KL(p_joint(L_o) || q_fact(L_o)) = sum_j p log(p / q), in nats. The joint
  model is the reference: it is the exact posterior of the richer generative model (with the
  relational factors), and the factorised belief is its cheaper approximation, so the divergence
  is taken *from* the reference, in the direction of the expected log-loss the approximation
  pays when the reference is right. It compares two models' beliefs on the same evidence, not
  either with the truth: it is zero whenever the joint model has no relational factors, whatever
  the world.
- **Brier score** (:func:`brier_scores`): sum over objects o and sites j of
  (q_o(j) - [j is o's true site])^2, in [0, 2 N]; 0 for a point mass on the truth. By default
  on the beliefs the agent actually held (:func:`agent_beliefs`, from the log).
- **Calibration** (:func:`calibration_pairs`, :func:`calibration`): (q_o(j), [j true]) pairs over
  steps, objects and sites, binned into a reliability curve; :func:`expected_calibration_error`
  sums |mean predicted - observed frequency| weighted by bin counts.
- :func:`quality_summary` turns them into scalars for one CSV row.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Iterable, Mapping, NamedTuple, Sequence

import numpy as np

from fg_tea.beliefs.detection import found_from_log, view_from_log
from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.episode.log import iter_events
from fg_tea.model.spec import Model, load_model
from fg_tea.world.scenario import Scenario, load_scenario

#: Bundled models used as the KL references when none are given.
FACTORISED_REFERENCE = "factorised"
JOINT_REFERENCE = "joint"


# ------------------------------------------------------------------ inputs
def _scenario(scenario: Scenario | str | Path) -> Scenario:
    return scenario if isinstance(scenario, Scenario) else load_scenario(scenario)


def _model(model: Model | str | Path) -> Model:
    return model if isinstance(model, Model) else load_model(model)


def _start(events: Sequence[Mapping]) -> Mapping:
    start = next(iter_events(list(events), "episode_start"), None)
    if start is None:
        raise ValueError("the events hold no episode_start event; is this an episode log?")
    return start


def true_sites(scenario: Scenario) -> dict[str, str]:
    """The true start site of every object of `scenario` (environment truth, for scoring only).

    Args:
        scenario: a scenario or a sampled world (:meth:`fg_tea.world.distributions.WorldDistribution.sample`).

    Returns:
        object name -> site name.
    """
    return {spec.name: spec.true_site for spec in scenario.objects}


# ------------------------------------------------------------------ beliefs per step
def replay_location_evidence(events: Sequence[Mapping], scenario: Scenario | str | Path,
                             model: Model | str | Path) -> list[dict]:
    """Re-feed every logged inspection into a fresh belief engine of `model`.

    Each ``observation`` event's view (sites in view and the detection probabilities the agent
    used) and detections (seen at a site, looked and not seen, absent = not considered) go
    through :meth:`BeliefEngine.observe_viewpoint` in log order, whatever model the episode itself ran.

    Args:
        events: one episode's events (:func:`fg_tea.episode.log.read_log`, or ``runner.events``).
        scenario: the house whose sites and priors the engine is built on (a Scenario, or a
            bundled name or path). Truth is not read.
        model: the generative model to replay with (a Model, or a bundled name or path).

    Returns:
        ``1 + inspections`` belief snapshots (:meth:`BeliefEngine.snapshot`): the prior, then the
        posterior after each inspection.

    Raises:
        fg_tea.common.errors.ContradictionError: the evidence has probability zero under `model`.
    """
    model = _model(model)
    engine = BeliefEngine(_scenario(scenario), model)
    snapshots = [engine.snapshot()]
    for event in iter_events(list(events), "observation"):
        view = view_from_log(event, engine.sites, engine.objects, model)
        engine.observe_viewpoint(view, found_from_log(event))
        snapshots.append(engine.snapshot())
    return snapshots


def agent_beliefs(events: Sequence[Mapping]) -> list[dict]:
    """The location beliefs the agent actually held, read from the log (no re-computation).

    Step 0 is ``episode_start``'s belief. After an inspection, the observation event's ``after``
    marginals update the objects it considered; the first full ``belief`` snapshot that follows
    (written after every event by default) then replaces every object's marginal, so objects the
    inspection did not consider also get their exact posterior (in joint models they can move).
    Without snapshots their previous marginal is carried forward.

    Args:
        events: one episode's events.

    Returns:
        ``1 + inspections`` dicts with ``sites`` (site names) and ``locations`` (object -> list of
        K probabilities).

    Raises:
        ValueError: no ``episode_start`` event, or it carries no belief.
    """
    start = _start(events)
    if "belief" not in start:
        raise ValueError("episode_start carries no belief snapshot")
    sites = list(start["belief"]["sites"])
    current = {o: list(q) for o, q in start["belief"]["locations"].items()}
    steps = [{"sites": sites, "locations": dict(current)}]
    refresh = False  # a snapshot after the latest inspection has not been seen yet
    for event in events:
        kind = event.get("event")
        if kind == "observation":
            current = {**current, **{o: list(q) for o, q in event["after"].items()}}
            steps.append({"sites": sites, "locations": current})
            refresh = True
        elif refresh and kind in ("belief", "episode_end"):
            snap = event.get("belief", {}) if kind == "episode_end" else event
            if "locations" not in snap:
                continue
            current = {o: list(q) for o, q in snap["locations"].items()}
            steps[-1] = {"sites": sites, "locations": current}
            refresh = False
    return steps


# ------------------------------------------------------------------ KL between two models
def kl_divergence(p: np.ndarray, q: np.ndarray) -> float:
    """KL(p || q) = sum_i p_i log(p_i / q_i) in nats; terms with p_i = 0 contribute 0.

    Returns:
        The divergence, >= 0; ``inf`` when q_i = 0 for some p_i > 0.
    """
    p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    support = p > 0
    if np.any(q[support] <= 0):
        return math.inf
    return max(float(np.sum(p[support] * np.log(p[support] / q[support]))), 0.0)


def kl_factorised_from_joint(events: Sequence[Mapping], scenario: Scenario | str | Path,
                             factorised_model: Model | str | Path = FACTORISED_REFERENCE,
                             joint_model: Model | str | Path = JOINT_REFERENCE) -> list[float]:
    """Per step, sum over objects of KL(joint posterior marginal || factorised posterior marginal).

    Both models are replayed on the episode's evidence (:func:`replay_location_evidence`), so the
    comparison is on the same evidence whichever model the agent ran. The joint model is the
    reference "exact" posterior (see the module docstring for the direction); this is a
    divergence between two models' beliefs, not a distance from the truth.

    Args:
        events: one episode's events.
        scenario: the house (priors and sites).
        factorised_model: the approximation q (default: bundled ``factorised``).
        joint_model: the reference p (default: bundled ``joint``).

    Returns:
        ``1 + inspections`` divergences in nats, >= 0.
    """
    joint = replay_location_evidence(events, scenario, joint_model)
    fact = replay_location_evidence(events, scenario, factorised_model)
    return [sum(kl_divergence(p["locations"][o], q["locations"][o]) for o in p["locations"])
            for p, q in zip(joint, fact)]


# ------------------------------------------------------------------ scores against truth
def _truth_vector(sites: Sequence[str], obj: str, truth_sites: Mapping[str, str]) -> np.ndarray:
    if obj not in truth_sites:
        raise ValueError(f"no true site given for object {obj!r}")
    if truth_sites[obj] not in sites:
        raise ValueError(f"true site {truth_sites[obj]!r} of {obj!r} is not one of the sites "
                         f"{list(sites)}")
    return (np.asarray(sites) == truth_sites[obj]).astype(float)


def brier_scores(events: Sequence[Mapping], truth_sites: Mapping[str, str],
                 beliefs: Sequence[Mapping] | None = None) -> list[float]:
    """Per step, the Brier score of every object's location belief against its true site.

    B = sum_o sum_j (q_o(j) - [j = true site of o])^2, in [0, 2 N]: 0 for point masses on the
    truth, 2 N for point masses elsewhere.

    Args:
        events: one episode's events.
        truth_sites: object -> true start site (:func:`true_sites` of the episode's world).
        beliefs: the snapshots to score; default :func:`agent_beliefs` (what the agent held). Pass
            ``replay_location_evidence(events, scenario, model)`` to score another model.

    Returns:
        One score per step (``1 + inspections`` for the defaults).
    """
    steps = agent_beliefs(events) if beliefs is None else beliefs
    out = []
    for snap in steps:
        total = 0.0
        for obj, q in snap["locations"].items():
            total += float(np.sum((np.asarray(q, dtype=float)
                                   - _truth_vector(snap["sites"], obj, truth_sites)) ** 2))
        out.append(total)
    return out


def calibration_pairs(events: Sequence[Mapping], truth_sites: Mapping[str, str],
                      beliefs: Sequence[Mapping] | None = None) -> np.ndarray:
    """Every (q_o(j), [j = true site of o]) pair over steps, objects and sites.

    Args:
        events: one episode's events.
        truth_sites: object -> true start site.
        beliefs: the snapshots to use; default :func:`agent_beliefs`.

    Returns:
        An (M, 2) array of (predicted probability, outcome 0 or 1), M = steps x objects x sites.
    """
    steps = agent_beliefs(events) if beliefs is None else beliefs
    rows = []
    for snap in steps:
        for obj, q in snap["locations"].items():
            rows.append(np.column_stack([np.asarray(q, dtype=float),
                                         _truth_vector(snap["sites"], obj, truth_sites)]))
    return np.concatenate(rows) if rows else np.empty((0, 2))


class CalibrationCurve(NamedTuple):
    """A reliability curve over equal-width probability bins (empty bins hold NaN, count 0)."""

    centres: np.ndarray
    mean_predicted: np.ndarray
    observed_frequency: np.ndarray
    counts: np.ndarray


def calibration(records: Iterable[Sequence[float]] | np.ndarray, bins: int = 10) -> CalibrationCurve:
    """Bin (predicted probability, outcome) pairs into a reliability curve.

    Bin b covers [b / bins, (b + 1) / bins); the last bin includes 1.

    Args:
        records: (q, outcome) pairs, q in [0, 1], outcome 0 or 1 (e.g. :func:`calibration_pairs`,
            possibly concatenated over many episodes).
        bins: number of equal-width bins, >= 1.

    Returns:
        (bin centres, mean predicted q, observed frequency of outcome 1, counts), each of
        shape (bins,).

    Raises:
        ValueError: bins < 1, or a probability outside [0, 1].
    """
    if bins < 1:
        raise ValueError(f"calibration needs at least one bin, got {bins}")
    data = np.asarray(list(records) if not isinstance(records, np.ndarray) else records,
                      dtype=float).reshape(-1, 2)
    q, y = data[:, 0], data[:, 1]
    if np.any((q < 0) | (q > 1)):
        raise ValueError("calibration probabilities must lie in [0, 1]")
    index = np.minimum((q * bins).astype(int), bins - 1)
    counts = np.bincount(index, minlength=bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_q = np.bincount(index, weights=q, minlength=bins) / counts
        freq = np.bincount(index, weights=y, minlength=bins) / counts
    centres = (np.arange(bins) + 0.5) / bins
    return CalibrationCurve(centres, mean_q, freq, counts)


def expected_calibration_error(curve: CalibrationCurve) -> float:
    """ECE = sum_b (n_b / n) |mean predicted_b - observed frequency_b|; NaN with no records."""
    n = int(curve.counts.sum())
    if n == 0:
        return math.nan
    used = curve.counts > 0
    gaps = np.abs(curve.mean_predicted[used] - curve.observed_frequency[used])
    return float(np.sum(curve.counts[used] * gaps) / n)


# ------------------------------------------------------------------ one row per episode
def quality_summary(events: Sequence[Mapping], scenario: Scenario | str | Path,
                    truth_sites: Mapping[str, str] | None = None,
                    factorised_model: Model | str | Path = FACTORISED_REFERENCE,
                    joint_model: Model | str | Path = JOINT_REFERENCE,
                    bins: int = 10) -> dict[str, float]:
    """Belief-quality scalars of one episode, for one CSV row.

    Args:
        events: one episode's events.
        scenario: the episode's world (sites and priors for the KL replay).
        truth_sites: object -> true start site; default :func:`true_sites` of `scenario` (pass
            it when `scenario` is the agent's house rather than the sampled world).
        factorised_model, joint_model: the KL references (default: the bundled models).
        bins: calibration bins for the ECE.

    Returns:
        ``kl_mean``, ``kl_final`` (nats, factorised from joint, over the prior and every
        inspection / after the last one), ``brier_initial``, ``brier_mean``, ``brier_final``
        (the agent's own beliefs) and ``ece`` (expected calibration error of those beliefs over
        all steps, objects and sites).
    """
    world = _scenario(scenario)
    truth = true_sites(world) if truth_sites is None else truth_sites
    kl = kl_factorised_from_joint(events, world, factorised_model, joint_model)
    beliefs = agent_beliefs(events)
    brier = brier_scores(events, truth, beliefs)
    ece = expected_calibration_error(calibration(calibration_pairs(events, truth, beliefs), bins))
    return {"kl_mean": float(np.mean(kl)), "kl_final": float(kl[-1]),
            "brier_initial": float(brier[0]), "brier_mean": float(np.mean(brier)),
            "brier_final": float(brier[-1]), "ece": ece}


__all__ = ["CalibrationCurve", "agent_beliefs", "brier_scores", "calibration", "calibration_pairs",
           "expected_calibration_error", "kl_divergence", "kl_factorised_from_joint",
           "quality_summary", "replay_location_evidence", "true_sites"]
