"""Belief quality (fg_tea.episode.quality): replay, KL between models, Brier score and calibration.

Hand-checked numbers use a tiny house: sites a (room r1) and b (room r2); the kettle's prior is
(3, 1) / 4 = (0.75, 0.25), the teabag's (1, 1) / 2 = (0.5, 0.5) (both above the 1e-4 floor);
the joint model adds co-location psi(teabag, kettle) = 3 on one site, 1 otherwise (the two
sites lie in different rooms, and no site has a capacity). Whole episodes check that a replay
reproduces the logged beliefs and that the summary is a usable CSV row.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fg_tea.env.fake import FakeHouse
from fg_tea.episode.log import EventLog, read_log
from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
from fg_tea.model.spec import load_model
from fg_tea.episode.quality import (agent_beliefs, brier_scores, calibration, calibration_pairs,
    expected_calibration_error, kl_divergence, kl_factorised_from_joint, quality_summary,
    replay_location_evidence, true_sites)
from fg_tea.world.scenario import load_scenario, parse_scenario

TINY = parse_scenario({
    "schema_version": 2, "name": "tiny",
    "house": {"floor": {"min": [0, 0], "max": [4, 2]}, "walls": [], "furniture": []},
    "sites": [
        {"name": "a", "room": "r1", "position": [1, 1, 0.9], "vantage_position": [1, 0.5],
         "affordances": {"kettle": 3, "teabag": 1}},
        {"name": "b", "room": "r2", "position": [3, 1, 0.9], "vantage_position": [3, 0.5],
         "affordances": {"kettle": 1, "teabag": 1}},
    ],
    "objects": [{"name": "kettle", "true_site": "a", "semantic_id": 1},
                {"name": "teabag", "true_site": "b", "semantic_id": 2}],
    "start_pose": {"position": [2, 0.5]},
})
TRUTH = {"kettle": "a", "teabag": "b"}
#: A perfect positive detector (fp = 0), so a detection makes an exact point mass.
EXACT = {"positive_update": "likelihood", "false_positive_rate": 0.0}


def obs(site: str, detections: dict, after: dict | None = None) -> dict:
    return {"event": "observation", "site": site, "objects": list(detections),
            "detections": detections, "after": after or {}}


def start(locations: dict) -> dict:
    return {"event": "episode_start", "belief": {"sites": ["a", "b"], "locations": locations}}


#: Evidence: the kettle seen at a, then the teabag looked for at b and not seen.
EVIDENCE = [start({}), obs("a", {"kettle": True}), obs("b", {"teabag": False})]


# ------------------------------------------------------------------ replay
def test_replay_gives_the_prior_then_one_posterior_per_inspection():
    snaps = replay_location_evidence(EVIDENCE, TINY, load_model("factorised").with_overrides(**EXACT))
    assert len(snaps) == 3
    # prior: kettle (0.75, 0.25), teabag (0.5, 0.5)
    np.testing.assert_allclose(snaps[0]["locations"]["kettle"], [0.75, 0.25], atol=1e-12)
    # kettle seen at a with fp = 0: (0.75 * 0.95, 0.25 * 0) -> (1, 0); teabag untouched
    np.testing.assert_allclose(snaps[1]["locations"]["kettle"], [1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(snaps[1]["locations"]["teabag"], [0.5, 0.5], atol=1e-12)
    # teabag missed at b (mu = 0.05): (0.5, 0.5 * 0.05) / 0.525
    np.testing.assert_allclose(snaps[2]["locations"]["teabag"], [0.5 / 0.525, 0.025 / 0.525],
                               atol=1e-12)


# ------------------------------------------------------------------ KL
def test_kl_divergence_arithmetic():
    # KL((0.5, 0.5) || (0.25, 0.75)) = 0.5 ln 2 + 0.5 ln(2/3)
    assert kl_divergence([0.5, 0.5], [0.25, 0.75]) == pytest.approx(
        0.5 * math.log(2) + 0.5 * math.log(2 / 3), abs=1e-15)
    assert kl_divergence([1.0, 0.0], [0.5, 0.5]) == pytest.approx(math.log(2), abs=1e-15)
    assert kl_divergence([0.5, 0.5], [1.0, 0.0]) == math.inf
    assert kl_divergence([0.3, 0.7], [0.3, 0.7]) == 0.0


def test_kl_by_hand_on_the_tiny_house():
    fact = load_model("factorised").with_overrides(**EXACT)
    joint = load_model("joint").with_overrides(**EXACT)
    kl = kl_factorised_from_joint(EVIDENCE, TINY, fact, joint)
    assert len(kl) == 3
    # Step 0. Joint prior P(K, T) ∝ pK pT psi: (a,a) 0.75*0.5*3 = 1.125, (K=a,T=b) 0.375,
    # (K=b,T=a) 0.125, (b,b) 0.25*0.5*3 = 0.375; Z = 2. Kettle marginal (0.75, 0.25) as in the
    # factorised model (KL 0); teabag (1.125 + 0.125, 0.375 + 0.375) / 2 = (0.625, 0.375).
    step0 = 0.625 * math.log(0.625 / 0.5) + 0.375 * math.log(0.375 / 0.5)   # = 0.0315839...
    # Step 1: kettle at a for sure; joint teabag = P(T | K = a) = (1.125, 0.375) / 1.5 =
    # (0.75, 0.25); factorised teabag stays (0.5, 0.5).
    step1 = 0.75 * math.log(0.75 / 0.5) + 0.25 * math.log(0.25 / 0.5)        # = 0.1308120...
    # Step 2: teabag missed at b (x0.05 at b): joint (0.75, 0.0125) / 0.7625, factorised
    # (0.5, 0.025) / 0.525.
    p, q = np.array([0.75, 0.0125]) / 0.7625, np.array([0.5, 0.025]) / 0.525
    step2 = float(np.sum(p * np.log(p / q)))
    np.testing.assert_allclose(kl, [step0, step1, step2], rtol=0, atol=1e-12)
    assert step0 == pytest.approx(0.0315839, abs=1e-7) and step1 == pytest.approx(0.1308120, abs=1e-7)


def test_kl_with_the_eq4_collapse_on_the_tiny_house():
    # Eq. 4 collapses the kettle to t = (1, eps) / (1 + eps), eps = 1e-4, in both models (KL 0 on
    # the kettle). Jeffrey's rule moves the joint teabag to t_a (0.75, 0.25) + t_b (0.25, 0.75).
    eps = 1e-4
    p = (np.array([0.75, 0.25]) + eps * np.array([0.25, 0.75])) / (1 + eps)
    kl = kl_factorised_from_joint(EVIDENCE[:2], TINY, "factorised", "joint")
    assert kl[1] == pytest.approx(float(np.sum(p * np.log(p / 0.5))), abs=1e-12)


def test_kl_is_zero_without_relational_factors():
    no_relations = load_model("joint").with_overrides(relations=())
    kl = kl_factorised_from_joint(EVIDENCE, TINY, "factorised", no_relations)
    assert kl == [0.0, 0.0, 0.0]
    apartment = load_scenario("default_apartment")
    events = [start({}), obs("kitchen_counter", {"kettle": True, "mug": False, "teabag": False})]
    assert kl_factorised_from_joint(events, apartment, "factorised", no_relations) == [0.0, 0.0]


def test_kl_grows_when_the_kettle_is_found_with_co_location():
    apartment = load_scenario("default_apartment")
    events = [start({}), obs("kitchen_counter", {"kettle": True})]
    kl = kl_factorised_from_joint(events, apartment)
    # the prior already differs (co-location and capacity couple the prior); finding the kettle
    # pulls the joint teabag towards the kitchen, which the factorised belief ignores
    assert kl[0] > 0 and kl[1] > kl[0] + 1e-3


# ------------------------------------------------------------------ Brier score
HELD = [
    start({"kettle": [0.75, 0.25], "teabag": [0.5, 0.5]}),
    obs("a", {"kettle": True, "teabag": False}, {"kettle": [1.0, 0.0], "teabag": [0.2, 0.8]}),
    {"event": "belief", "sites": ["a", "b"],
     "locations": {"kettle": [1.0, 0.0], "teabag": [0.1, 0.9]}},
    obs("b", {"teabag": True}, {"teabag": [0.0, 1.0]}),
]


def test_brier_by_hand_on_the_beliefs_the_agent_held():
    scores = brier_scores(HELD, TRUTH)
    # step 0: kettle (0.75 - 1)^2 + 0.25^2 = 0.125; teabag (truth b) 0.5^2 + 0.5^2 = 0.5 -> 0.625
    # step 1: the belief snapshot after the inspection replaces the logged `after`: kettle a point
    #   mass on the truth (0); teabag 0.1^2 + 0.1^2 = 0.02
    # step 2: teabag a point mass on b, kettle carried forward: 0 (a point mass on truth)
    assert scores == pytest.approx([0.625, 0.02, 0.0], abs=1e-15)
    # without the snapshot, step 1 scores the observation's own `after`: 0.2^2 + 0.2^2 = 0.08
    assert brier_scores([e for e in HELD if e["event"] != "belief"], TRUTH)[1] == pytest.approx(0.08)


def test_brier_extremes_and_bad_truth():
    wrong = [start({"kettle": [0.0, 1.0], "teabag": [1.0, 0.0]})]
    assert brier_scores(wrong, TRUTH) == [4.0]          # 2 per object placed wholly elsewhere
    with pytest.raises(ValueError, match="teabag"):
        brier_scores(wrong, {"kettle": "a"})
    with pytest.raises(ValueError, match="not one of the sites"):
        brier_scores(wrong, {"kettle": "a", "teabag": "attic"})
    with pytest.raises(ValueError, match="episode_start"):
        brier_scores([obs("a", {"kettle": True})], TRUTH)


def test_brier_of_a_replayed_model():
    snaps = replay_location_evidence(EVIDENCE, TINY, load_model("joint").with_overrides(**EXACT))
    # step 1 (joint): kettle (1, 0) on truth: 0; teabag (0.75, 0.25), truth b: 0.75^2 * 2 = 1.125
    assert brier_scores(EVIDENCE, TRUTH, snaps)[1] == pytest.approx(1.125, abs=1e-12)


# ------------------------------------------------------------------ calibration
def test_calibration_by_hand():
    records = [(0.1, 0), (0.2, 0), (0.3, 1), (0.8, 1), (0.9, 1), (0.7, 0), (1.0, 1)]
    curve = calibration(records, bins=2)
    np.testing.assert_allclose(curve.centres, [0.25, 0.75])
    np.testing.assert_array_equal(curve.counts, [3, 4])              # q = 1 lands in the last bin
    # bin [0, 0.5): mean q (0.1 + 0.2 + 0.3) / 3 = 0.2, outcomes 1/3
    # bin [0.5, 1]: mean q (0.8 + 0.9 + 0.7 + 1.0) / 4 = 0.85, outcomes 3/4
    np.testing.assert_allclose(curve.mean_predicted, [0.2, 0.85])
    np.testing.assert_allclose(curve.observed_frequency, [1 / 3, 0.75])
    # ECE = 3/7 |0.2 - 1/3| + 4/7 |0.85 - 0.75| = 3/7 * 2/15 + 4/7 * 0.1 = 0.0571429 + 0.0571429
    assert expected_calibration_error(curve) == pytest.approx(3 / 7 * 2 / 15 + 4 / 7 * 0.1)


def test_calibration_empty_bins_and_bad_input():
    curve = calibration([(0.05, 0)], bins=4)
    np.testing.assert_array_equal(curve.counts, [1, 0, 0, 0])
    assert np.isnan(curve.mean_predicted[1]) and np.isnan(curve.observed_frequency[3])
    assert expected_calibration_error(curve) == pytest.approx(0.05)
    assert math.isnan(expected_calibration_error(calibration([], bins=3)))
    with pytest.raises(ValueError):
        calibration([(1.5, 1)])
    with pytest.raises(ValueError):
        calibration([(0.5, 1)], bins=0)


def test_calibration_pairs_cover_steps_objects_and_sites():
    pairs = calibration_pairs(HELD, TRUTH)
    assert pairs.shape == (3 * 2 * 2, 2)                    # steps x objects x sites
    # step 0, kettle: (0.75, a true), (0.25, b false); teabag: (0.5, 0), (0.5, 1)
    np.testing.assert_allclose(pairs[:4], [[0.75, 1], [0.25, 0], [0.5, 0], [0.5, 1]])
    assert pairs[:, 1].sum() == 3 * 2                       # one true site per object and step


# ------------------------------------------------------------------ whole episodes
def run(scenario: str, model: str, seed: int = 0, **config) -> EpisodeRunner:
    s, m = load_scenario(scenario), load_model(model)
    env = FakeHouse(s, env_config_for(m))
    runner = EpisodeRunner(s, m, env, RunConfig(seed=seed, **config))
    runner.run()
    return runner


@pytest.mark.parametrize("model", ["factorised", "joint"])
def test_replay_reproduces_the_beliefs_the_agent_logged(model):
    runner = run("prior_violation", model)
    held = agent_beliefs(runner.events)
    replay = replay_location_evidence(runner.events, runner.scenario, runner.model)
    n_obs = sum(e["event"] == "observation" for e in runner.events)
    assert len(held) == len(replay) == n_obs + 1 >= 3
    for h, r in zip(held, replay):
        for obj in r["locations"]:
            # the log rounds to 9 decimals
            np.testing.assert_allclose(h["locations"][obj], r["locations"][obj], rtol=0, atol=2e-9)


def test_without_snapshots_unconsidered_objects_carry_forward():
    runner = run("prior_violation", "factorised", snapshot_every_event=False)
    assert not any(e["event"] == "belief" for e in runner.events)
    held = agent_beliefs(runner.events)
    replay = replay_location_evidence(runner.events, runner.scenario, runner.model)
    for h, r in zip(held, replay):   # factorised: a found object's belief no longer moves
        for obj in r["locations"]:
            np.testing.assert_allclose(h["locations"][obj], r["locations"][obj], rtol=0, atol=2e-9)


def test_quality_summary_of_a_logged_episode(tmp_path):
    s, m = load_scenario("default_apartment"), load_model("joint")
    env = FakeHouse(s, env_config_for(m))
    with EventLog(tmp_path / "log.jsonl") as log:
        EpisodeRunner(s, m, env, RunConfig(seed=0), log).run()
    events = read_log(tmp_path / "log.jsonl")
    row = quality_summary(events, s, true_sites(s))
    assert set(row) == {"kl_mean", "kl_final", "brier_initial", "brier_mean", "brier_final", "ece"}
    assert all(isinstance(v, float) and math.isfinite(v) for v in row.values())
    kl = kl_factorised_from_joint(events, s)
    brier = brier_scores(events, true_sites(s))
    assert row["kl_mean"] == pytest.approx(float(np.mean(kl))) and row["kl_final"] == kl[-1]
    assert row["brier_initial"] == brier[0] and row["brier_final"] == brier[-1]
    # every object is found, so the final belief is close to point masses on the truth
    assert row["brier_final"] < 1e-3 < row["brier_initial"]
    assert 0.0 <= row["ece"] <= 1.0
    # truth defaults to the scenario's; with the factorised model as both references, KL is 0
    assert quality_summary(events, s)["brier_mean"] == row["brier_mean"]
    assert quality_summary(events, s, joint_model="factorised")["kl_mean"] == 0.0
