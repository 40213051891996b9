"""Which factors moved a belief (fg_tea/beliefs/attribution.py) and the exact method of each query
(fg_tea/beliefs/query_methods.py), both in ``episode_start`` (docs/design.md §4.8, docs/log-format.md).

The attribution is checked against brute force: the joint of every program variable enumerated
from the program's own tables (its own variables and task states included), once with every
factor and once without each, each object's marginal compared by total variation.
"""

from __future__ import annotations

import json
import string
from pathlib import Path

import numpy as np
import pytest

import fg_tea as fg
from fg_tea.beliefs.attribution import MOVED_BY_TV, FactorAttribution, total_variation
from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.beliefs.factors import Evidence, location_var
from fg_tea.beliefs.query_methods import inference_record
from fg_tea.cli.main import main
from fg_tea.model.program_file import program_for

ROOT = Path(__file__).resolve().parent.parent

#: A unary factor, a three-object factor, a state of the program's own summed out onto the mug,
#: and a coupling of a task state the scenario tracks with the kettle's location; on the joint
#: model (capacity, co-location).
PROGRAM = '''\
import fg_tea as fg
base = "joint"

def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))
    counter = m.site("kitchen_counter")

    @m.factor("teabag")
    def never_in_study(teabag):
        return 0.0 if teabag.room == "study" else 1.0

    @m.factor("mug", "teabag", "kettle")
    def kept_together(mug, teabag, kettle):
        return 6.0 if mug.room == teabag.room == kettle.room else 1.0

    m.state("mug.dirty")
    m.table("mug.dirty", [0.4, 0.6], name="dirty prior")

    @m.factor("mug.dirty", "mug")
    def near_counter_when_dirty(dirty, mug):
        return 8.0 if dirty and mug.distance(counter) < 1.5 else 1.0

    @m.factor("kettle.contains_water", "kettle")
    def full_kettle_by_counter(full, kettle):
        return 10.0 if full and kettle.name == "kitchen_counter" else 1.0
    return m
'''


@pytest.fixture()
def setting(tmp_path):
    path = tmp_path / "attributed.py"
    path.write_text(PROGRAM)
    scenario = fg.load_scenario("default_apartment")
    model = fg.load_model(path)
    return scenario, model, program_for(scenario, model)


def _brute_marginals(program, objects, evidence, drop=()):
    """Each object's location marginal from the product of the program's factors (those named in
    `drop` left out) and the looks' evidence, by enumerating every variable of the program."""
    variables = [v.name for v in program.variables]
    letters = dict(zip(variables, string.ascii_letters))
    operands = [np.ones(v.card) for v in program.variables]  # every variable, with or without factors
    subscripts = [letters[v] for v in variables]
    for f in program.factors:
        if f.name not in drop:
            operands.append(np.asarray(f.table, dtype=float))
            subscripts.append("".join(letters[s] for s in f.scope))
    for obj, likelihood in evidence.items():
        operands.append(likelihood)
        subscripts.append(letters[obj])
    joint = np.einsum(",".join(subscripts) + "->" + "".join(letters[v] for v in variables), *operands)
    out = {}
    for obj in objects:
        axis = variables.index(obj)
        m = joint.sum(axis=tuple(a for a in range(joint.ndim) if a != axis))
        out[obj] = m / m.sum()
    return out


def _members(label):
    """The program factors an attributed label stands for (a summed-out group names each)."""
    return tuple(label.split(" (summed out: ")[0].split(" * "))


def _evidence(engine):
    return {f.variables[0][2:-1]: np.exp(f.log_table - np.max(f.log_table))
            for f in engine._loc_factors if isinstance(f, Evidence)}


def test_the_attribution_is_a_brute_force_leave_one_out(setting):
    scenario, model, program = setting
    engine = BeliefEngine(scenario, model)
    engine.observe_site("kitchen_counter", {"mug": False, "teabag": False})
    engine.observe_site("dining_table", {"kettle": False})
    attribution = FactorAttribution(engine, program)
    moved, note = attribution.moved_by(engine)
    assert note is None
    evidence = _evidence(engine)
    objects = list(engine.objects)
    whole = _brute_marginals(program, objects, evidence)
    for obj in objects:  # the attribution's belief is the engine's, which is brute force's
        assert np.max(np.abs(whole[obj] - engine.location(obj))) <= 1e-12
    expected: dict[str, dict[str, float]] = {}
    for label in attribution.factors:
        without = _brute_marginals(program, objects, evidence, drop=_members(label))
        for obj in objects:
            tv = total_variation(whole[obj], without[obj])
            if tv > MOVED_BY_TV:
                expected.setdefault(obj, {})[label] = tv
    assert set(moved) == set(expected)
    for obj in expected:
        assert set(moved[obj]) == set(expected[obj]), obj
        for label, tv in expected[obj].items():
            assert abs(moved[obj][label] - tv) <= 1e-9, (obj, label)
        assert list(moved[obj].values()) == sorted(moved[obj].values(), reverse=True)
    # Not a vacuous check: each kind of factor moved some object's belief here.
    named = {label for v in moved.values() for label in v}
    assert {"never_in_study", "kept_together", "full_kettle_by_counter"} <= named
    assert any(label.startswith("dirty prior * near_counter_when_dirty (summed out") for label in named)
    assert not any(label.startswith("prior ") for label in named)  # an object's prior is the baseline


