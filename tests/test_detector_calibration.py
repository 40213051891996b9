"""Does the agent's expected P(seen) match what the PyBullet camera detects?

The agent's view model averages the visibility curve over the pixel counts the environment
*expects* for a category at each placement slot of a site from a viewpoint (house geometry only,
computed once per house), each slot equally likely; the camera draws each detection from the same
curve at the pixel count it *renders*. With the object alone at a uniformly drawn slot of its
site, as the model assumes, the two agree only if the expected pixel counts match what the camera
renders: this test checks both the pixel counts look by look (against the count expected at the
slot the object stood at) and the detected frequencies against the model's Poisson-binomial 95 %
interval, for the teabag (smallest object) and the kettle (largest) at close and glance distance
on default_apartment. It uses ``experiments/check_detector_calibration.py`` (the full check).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "experiments" / "check_detector_calibration.py"

#: Looks per (object, look kind): 60 gives a standard deviation of the detected fraction of about
#: 0.06 at the teabag's glance p (~0.35), where a 30 % error in the expected pixel count moves p by
#: about 0.17 (the curve's slope 3 per unit ln n), so such an error falls outside the interval.
LOOKS = 60


def _calibration_module():
    spec = importlib.util.spec_from_file_location("check_detector_calibration", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the class is built
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def calibration():
    from fg_tea.model.spec import load_model
    from fg_tea.world.scenario import load_scenario

    cal = _calibration_module()
    calibrator = cal.Calibrator(load_scenario("default_apartment"), load_model("factorised"))
    rng = np.random.default_rng(20240607)
    close = [v.name for v in calibrator.scenario.viewpoints if v.kind == "site"]
    rooms = [v.name for v in calibrator.scenario.viewpoints if v.kind == "room"]
    records = {}
    try:
        for obj in ("teabag", "kettle"):
            for kind, names in (("site", close), ("room", rooms)):
                recs = []
                for _ in range(LOOKS):
                    view = names[rng.integers(len(names))]
                    # crowd=False: every other object stands out of view, the target alone, at
                    # a slot of its site drawn uniformly (the model's assumption).
                    recs += [r for r in calibrator.look(rng, viewpoint=view, target=obj, crowd=False,
                                                        uniform_slot=True)
                             if r.obj == obj]
                records[obj, kind] = recs
        yield cal, calibrator, records
    finally:
        calibrator.close()


@pytest.mark.parametrize("obj", ["teabag", "kettle"])
@pytest.mark.parametrize("kind", ["site", "room"])
def test_rendered_pixels_match_the_expected_counts(calibration, obj, kind):
    _, _, records = calibration
    recs = records[obj, kind]
    assert len(recs) == LOOKS  # the target alone stands in view, once per look
    assert all(r.setup == "alone" for r in recs)
    assert all(r.slot >= 0 for r in recs)
    assert len({r.slot for r in recs}) > 1  # the slots vary
    ratio = np.array([r.pixels / r.slot_pixels for r in recs if r.slot_pixels > 0])
    # The look faces its site to within the turn tolerance (2.5 deg), the probe exactly: a small
    # object far away then covers a few pixels more or fewer (the probe rendered at the look's
    # own heading gives the look's count exactly). Teabag glances at default_apartment's 21
    # (site, slot) pairs: 0.79-1.21, mean 0.985; close looks and the kettle closer to 1.
    assert np.all((ratio > 0.75) & (ratio < 1.33)), ratio
    assert 0.9 < float(np.mean(ratio)) < 1.1, float(np.mean(ratio))


@pytest.mark.parametrize("obj", ["teabag", "kettle"])
@pytest.mark.parametrize("kind", ["site", "room"])
def test_detected_frequency_within_the_models_interval(calibration, obj, kind):
    cal, _, records = calibration
    recs = records[obj, kind]
    p = np.array([r.p for r in recs])
    k = sum(r.detected for r in recs)
    lo, hi, _ = cal.interval(p, 0.95)
    assert lo <= k <= hi, (f"{obj} {kind}: {k}/{len(recs)} detected, model expects "
                           f"{p.sum():.1f} (95 % interval {lo}..{hi})")


def test_glance_is_less_likely_than_close_look_and_kettle_beats_teabag(calibration):
    _, calibrator, _ = calibration
    views = calibrator.views
    glances = [v for v in calibrator.scenario.viewpoints if v.kind == "room"]
    assert glances
    for vp in glances:
        glance = views.probabilities(vp.name)
        for site in vp.sites:
            close = views.probabilities(site)
            assert glance["teabag"][site] < close["teabag"][site], (vp.name, site)
            assert glance["kettle"][site] > glance["teabag"][site], (vp.name, site)


def test_poisson_binomial_interval():
    cal = _calibration_module()
    # Equal p: the binomial. Binomial(100, 0.5) central 95 %: 40..60.
    lo, hi, pmf = cal.interval(np.full(100, 0.5))
    assert (lo, hi) == (40, 60)
    assert pmf.sum() == pytest.approx(1.0)
    # Mixed p: mean and variance are the sums.
    p = np.array([0.1, 0.9, 0.5, 0.3])
    pmf = cal.poisson_binomial(p)
    k = np.arange(len(pmf))
    assert (pmf * k).sum() == pytest.approx(p.sum())
    assert (pmf * (k - p.sum()) ** 2).sum() == pytest.approx((p * (1 - p)).sum())
    assert cal.two_sided_p(pmf, 0) == pytest.approx(min(1.0, 2 * pmf[0]))
