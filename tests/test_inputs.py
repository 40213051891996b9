"""Bad scenario and model files: one line naming file, path and fault; exit status 2."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from fg_tea.cli import main
from fg_tea.common.errors import InputError
from fg_tea.model.spec import load_model
from fg_tea.world.scenario import load_scenario
from houses import set_at

ROOT = Path(__file__).resolve().parent.parent
DEFAULT = json.loads((ROOT / "scenarios" / "default_apartment.json").read_text())


def _mutated(edit):
    data = copy.deepcopy(DEFAULT)
    edit(data)
    return data




def _delete(path):
    def edit(data):
        node = data
        for key in path[:-1]:
            node = node[key]
        del node[path[-1]]
    return edit


SCENARIO_FAULTS = [
    # (id, edit, expected JSON path, expected words in the fault)
    ("missing field", _delete(["objects", 0, "semantic_id"]), "$.objects[0].semantic_id", "missing required field"),
    ("mistyped field", set_at(["sites", 1, "room"], 7), "$.sites[1].room", "expected a string"),
    ("mistyped vector", set_at(["sites", 0, "position"], [1.0, 2.0]), "$.sites[0].position", "expected 3 numbers"),
    ("unknown schema version", set_at(["schema_version"], 3), "$.schema_version", "unknown schema version 3"),
    ("undefined true site", set_at(["objects", 0, "true_site"], "attic"), "$.objects[0].true_site",
     "'attic' is referenced but not defined"),
    ("undefined preparation site", set_at(["preparation_site"], "garage"), "$.preparation_site",
     "'garage' is referenced but not defined"),
    ("undefined furniture", set_at(["sites", 2, "furniture"], "piano"), "$.sites[2].furniture",
     "'piano' is referenced but not defined"),
    ("duplicate site name", set_at(["sites", 1, "name"], "kitchen_counter"), "$.sites[1].name",
     "duplicate site name"),
    ("duplicate object name", set_at(["objects", 1, "name"], "mug"), "$.objects[1].name", "duplicate object name"),
    ("duplicate semantic id", set_at(["objects", 2, "semantic_id"], 9001), "$.objects[2].semantic_id",
     "duplicate semantic id 9001"),
    ("negative affordance", set_at(["sites", 3, "affordances", "mug"], -0.2), "$.sites[3].affordances.mug",
     "negative weight"),
    ("all-zero affordances", lambda d: [s["affordances"].__setitem__("kettle", 0.0) for s in d["sites"]],
     "$.objects[1].category", "zero"),
    ("probability above 1", set_at(["objects", 1, "state_priors", "contains_water"], 1.4),
     "$.objects[1].state_priors.contains_water", "outside [0, 1]"),
    ("probability below 0", set_at(["objects", 0, "state_priors", "water_hot"], -0.1),
     "$.objects[0].state_priors.water_hot", "outside [0, 1]"),
    ("truth without prior", set_at(["objects", 2, "hidden_state_truth", "soggy"], True),
     "$.objects[2].hidden_state_truth.soggy", "no entry in state_priors"),
    ("doorway off the wall", set_at(["house", "walls", 4, "doorways", 0, "at"], 3.9),
     "$.house.walls[4].doorways[0]", "outside the wall"),
]


@pytest.mark.parametrize("edit,path,words", [f[1:] for f in SCENARIO_FAULTS], ids=[f[0] for f in SCENARIO_FAULTS])
def test_scenario_fault_is_one_line_with_exit_2(tmp_path, capsys, edit, path, words):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(_mutated(edit)))
    with pytest.raises(InputError) as info:
        load_scenario(bad)
    assert info.value.path == path
    assert words in info.value.fault
    assert main(["beliefs", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith(f"fg-tea: error: {bad}: {path}: ")
    assert words in err


def test_invalid_json_names_line_and_column(tmp_path, capsys):
    bad = tmp_path / "broken.json"
    bad.write_text('{"schema_version": 2,\n "name": }')
    assert main(["beliefs", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "broken.json: line 2 column" in err and "invalid JSON" in err


def test_schema_version_1_single_target_loads(tmp_path):
    data = copy.deepcopy(DEFAULT)
    data["schema_version"] = 1
    data["target"] = data.pop("objects")[0]
    path = tmp_path / "v1.json"
    path.write_text(json.dumps(data))
    scenario = load_scenario(path)
    assert scenario.object_names == ("mug",)
    assert scenario.object("mug").true_site == "sideboard"


MODEL = (ROOT / "models" / "factorised.toml").read_text()

MODEL_FAULTS = [
    ("missing section", MODEL.replace("[detection]", "[detection_typo]"), "$.detection", "missing required field"),
    ("mistyped", MODEL.replace("miss_likelihood = 0.05", 'miss_likelihood = "low"'),
     "$.detection.miss_likelihood", "expected a number"),
    ("probability outside", MODEL.replace("sensitivity = 0.95", "sensitivity = 1.5"),
     "$.sensors.state.sensitivity", "outside [0, 1]"),
    ("unknown structure", MODEL.replace('structure = "factorised"', 'structure = "tree"'),
     "$.beliefs.structure", "must be one of factorised, joint"),
    ("uninformative sensor", MODEL.replace("specificity = 0.95", "specificity = 0.05"),
     "$.sensors.state", "must exceed 1"),
    ("relations in factorised", MODEL + '\n[[relations]]\nkind = "capacity"\npenalty = 0.1\n',
     "$.relations", "need structure"),
    ("effect success outside", MODEL.replace("success = 0.995 }]\ngoals", "success = 1.995 }]\ngoals", 1),
     "$.transitions.fill.effects[0].success", "outside [0, 1]"),
    ("zero miss likelihood", MODEL.replace("miss_likelihood = 0.05", "miss_likelihood = 0.0"),
     "$.detection.miss_likelihood", "miss likelihood of 0"),
    ("missing parent", 'extends = "nowhere"\nname = "x"\n', "$.extends", "'nowhere' is referenced but not found"),
]


@pytest.mark.parametrize("text,path,words", [f[1:] for f in MODEL_FAULTS], ids=[f[0] for f in MODEL_FAULTS])
def test_model_fault_is_one_line_with_exit_2(tmp_path, capsys, text, path, words):
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(InputError) as info:
        load_model(bad)
    assert info.value.path == path
    assert words in info.value.fault
    assert main(["beliefs", "--model", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{bad}: {path}: " in err


def test_invalid_toml(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("name = \n")
    assert main(["validate", str(bad)]) == 2
    assert "invalid TOML" in capsys.readouterr().err


def test_every_bundled_file_validates(capsys):
    files = sorted((ROOT / "scenarios").glob("*.json")) + sorted((ROOT / "models").rglob("*.toml"))
    assert main(["validate", *map(str, files)]) == 0
    assert capsys.readouterr().out.count(": ok") == len(files)


def test_ablation_models_change_only_their_switch():
    base = load_model("factorised")
    assert load_model(ROOT / "models/ablations/no_epistemic.toml").planning.information_weight == 0.0
    assert load_model(ROOT / "models/ablations/no_relevance.toml").planning.relevance_weight == 0.0
    assert load_model(ROOT / "models/ablations/weak_negative.toml").miss_likelihood == 0.95
    assert load_model(ROOT / "models/ablations/euclidean.toml").planning.distance == "euclidean"
    assert load_model(ROOT / "models/ablations/no_repeat_penalty.toml").planning.repeat_penalty == 0.0
    assert load_model(ROOT / "models/ablations/no_site_association.toml").room_glances is False
    certain = load_model(ROOT / "models/ablations/certain_effects.toml")
    assert all(e.success == 1.0 for t in certain.transitions.values() for e in t.effects)
    assert load_model(ROOT / "models/ablations/direct_effects.toml").transition_form == "direct"
    assert base.planning.information_weight == 1.5 and base.miss_likelihood == 0.05


def test_a_category_curve_inherits_what_it_does_not_set(tmp_path):
    """[perception.visibility.categories.X] with half_pixels only keeps the curve's slope (3.0 in
    the bundled models, not the library default), and so does a camera's category table."""
    from fg_tea.env.camera import load_camera

    base = load_model("factorised").detection_curve
    path = tmp_path / "n50.toml"
    path.write_text('extends = "factorised"\nname = "n50"\n'
                    "[perception.visibility.categories.teabag]\nhalf_pixels = 80.0\n")
    camera = tmp_path / "n50_camera.toml"
    camera.write_text('name = "n50"\n[camera]\ndetector = "visibility"\n[camera.visibility]\n'
                      "half_pixels = 50\nslope = 3.0\n[camera.visibility.categories.teabag]\n"
                      "half_pixels = 80.0\n")
    for curve in (load_model(path).detection_curve, load_camera(camera).curve):
        teabag, mug = curve.params("teabag"), curve.params("mug")
        assert (teabag.half_pixels, teabag.slope) == (80.0, base.params("teabag").slope)
        assert mug == base.params("mug")
        assert curve.max_probability == base.max_probability
    same = tmp_path / "same.toml"
    same.write_text('extends = "factorised"\nname = "same"\n'
                    "[perception.visibility.categories.teabag]\nhalf_pixels = 50\n")
    assert load_model(same).detection_curve.params("teabag") == base.params("teabag")


def test_a_relative_extends_path_resolves_against_the_extending_file(tmp_path, monkeypatch):
    """``extends = "sub/base.toml"`` names a file beside the extending model, wherever the
    command runs from (it used to be resolved against the working directory)."""
    from fg_tea.model.spec import load_model

    (tmp_path / "models" / "sub").mkdir(parents=True)
    (tmp_path / "models" / "child.toml").write_text('extends = "sub/base.toml"\nname = "child"\n')
    (tmp_path / "models" / "sub" / "base.toml").write_text(
        'extends = "factorised"\nname = "base"\n[detection]\nmiss_likelihood = 0.2\n')
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    model = load_model(tmp_path / "models" / "child.toml")
    assert model.name == "child" and model.miss_likelihood == 0.2


def test_positive_update_is_named_for_what_it_does_and_the_old_name_still_reads(tmp_path):
    from fg_tea.model.spec import load_model

    assert load_model("factorised").positive_update == "collapse"
    old = tmp_path / "old.toml"
    old.write_text('extends = "factorised"\nname = "old"\n[detection]\npositive_update = "blue' 'print"\n')
    assert load_model(old).positive_update == "collapse"