def test_every_backend_gives_the_same_attribution(setting):
    """The solves are the compiled engine's; each is checked against the belief's own marginals,
    which gtsam (the engine of record) and the compiled block answer too."""
    scenario, model, program = setting
    found = []
    for backend in ("numpy", "gtsam", "compiled"):
        engine = BeliefEngine(scenario, model, backend=backend)
        engine.observe_site("sideboard", {"mug": False, "kettle": False})
        found.append(FactorAttribution(engine, program).fields(engine))
    assert "moved_by" in found[0] and "moved_by_note" not in found[0]
    for other in found[1:]:
        assert set(other) == {"moved_by"}
        assert {o: set(v) for o, v in other["moved_by"].items()} == {o: set(v) for o, v in found[0]["moved_by"].items()}
        for o, v in other["moved_by"].items():
            assert all(abs(tv - found[0]["moved_by"][o][f]) <= 1e-9 for f, tv in v.items())


def test_a_factorised_toml_model_has_nothing_to_attribute():
    engine = BeliefEngine(fg.load_scenario("default_apartment"), fg.load_model("factorised"))
    attribution = FactorAttribution(engine)
    assert attribution.factors == ()
    assert attribution.fields(engine) == {}
    assert inference_record(engine, attribution) == {
        "solver": "numpy", "locations": "independent", "states": "dense",
        "attribution": {"factors": [], "threshold_tv": MOVED_BY_TV, "budget": 20_000_000}}


def test_an_over_budget_step_is_skipped_with_a_note(setting, monkeypatch):
    scenario, model, program = setting
    engine = BeliefEngine(scenario, model)
    monkeypatch.setattr("fg_tea.beliefs.attribution.ATTRIBUTION_BUDGET", 100)
    fields = FactorAttribution(engine, program).fields(engine)
    assert "moved_by" not in fields
    assert fields["moved_by_note"].startswith("skipped: ") and "budget 100" in fields["moved_by_note"]


def test_a_capacity_only_the_subset_program_holds_is_noted_not_attributed(tmp_path):
    house = tmp_path / "five.json"
    assert main(["house", "--rooms", "6", "--seed", "7", "--objects", "mug,kettle,teabag,milk,sugar",
                 "--out", str(house)]) == 0
    engine = BeliefEngine(fg.load_scenario(house), fg.load_model("joint"))
    assert engine.graph.joint_size > 4_194_304 and engine.location_method == "structured"
    attribution = FactorAttribution(engine)
    assert attribution.factors == () and attribution.fields(engine) == {}
    [note] = attribution.record()["notes"]
    assert note.startswith("nothing attributed: the capacity factor over 5 objects x 27 sites is held only by "
                           "the subset program (14,348,907 joint states")


@pytest.mark.parametrize("solver, method", [("numpy", "dense"), ("gtsam", "gtsam"), ("compiled", "compiled")])
def test_the_log_records_the_method_and_the_factors(setting, tmp_path, solver, method):
    scenario, model, _ = setting
    out = tmp_path / solver
    assert main(["run", "default_apartment", "--model", str(tmp_path / "attributed.py"), "--seed", "0",
                 "--solver", solver, "--env", "fake", "--no-video", "--out", str(out)]) == 0
    events = [json.loads(line) for line in (out / "episode.jsonl").read_text().splitlines()]
    inference = events[0]["inference"]
    assert (inference["solver"], inference["locations"]) == (solver, method)
    assert inference["states"] == ("gtsam" if solver == "gtsam" else "dense")
    if solver == "compiled":
        [component] = inference["components"]  # the three-object factor joins every location
        assert component["variables"] == [location_var(o) for o in scenario.object_names]
        assert component["method"] == "dense joint" and component["states"] == 8 ** 3
    else:
        assert "components" not in inference
    assert "never_in_study" in inference["attribution"]["factors"]
    assert "kept_together" in events[0]["belief"]["moved_by"]["teabag"]
    assert any("moved_by" in e for e in events if e["event"] == "belief")
