"""Model programs wherever a model goes (docs/design.md §4.8, docs/how-to/model-as-program.md).

A ``.py`` file, ``module:attr`` or entry point is a model: it runs episodes, its log names it
exactly, ``beliefs --top K`` prints its K best arrangements, ``validate`` prints its compiled plan,
``compare`` runs it; bad programs are one line and exit 2. TOML models build the engine's graph
through the same program path, to the same numbers as the former construction.
"""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path

import numpy as np
import pytest

import fg_tea as fg
from fg_tea.beliefs.compiled import compile_program
from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.beliefs.graph import assemble_graph, build_graph, prior_weights
from fg_tea.common.resources import bundled_names
from fg_tea.model.learning import location_weights
from fg_tea.model.program_file import program_for
from test_input_faults import assert_one_line_error, cli

ROOT = Path(__file__).resolve().parent.parent

PROGRAM = '''\
import fg_tea as fg
base = "joint"

def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))

    @m.factor("teabag")
    def never_on_the_study_shelf(teabag):
        return 0.0 if teabag.name == "study_shelf" else 1.0

    m.variable("tidy", [False, True])
    m.table("tidy", [0.3, 0.7], name="tidy prior")

    @m.factor("tidy", "mug", "teabag")
    def tidy_together(tidy, mug, teabag):
        return 4.0 if tidy and mug.room == teabag.room else 1.0
    return m
'''


@pytest.fixture()
def program_file(tmp_path):
    path = tmp_path / "my_model.py"
    path.write_text(PROGRAM)
    return path


def _old_build_graph(scenario, model):
    """The construction build_graph used before programs (kept here as the reference)."""
    return assemble_graph(
        model, sites=scenario.site_names, rooms=[s.room for s in scenario.sites],
        objects=scenario.object_names, categories=[o.category for o in scenario.objects],
        weights=np.stack([location_weights(model.learning, o.category, scenario.site_names,
                                           prior_weights(scenario, o.category), model.prior_floor,
                                           model.source) for o in scenario.objects]),
        capacities=[s.capacity for s in scenario.sites],
        state_priors={f"{o.name}.{n}": p for o in scenario.objects for n, p in o.state_priors.items()})


def _assert_same_graph(old, new):
    assert (old.sites, old.objects, old.rooms, old.capacities, old.structure) == \
        (new.sites, new.objects, new.rooms, new.capacities, new.structure)
    assert old.capacity_active == new.capacity_active
    if old.capacity_active:
        assert old.capacity_penalty == new.capacity_penalty
    assert [p.label for p in old.pairs] == [p.label for p in new.pairs]
    for a, b in zip(old.pairs, new.pairs):
        assert (a.a, a.b) == (b.a, b.b)
        assert abs(a.same_site - b.same_site) <= 1e-12 and abs(a.same_room - b.same_room) <= 1e-12
    assert len(old.location_priors) == len(new.location_priors)
    assert len(old.state_priors) == len(new.state_priors)
    for f, g in zip(old.location_priors + old.state_priors, new.location_priors + new.state_priors):
        assert (f.variables, f.label) == (g.variables, g.label)
        assert np.max(np.abs(f.table - g.table)) <= 1e-12
    assert not new.extra


@pytest.mark.parametrize("scenario_name", bundled_names("scenarios"))
def test_a_toml_model_builds_the_same_graph_through_its_program(scenario_name):
    scenario = fg.load_scenario(scenario_name)
    for name in bundled_names("models") + bundled_names("ablations"):
        model = fg.load_model(name)
        _assert_same_graph(_old_build_graph(scenario, model), build_graph(scenario, model))


def test_learned_relation_weights_go_through_the_program_too(tmp_path):
    path = tmp_path / "learned.toml"
    path.write_text('extends = "joint"\n[learning.co_location.kettle]\n'
                    'teabag = { same_site = 5, same_room = 1, apart = 2 }\n')
    model = fg.load_model(path)
    scenario = fg.load_scenario("prior_violation")
    new = build_graph(scenario, model)
    assert any(p.label.endswith("(learned)") for p in new.pairs)
    _assert_same_graph(_old_build_graph(scenario, model), new)


