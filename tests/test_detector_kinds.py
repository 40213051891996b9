"""Detector kinds are registered objects (fg_tea/world/detectors.py, docs/how-to/add-a-detector.md).

A toy kind registered in a test is accepted by model and camera files, and the agent's view model
computes its look probabilities through the kind's own methods; a kind no one registered is one
line naming the file and the field, exit 2.
"""

from __future__ import annotations

import numpy as np
import pytest

from fg_tea.beliefs.detection import ViewModel
from fg_tea.cli.main import main
from fg_tea.common.errors import InputError
from fg_tea.env.camera import default_camera, load_camera
from fg_tea.model.spec import load_model
from fg_tea.world.detectors import (Detector, ThresholdDetector, VisibilityDetector, detector_kind,
                                    detector_names, register_detector, unregister_detector)
from fg_tea.world.scenario import load_scenario


class HalfDetector(Detector):
    """Sees an object in view with half the close-look probability, wherever it stands."""

    name = "toy_half"
    pixel_threshold = True
    miss_rate = True
    default_camera = "threshold"

    def slot_probability(self, model, category, slots, view_kind):
        return 0.5 * (1.0 - model.miss_likelihood)


@pytest.fixture
def toy():
    kind = register_detector(HalfDetector)
    yield kind
    unregister_detector(HalfDetector.name)


def _table(scenario, value):
    cats = {o.category for o in scenario.objects}
    return {v.name: {s: {c: value for c in cats} for s in v.sites} for v in scenario.viewpoints}


def test_the_built_in_kinds_are_registered_objects():
    assert detector_names()[:2] == ("threshold", "visibility")
    assert isinstance(detector_kind("threshold"), ThresholdDetector)
    assert isinstance(detector_kind("visibility"), VisibilityDetector)
    assert default_camera("visibility") == "visibility" and default_camera("threshold") == "threshold"
    model = load_model("factorised_close")
    assert model.detector_kind is detector_kind("threshold") and model.close_looks_only
    assert load_camera("visibility").kind.curve and not load_camera("threshold").kind.curve


def test_a_registered_toy_kind_is_read_from_files_and_computes_its_own_probabilities(tmp_path, toy):
    path = tmp_path / "toy.toml"
    path.write_text('extends = "factorised_close"\nname = "toy"\n[perception]\ndetector = "toy_half"\n'
                    "[viewpoints]\nroom_glances = true\n")
    model = load_model(path)
    assert model.detector == "toy_half" and model.detector_kind is toy and not model.close_looks_only
    scenario = load_scenario("default_apartment")
    views = ViewModel(scenario, model, scenario.object_names, _table(scenario, 80.0))
    mu = model.miss_likelihood
    assert views.max_probability == pytest.approx(1.0 - mu)
    for view in views.views:
        assert np.allclose(view.probability, 0.5 * (1.0 - mu))
        assert np.allclose(view.miss, 1.0 - 0.5 * (1.0 - mu))
    camera = tmp_path / "camera.toml"
    camera.write_text('name = "toy"\n[camera]\ndetector = "toy_half"\nmin_visible_pixels = 30\n')
    loaded = load_camera(camera)
    assert loaded.kind is toy and loaded.env_config().camera_curve is None
    assert default_camera("toy_half") == "threshold"


def test_registering_another_kind_under_a_taken_name_is_refused():
    class Clash(Detector):
        name = "visibility"

    with pytest.raises(ValueError, match="already registered"):
        register_detector(Clash)
    with pytest.raises(ValueError, match="built in"):
        unregister_detector("threshold")


@pytest.mark.parametrize("kind", ["model", "camera"])
def test_an_unknown_detector_kind_is_one_line_naming_file_and_field(tmp_path, capsys, kind):
    path = tmp_path / f"{kind}.toml"
    if kind == "model":
        path.write_text('extends = "factorised"\nname = "sonar"\n[perception]\ndetector = "sonar"\n')
    else:
        path.write_text('name = "sonar"\n[camera]\ndetector = "sonar"\n')
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0] and "detector" in err[0] and "sonar" in err[0], err
    with pytest.raises(InputError, match="unknown detector 'sonar'"):
        detector_kind("sonar", str(path))
