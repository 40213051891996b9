"""The camera file configures the camera, the model file the agent (docs/design.md §1.3)."""

from __future__ import annotations

import json
import textwrap

import pytest

import fg_tea as fg
from fg_tea.cli.main import main
from fg_tea.common.errors import InputError
from fg_tea.env.camera import camera_names, load_camera
from fg_tea.episode.runner import env_config_for


def test_the_bundled_cameras_and_each_models_default_camera():
    assert set(camera_names()) >= {"visibility", "threshold", "no_site_association"}
    visibility = env_config_for(fg.load_model("factorised"))
    assert visibility.camera_curve == load_camera("visibility").curve
    assert visibility.camera_curve.half_pixels == 50.0 and visibility.site_association
    close = env_config_for(fg.load_model("factorised_close"))
    assert close.camera_curve is None and close.min_visible_pixels == 25
    ablation = env_config_for(fg.load_model("no_site_association"), "no_site_association")
    assert ablation.site_association is False and ablation.camera_curve is not None


def test_the_models_assumed_curve_does_not_move_the_camera(tmp_path):
    """Before the split, a model's [perception.visibility] set the camera's curve as well."""
    model = tmp_path / "myopic.toml"
    model.write_text('extends = "factorised"\nname = "myopic"\n'
                     "[perception.visibility]\nhalf_pixels = 500\n")
    loaded = fg.load_model(model)
    assert loaded.detection_curve.half_pixels == 500.0
    assert env_config_for(loaded).camera_curve.half_pixels == 50.0


@pytest.mark.parametrize("table, key", [("[perception]\nsite_association = false\n", "site_association"),
                                        ("[detection.visibility]\nhalf_pixels = 40\n", "visibility")])
def test_a_model_key_that_moved_to_the_camera_is_refused_by_name(tmp_path, capsys, table, key):
    model = tmp_path / "old.toml"
    model.write_text(f'extends = "factorised"\nname = "old"\n{table}')
    assert main(["validate", str(model)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(model) in err[0] and key in err[0] and "camera file" in err[0]


CAMERA = textwrap.dedent("""
    name = "mine"
    [camera]
    detector = "threshold"
    min_visible_pixels = 40
""")


@pytest.mark.parametrize("edit, key", [
    (("detector = \"threshold\"", "detector = \"thresold\""), "detector"),
    (("min_visible_pixels = 40", "min_visible_pixel = 40"), "min_visible_pixel"),
    (("min_visible_pixels = 40", "min_visible_pixels = 0"), "min_visible_pixels"),
    (("detector = \"threshold\"", "detector = \"visibility\""), "min_visible_pixels"),
    (("min_visible_pixels = 40", "min_visible_pixels = 40\n[camera.visibility]\nslope = 2"), "visibility"),
    (('name = "mine"', 'name = ""'), "name"),
])
def test_a_bad_camera_file_gets_one_line_naming_the_key(tmp_path, capsys, edit, key):
    path = tmp_path / "camera.toml"
    path.write_text(CAMERA.replace(*edit))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0] and key in err[0], err


def test_a_good_camera_file_validates_and_sets_the_environment(tmp_path, capsys):
    path = tmp_path / "camera.toml"
    path.write_text(CAMERA)
    assert main(["validate", str(path), "visibility"]) == 0
    assert capsys.readouterr().out.count(": ok (camera)") == 2
    assert env_config_for(fg.load_model("factorised"), path).min_visible_pixels == 40


def test_a_mistyped_camera_name_gets_did_you_mean(capsys):
    assert main(["run", "--camera", "visiblity", "--no-video", "--out", "unused"]) == 2
    err = capsys.readouterr().err
    assert "did you mean 'visibility'" in err and len(err.strip().splitlines()) == 1


def test_a_pixel_threshold_under_the_visibility_camera_is_refused(capsys, tmp_path):
    assert main(["run", "--min-visible-pixels", "40", "--no-video", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "min_visible_pixels: has no effect with camera 'visibility'" in err
    assert not (tmp_path / "episode.jsonl").exists()


def test_a_misspecified_agent_runs_and_its_log_names_the_camera(tmp_path):
    """The close-look model in the visibility camera's world: a model that is wrong on purpose."""
    scenario, model = fg.load_scenario("default_apartment"), fg.load_model("factorised_close")
    env = fg.make_env(scenario, model, "fake", camera="visibility")
    assert env.config.camera_curve is not None
    runner = fg.run_episode(scenario, model, env=env, log=tmp_path / "episode.jsonl")
    env.close()
    start = json.loads((tmp_path / "episode.jsonl").read_text().splitlines()[0])
    assert start["inputs"]["camera"]["bundled"] == "cameras/visibility.toml"
    assert len(start["inputs"]["camera"]["sha256"]) == 64
    assert start["parameters"]["env"]["camera_curve"]["half_pixels"] == 50.0
    assert start["parameters"]["detection"]["detector"] == "threshold"
    assert runner.reason in ("complete", "frame_limit")


def test_an_override_of_a_camera_field_is_refused():
    with pytest.raises(InputError, match="site_association: is set by the camera file"):
        load_camera("visibility").env_config(site_association=False)


def test_a_pixel_threshold_in_a_visibility_model_is_refused(tmp_path, capsys):
    """The agent's pixel threshold belongs to the threshold detector; a visibility model ignored it."""
    model = tmp_path / "m.toml"
    model.write_text('extends = "factorised"\nname = "m"\n[perception]\nmin_visible_pixels = 40\n')
    assert main(["validate", str(model)]) == 2
    err = capsys.readouterr().err.strip()
    assert "min_visible_pixels: has no effect with detector = \"visibility\"" in err
    close = tmp_path / "c.toml"
    close.write_text('extends = "factorised_close"\nname = "c"\n[perception]\nmin_visible_pixels = 40\n')
    assert fg.load_model(close).min_visible_pixels == 40


def test_a_visibility_curve_in_a_threshold_model_is_refused(tmp_path, capsys):
    """The curve the agent assumes is the visibility detector's; a threshold model ignored it. A
    curve inherited from a parent (factorised_close extends factorised) is the parent's, not a
    setting of this file."""
    model = tmp_path / "m.toml"
    model.write_text('extends = "factorised_close"\nname = "m"\n[perception.visibility]\nhalf_pixels = 10\n')
    assert main(["validate", str(model)]) == 2
    err = capsys.readouterr().err.strip()
    assert "perception.visibility: has no effect with detector = \"threshold\"" in err and "\n" not in err
    inherited = tmp_path / "i.toml"
    inherited.write_text('extends = "factorised"\nname = "i"\n[perception]\ndetector = "threshold"\n')
    assert fg.load_model(inherited).detector == "threshold"