def test_a_45_site_joint_house_needs_no_capacity_table():
    """The structured capacity factor builds no K^N table unless asked (generated_large: 44 sites)."""
    scenario = fg.load_scenario("generated_large")
    graph = build_graph(scenario, fg.load_model("joint"))
    program = fg.program_from_model(scenario, fg.load_model("joint"))
    capacity = program.factor_named("capacity")
    assert capacity.form == ("capacity", graph.capacity_penalty) and capacity._table is None


def test_the_engine_and_the_compiled_program_agree(program_file):
    """The program's summed-out variable and hard zero reach the engine exactly."""
    scenario = fg.load_scenario("default_apartment")
    model = fg.load_model(program_file)
    assert model.name == "my_model" and model.structure == "joint"
    assert model.planning == fg.load_model("joint").planning
    engine = BeliefEngine(scenario, model)
    compiled = compile_program(program_for(scenario, model))
    locations = engine.locations()
    for o in scenario.object_names:
        assert np.max(np.abs(locations[o] - compiled.marginal(o))) <= 1e-12
    assert locations["teabag"][scenario.site_names.index("study_shelf")] == 0.0
    assert any("summed out: tidy" in label for label in engine.graph.relational_labels)
    for state, p in engine.states().items():
        assert abs(p - compiled.marginal(state)[1]) <= 1e-12


def test_an_episode_with_a_program_model_logs_the_program(program_file, tmp_path):
    scenario = fg.load_scenario("default_apartment")
    log = tmp_path / "episode.jsonl"
    runner = fg.run_episode(scenario, fg.load_model(program_file), env="fake", log=log)
    assert runner.metrics()["success"] is True
    start = json.loads(log.read_text().splitlines()[0])
    record = start["program"]
    assert record["sha256"] == hashlib.sha256(program_file.read_bytes()).hexdigest()
    assert record["base"] == "joint" and record["spec"] == str(program_file)
    factors = {f["name"]: f["scope"] for f in record["factors"]}
    assert factors["never_on_the_study_shelf"] == ["teabag"]
    assert factors["tidy_together"] == ["tidy", "mug", "teabag"]
    assert start["model"] == "my_model"
    toml = fg.run_episode(scenario, fg.load_model("joint"), env="fake")
    assert "program" not in toml.events[0]


def test_beliefs_top_k_prints_the_exact_k_best(program_file):
    status, out, err = cli(["beliefs", "--model", program_file, "--top", "3"])
    assert status == 0, err
    ranked = re.findall(r"^\s+(\d)\. p=([0-9.]+)  (.*)$", out, re.M)
    assert [r[0] for r in ranked] == ["1", "2", "3"]
    scenario = fg.load_scenario("default_apartment")
    best = compile_program(program_for(scenario, fg.load_model(program_file))).kbest(3)
    for (_, p, text), arrangement in zip(ranked, best):
        assert float(p) == pytest.approx(arrangement.probability, abs=1e-6)
        assert f"teabag on {arrangement.values['teabag'].name}" in text
    status, out, err = cli(["beliefs", "--model", "joint", "--top", "2", "milk_sugar_apartment"])
    assert status == 0 and "2 most probable arrangements" in out, err
    status, _, err = cli(["beliefs", "--top", "0"])
    assert status == 2 and "--top" in err


def test_validate_prints_the_compiled_plan(program_file):
    status, out, err = cli(["validate", program_file])
    assert status == 0, err
    assert "ok (model program, base joint" in out
    assert "location queries by the dense method" in out
    for words in ("variables:", "tidy_together (tidy, mug, teabag)", "elimination width", "largest table"):
        assert words in out, words


def test_a_module_attribute_reference_is_a_model(program_file, monkeypatch, tmp_path):
    import sys

    monkeypatch.chdir(program_file.parent)
    sys.modules.pop("my_model", None)
    status, out, err = cli(["beliefs", "--model", "my_model:model"])
    assert status == 0, err
    assert "model my_model:model (joint)" in out
    log = tmp_path / "module.jsonl"
    fg.run_episode(fg.load_scenario("default_apartment"), fg.load_model("my_model:model"), env="fake", log=log)
    text = log.read_text().splitlines()[0]
    start = json.loads(text)
    assert start["model_file"] == "my_model:model" and start["program"]["file"] == "my_model.py"
    assert start["program"]["sha256"] == hashlib.sha256(program_file.read_bytes()).hexdigest()
    assert str(tmp_path) not in text  # no absolute path in the log
    sys.modules.pop("my_model", None)


def test_compare_runs_a_program_model(program_file, tmp_path):
    status, out, err = cli(["compare", "--executor", "serial", "--env", "fake", "--worlds", "2",
                            "--planners", "nearest", "--models", program_file, "factorised",
                            "--out", tmp_path / "out"])
    assert status == 0, err
    import csv

    with (tmp_path / "out" / "episodes.csv").open(newline="") as fh:
        models = [row["model"] for row in csv.DictReader(fh)]
    assert sorted(models) == ["factorised", "factorised", "my_model", "my_model"]


def test_learning_a_program_into_a_toml_file_is_refused_in_one_line(program_file, tmp_path):
    """A program's learned tables are a program (tests/test_program_learning.py), never a TOML file."""
    status, _, err = cli(["learn", "--base", program_file, "--out", tmp_path / "m.toml"])
    assert_one_line_error(status, err, "must end in .py")


BAD = {
    "raises": ('''
def model(scenario):
    m = fg.Program.from_scenario(scenario)
    m.location("mug")
    m.function(["mug"], lambda mug: 1 / 0, name="broken")
    return m
''', ["factor 'broken'", "ZeroDivisionError"]),
    "nan": ('''
def model(scenario):
    m = fg.Program.from_scenario(scenario)
    m.location("mug")
    m.function(["mug"], lambda mug: float("nan"), name="nan")
    return m
''', ["factor 'nan'", "nan"]),
    "negative": ('''
def model(scenario):
    m = fg.Program.from_scenario(scenario)
    m.location("mug")
    m.function(["mug"], lambda mug: -1.0, name="neg")
    return m
''', ["factor 'neg'", "-1.0"]),
    "all zero": ('''
def model(scenario):
    m = fg.Program.from_scenario(scenario)
    m.location("mug")
    m.function(["mug"], lambda mug: 0.0, name="zero")
    return m
''', ["factor 'zero'", "every weight is zero"]),
    "unknown variable": ('''
def model(scenario):
    m = fg.Program.from_scenario(scenario)
    m.function(["spoon"], lambda s: 1.0, name="spoon prior")
    return m
''', ["factor 'spoon prior'", "unknown variable 'spoon'"]),
    "unknown site": ('''
def model(scenario):
    m = fg.Program.from_scenario(scenario)
    m.location("mug")
    m.table("mug", {"attic": 1.0}, name="attic")
    return m
''', ["factor 'attic'", "unknown site 'attic'"]),
    "no model function": ("x = 1\n", ["not a model program", "defines no function model"]),
    "returns no program": ("def model(scenario):\n    return 3\n", ["returned int, not a fg.Program"]),
    "not python": ('extends = "joint"\n[learning.co_location.kettle]\nteabag = { same_site = 5 }\n',
                   ["not a Python model program", "SyntaxError"]),
    "raises on import": ("raise RuntimeError('boom')\n", ["importing it raised RuntimeError: boom"]),
    "exits": ("def model(scenario):\n    raise SystemExit(0)\n", ["called exit(0)"]),
    "couples four task states with locations": ('''
def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model("factorised"))
    m.function(["mug", "kettle", "mug.served", "mug.tea_brewed", "mug.water_hot", "kettle.water_hot"],
               lambda mug, kettle, s, b, w, h: 2.0 if s else 1.0, name="served where")
    return m
''', ["factor 'served where'", "couples 4 task states with locations; at most 3", "§4.8"]),
    "never returns": ("def model(scenario):\n    while True:\n        pass\n",
                      ["did not finish within 0.3 s", "FG_TEA_MODEL_SECONDS"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_program_is_one_line_and_exit_2(case, tmp_path, monkeypatch):
    body, words = BAD[case]
    path = tmp_path / "bad_model.py"
    path.write_text("import fg_tea as fg\n" + body if "def model" in body else body)
    monkeypatch.setenv("FG_TEA_MODEL_SECONDS", "0.3")
    for argv in (["beliefs", "--model", path], ["validate", path]):
        status, _, err = cli(argv)
        assert_one_line_error(status, err, str(path), *words)


def test_the_time_limit_is_stated_in_help():
    status, out, _ = cli(["validate", "--help"])
    assert status == 0 and "FG_TEA_MODEL_SECONDS" in out and "60" in out


def test_the_how_to_page_runs_as_it_stands(tmp_path, monkeypatch):
    """docs/how-to/model-as-program.md: its model file is <= 25 lines, and its Python blocks run
    as they stand, in order, printing marginals and the top 3 arrangements."""
    text = (ROOT / "docs" / "how-to" / "model-as-program.md").read_text(encoding="utf-8")
    blocks = re.findall(r"^```python\n(.*?)^```", text, re.M | re.S)
    assert blocks and blocks[0].startswith("# my_model.py\n")
    assert len(blocks[0].strip().splitlines()) <= 25
    monkeypatch.chdir(tmp_path)
    printed = []
    for body in blocks:
        first = body.split("\n", 1)[0]
        if first.startswith("# ") and first.endswith(".py"):
            (tmp_path / first[2:].strip()).write_text(body)
        if first.strip() != "# my_model.py":  # the model file is run by the episode block
            import contextlib
            import io

            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                exec(compile(body, first, "exec"), {"__name__": "__main__"})
            printed.append(out.getvalue())
    output = "".join(printed)
    assert "q(L[teabag])" in output or "teabag" in output
    assert len(re.findall(r"^\s*[123]\. p=", output, re.M)) == 3


def test_an_entry_point_names_a_model(program_file, monkeypatch):
    """A name registered in the fg_tea.models entry-point group is a model (as planner plug-ins are)."""
    import importlib.metadata
    import sys

    from fg_tea.common import resources

    monkeypatch.syspath_prepend(str(program_file.parent))
    sys.modules.pop("my_model", None)
    point = importlib.metadata.EntryPoint("tidy_house", "my_model:model", resources.MODEL_ENTRY_POINT_GROUP)
    monkeypatch.setattr(resources, "model_entry_points", lambda: {"tidy_house": point})
    model = fg.load_model("tidy_house")
    assert model.name == "tidy_house" and model.program.base == "joint"
    graph = build_graph(fg.load_scenario("default_apartment"), model)
    assert any("tidy_together" in label for label in graph.relational_labels)
    sys.modules.pop("my_model", None)


def test_the_agent_and_the_gymnasium_env_take_a_program(program_file):
    from fg_tea.episode.gym_env import TeaEnv

    scenario = fg.load_scenario("default_apartment")
    agent = fg.Agent(scenario, fg.load_model(program_file))
    assert agent.belief.location_map("teabag")["study_shelf"] == 0.0
    env = TeaEnv(scenario, str(program_file), env="fake")
    try:
        assert env.model.program is not None and env.model.name == "my_model"
        env.reset(seed=0)
    finally:
        env.close()


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_compare_at_scale_compares_a_program_model(program_file, tmp_path):
    import subprocess
    import sys

    out = tmp_path / "cas"
    done = subprocess.run([sys.executable, "experiments/compare_at_scale.py", "--table", "houses", "--sizes",
                           "small", "--tasks", "make_tea", "--worlds", "2", "--env", "fake", "--planners",
                           "nearest", "--executor", "serial", "--timing-worlds", "0",
                           "--models", "factorised", str(program_file), "--out", str(out)],
                          capture_output=True, text=True, stdin=subprocess.DEVNULL, cwd=ROOT, timeout=600)
    assert done.returncode == 0, done.stderr
    import csv

    with (out / "houses" / "episodes.csv").open(newline="") as fh:
        models = [row["model"] for row in csv.DictReader(fh)]
    assert sorted(models) == ["factorised", "factorised", "my_model", "my_model"]
    assert "| small | make_tea | nearest | 2 |" in (out / "houses" / "houses.md").read_text()
    wrong = subprocess.run([sys.executable, "experiments/compare_at_scale.py", "--models", str(program_file),
                            "factorised", "--out", str(tmp_path / "x")],
                           capture_output=True, text=True, stdin=subprocess.DEVNULL, cwd=ROOT, timeout=600)
    assert wrong.returncode == 2 and "first must have a factorised belief" in wrong.stderr


def test_what_a_program_leaves_undeclared_keeps_the_base_priors(tmp_path):
    """A program from scratch declaring only the teabag: the teabag's prior is its normalised
    table, the mug, kettle and task states keep the base (default) model's priors."""
    path = tmp_path / "scratch.py"
    path.write_text("import fg_tea as fg\n\ndef model(scenario):\n    m = fg.Program.from_scenario(scenario)\n"
                    "    m.location('teabag')\n    m.table('teabag', {'pantry_shelf': 3.0, 'sideboard': 1.0})\n"
                    "    return m\n")
    scenario = fg.load_scenario("default_apartment")
    model = fg.load_model(path)
    assert model.program.base == "factorised" and model.structure == "factorised"
    graph, base = build_graph(scenario, model), build_graph(scenario, fg.load_model("factorised"))
    teabag = dict(zip(scenario.site_names, graph.location_priors[scenario.object_names.index("teabag")].table))
    assert teabag["pantry_shelf"] == 0.75 and teabag["sideboard"] == 0.25 and sum(teabag.values()) == 1.0
    for i, o in enumerate(scenario.object_names):
        if o != "teabag":
            assert np.array_equal(graph.location_priors[i].table, base.location_priors[i].table)
    assert [f.table.tolist() for f in graph.state_priors] == [f.table.tolist() for f in base.state_priors]


def test_beliefs_joint_prints_the_exact_joint_of_any_set(program_file):
    status, out, err = cli(["beliefs", "--model", program_file, "--joint", "mug", "tidy"])
    assert status == 0, err
    scenario = fg.load_scenario("default_apartment")
    joint = compile_program(program_for(scenario, fg.load_model(program_file))).joint(["mug", "tidy"])
    rows = re.findall(r"^(\w+)\s+(true|false)\s+([0-9.]+)$", out, re.M)
    assert len(rows) == joint.size == 16
    for site, tidy, p in rows:
        assert float(p) == pytest.approx(joint[scenario.site_names.index(site), int(tidy == "true")], abs=1e-6)
    status, out, err = cli(["beliefs", "--model", program_file, "--joint", "mug", "spoon"])
    assert_one_line_error(status, err, "variable 'spoon': unknown variable")
    assert out == ""


def test_which_references_name_a_program():
    from fg_tea.common.resources import is_program_ref

    assert [is_program_ref(r) for r in ("my_model.py", "pkg.mod:model", "joint", "no_epistemic",
                                         "models/joint.toml", "a:b.toml", "nothing_here", "a\x00b")] == \
        [True, True, False, False, False, False, False, False]


def test_a_program_beyond_the_dense_joint_is_answered_exactly(tmp_path):
    """44 sites, 5 objects (44^5 joint states): the program's own pair factors reach the engine as
    extra factors, which it answers by variable elimination, equal to the compiled program."""
    path = tmp_path / "pairs.py"
    path.write_text("import fg_tea as fg\n\ndef model(scenario):\n"
                    "    m = fg.program_from_model(scenario, fg.load_model('factorised'))\n"
                    "    m.function(['milk', 'sugar'], lambda a, b: 3.0 if a.distance(b) < 2.0 else 1.0, name='near')\n"
                    "    m.function(['mug', 'kettle'], lambda a, b: 2.0 if a.room == b.room else 1.0, name='room')\n"
                    "    return m\n")
    scenario = fg.load_world("generated_large_milk_sugar").sample(0)
    model = fg.load_model(path)
    engine = BeliefEngine(scenario, model)
    assert engine.graph.joint_size > 4_000_000 and engine.location_method == "elimination"
    assert [f.label for f in engine.graph.extra] == ["near", "room"]
    compiled = compile_program(program_for(scenario, model))
    locations = engine.locations()
    for o in scenario.object_names:
        assert np.max(np.abs(locations[o] - compiled.marginal(o))) <= 1e-12
