"""The modelling API (docs/design.md §4.8): declaring programs, factors over site attributes, a
state and a location in one factor, editing a bundled model's program, the compiled plan, and
one clear line for every bad program."""

from __future__ import annotations

import math
import pydoc

import numpy as np
import pytest

import fg_tea as fg
from fg_tea.beliefs.compiled import compile_program, plan_text
from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.common.errors import InputError
from fg_tea.model.program import Program, SiteValue
from fg_tea.model.program_bundled import program_from_model

TOL = 1e-12


@pytest.fixture(scope="module")
def scenario():
    return fg.load_scenario("default_apartment")


def test_location_values_carry_their_site(scenario):
    m = Program.from_scenario(scenario)
    mug = m.location("mug")
    assert mug.key == "L[mug]" and mug.card == len(scenario.sites)
    assert [v.name for v in mug.values] == list(scenario.site_names)
    side = m.site("side_table")
    assert isinstance(side, SiteValue) and side.room == "living_room" and side.capacity == 1
    assert side.furniture == "side_table" and side.position == (9.6, 0.45, 0.6)
    assert m.site("coffee_table").distance(side) == pytest.approx(math.hypot(3.6, 1.55))
    assert m.var("L[mug]") is m.var("mug")


def test_one_line_factors_over_site_attributes(scenario):
    m = Program.from_scenario(scenario)
    m.location("mug")
    m.location("kettle")
    counter = m.site("kitchen_counter")

    @m.factor("mug", "kettle")
    def same_room(mug, kettle):
        return 4.0 if mug.room == kettle.room else 1.0

    @m.factor("mug")
    def near_the_counter(mug):
        return 3.0 if mug.distance(counter) <= 1.5 else 1.0

    m.function(["kettle"], lambda k: 2.0 if "shelf" in k.name else 1.0, name="on a shelf")
    model = compile_program(m)
    # The joint by hand: every (mug, kettle) pair's weight written out.
    sites = scenario.sites
    w = np.array([[(4.0 if a.room == b.room else 1.0)
                   * (3.0 if math.hypot(a.position[0] - 2.0, a.position[1] - 0.35) <= 1.5 else 1.0)
                   * (2.0 if "shelf" in b.name else 1.0) for b in sites] for a in sites])
    np.testing.assert_allclose(model.joint(["mug", "kettle"]), w / w.sum(), rtol=0, atol=TOL)
    np.testing.assert_allclose(model.marginal("L[kettle]"), (w / w.sum()).sum(axis=0), rtol=0, atol=TOL)


def test_a_location_and_a_state_share_a_factor(scenario):
    m = Program.from_scenario(scenario)
    m.location("mug")
    m.state("mug.dirty")
    m.table("mug.dirty", {"true": 0.3, "false": 0.7}, name="dirty prior")

    @m.factor("mug", "mug.dirty")
    def dirty_mugs_wait_by_the_counter(mug, dirty):
        return 5.0 if dirty and mug.furniture == "counter" else 1.0

    model = compile_program(m)
    k = len(scenario.sites)
    counter = scenario.site_index("kitchen_counter")
    dirty_row = np.ones(k)
    dirty_row[counter] = 5.0
    joint = np.stack([0.7 * np.ones(k), 0.3 * dirty_row], axis=1)  # (mug, dirty)
    joint /= joint.sum()
    np.testing.assert_allclose(model.joint(["mug", "mug.dirty"]), joint, rtol=0, atol=TOL)
    seen_dirty = model.condition("mug.dirty", True)
    np.testing.assert_allclose(seen_dirty.marginal("mug"), dirty_row / dirty_row.sum(), rtol=0, atol=TOL)
    # The hypothetical posterior of the mug's place under "it is dirty" / "it is clean".
    hyp = model.hypothetical("mug.dirty", np.eye(2))
    np.testing.assert_allclose(hyp.marginals["mug"][1], dirty_row / dirty_row.sum(), rtol=0, atol=TOL)
    np.testing.assert_allclose(hyp.probability, joint.sum(axis=0), rtol=0, atol=TOL)
    best = model.map()
    assert best.values["mug"].name == "kitchen_counter" and best.values["mug.dirty"] is True  # 0.3 x 5 > 0.7


def test_variables_of_ones_own_and_learnable_tables():
    m = Program(source="tea.py")
    m.variable("weather", ["dry", "wet"])
    m.variable("guests", [0, 1, 2])
    m.table("weather", [0.8, 0.2], name="weather prior", learnable=True)
    m.function(["weather", "guests"], lambda w, g: 1.0 + g if w == "wet" else 1.0, name="rain keeps guests")
    assert m.learnable == ("weather prior",)
    model = compile_program(m)
    w = np.array([[0.8, 0.8, 0.8], [0.2 * 1, 0.2 * 2, 0.2 * 3]])
    np.testing.assert_allclose(model.joint(["weather", "guests"]), w / w.sum(), rtol=0, atol=TOL)
    assert model.values("guests") == (0, 1, 2)
    assert [a.values for a in model.kbest(2)] == [{"weather": "dry", "guests": 0},
                                                  {"weather": "dry", "guests": 1}]  # a tie: index order


@pytest.mark.parametrize("scenario_name", ["default_apartment", "milk_sugar_apartment"])
@pytest.mark.parametrize("model_name", ["joint", "factorised"])
def test_a_bundled_models_program_gives_the_engines_prior(scenario_name, model_name):
    scenario, model = fg.load_scenario(scenario_name), fg.load_model(model_name)
    compiled = compile_program(program_from_model(scenario, model))
    engine = BeliefEngine(scenario, model)
    for o in scenario.object_names:
        np.testing.assert_allclose(compiled.marginal(o), engine.location(o), rtol=0, atol=1e-12)
    for s in engine.state_names:
        assert compiled.marginal(s)[1] == pytest.approx(engine.state(s), abs=1e-12)


def test_edit_a_bundled_models_program(scenario):
    m = program_from_model(scenario, fg.load_model("joint"))
    assert "capacity" in [f.name for f in m.factors]
    assert set(m.learnable) >= {"prior mug", "prior kettle.contains_water"}
    for name in [f.name for f in m.factors if not f.name.startswith("prior")]:
        m.remove(name)
    k = len(scenario.sites)
    m.replace("prior mug", np.arange(1.0, k + 1))
    m.replace("prior kettle", function=lambda s: 2.0 if s.room == "kitchen" else 1.0)

    @m.factor("mug", "teabag", name="teabag by the mug")
    def near(mug, teabag):
        return 3.0 if mug.name == teabag.name else 1.0

    model = compile_program(m)
    np.testing.assert_allclose(model.marginal("kettle"), _normalised([2.0 if s.room == "kitchen" else 1.0
                                                                     for s in scenario.sites]), atol=TOL)
    prior_teabag = m.factor_named("prior teabag").table
    pair = np.arange(1.0, k + 1)[:, None] * prior_teabag[None, :] * np.where(np.eye(k) > 0, 3.0, 1.0)
    np.testing.assert_allclose(model.joint(["mug", "teabag"]), pair / pair.sum(), rtol=0, atol=TOL)
    assert [f.name for f in m.factors][:2] == ["prior mug", "prior kettle"]  # replaced in place


def _normalised(x):
    x = np.asarray(x, dtype=float)
    return x / x.sum()


def test_plan_names_variables_factors_methods_width_and_largest_table(scenario):
    m = program_from_model(scenario, fg.load_model("joint"))
    text = plan_text(m)
    assert text.splitlines()[0] == f"program {m.source}: 10 variables, 12 factors (10 learnable)"
    assert "  prior mug (mug): 8 entries, table, learnable" in text
    assert "  capacity (mug, kettle, teabag): 512 entries, table" in text
    assert "1. mug, kettle, teabag: dense joint of 512 states" in text
    assert "kettle.contains_water: closed form" in text
    assert text.rstrip().endswith("elimination width 2; largest table: 512 entries")
    forced = plan_text(m, method="elimination")
    assert "1. mug, kettle, teabag: variable elimination, min-fill order" in forced
    assert "elimination width 2, largest table: 512 entries" in forced


def _fault(call) -> str:
    with pytest.raises(InputError) as exc:
        call()
    message = str(exc.value)
    assert "\n" not in message and "Traceback" not in message
    return message


def test_bad_programs_are_one_line_each(scenario):
    m = Program.from_scenario(scenario, source="my_model.py")
    m.location("mug")
    m.state("mug.dirty")

    def raises(mug):
        raise ZeroDivisionError("no")
    assert _fault(lambda: m.function(["mug"], raises, name="boom")) == \
        "my_model.py: factor 'boom': raised ZeroDivisionError: no at mug=kitchen_counter"
    assert _fault(lambda: m.function(["mug.dirty"], lambda d: float("nan") if d else 1.0, name="nan")) == \
        "my_model.py: factor 'nan': weight nan at mug.dirty=true (weights must be finite and >= 0)"
    assert _fault(lambda: m.function(["mug"], lambda s: -1.0, name="neg")) == \
        "my_model.py: factor 'neg': weight -1.0 at mug=kitchen_counter (weights must be finite and >= 0)"
    assert _fault(lambda: m.function(["mug"], lambda s: "high", name="word")).endswith(
        "returned str 'high', not a number, at mug=kitchen_counter")
    assert _fault(lambda: m.table("mug.dirty", [0.0, 0.0], name="zero")) == \
        "my_model.py: factor 'zero': every weight is zero (the program would be impossible)"
    assert _fault(lambda: m.table("mug.dirty", [1.0, -2.0], name="negtab")) == \
        "my_model.py: factor 'negtab': table holds a negative weight (-2)"
    assert _fault(lambda: m.table("mug.dirty", [1.0, np.nan], name="nantab")) == \
        "my_model.py: factor 'nantab': table holds NaN or infinite weights"
    assert _fault(lambda: m.table(["mug", "cup"], np.ones((8, 2)), name="cup")).startswith(
        "my_model.py: factor 'cup': unknown variable 'cup' (known: mug, mug.dirty)")
    assert _fault(lambda: m.table("mug", {"sink": 2.0}, name="sink")) == (
        "my_model.py: factor 'sink': unknown site 'sink' of mug (known: " + ", ".join(scenario.site_names) + ")")
    assert _fault(lambda: m.site("sink")).startswith("my_model.py: site 'sink': unknown site (known: kitchen_counter")
    assert _fault(lambda: m.table("mug", np.ones(3), name="short")) == \
        "my_model.py: factor 'short': table has shape (3,), expected (8,) (values of mug)"
    assert _fault(lambda: m.location("cup")) == \
        "my_model.py: location 'cup': unknown object (known: mug, kettle, teabag)"
    assert _fault(lambda: m.state("mug.dirty")) == "my_model.py: variable 'mug.dirty': declared twice"
    m.table("mug", np.ones(8), name="flat")
    assert _fault(lambda: m.table("mug", np.ones(8), name="flat")) == \
        "my_model.py: factor 'flat': declared twice (use replace to change it)"
    assert _fault(lambda: m.remove("flat2")) == "my_model.py: factor 'flat2': unknown factor (known: flat)"
    assert _fault(lambda: m.table(["mug", "mug"], np.ones((8, 8)), name="twice")) == \
        "my_model.py: factor 'twice': names a variable twice"
    model = compile_program(m)
    assert _fault(lambda: model.marginal("cup")).startswith("my_model.py: variable 'cup': unknown variable")
    assert _fault(lambda: model.observe("mug.dirty", [1.0, -1.0])).startswith(
        "my_model.py: evidence on 'mug.dirty': a likelihood must be 2 finite non-negative numbers")
    assert _fault(lambda: compile_program(m, method="fast")).startswith("my_model.py: method: unknown method 'fast'")


def test_a_refused_program_is_one_line_naming_variables_width_and_size(scenario):
    m = Program.from_scenario(scenario, source="crowd.py")
    for o in scenario.object_names:
        m.location(o)
    for i in range(6):
        m.variable(f"guest{i}", [s.name for s in scenario.sites])
    names = [v.name for v in m.variables]
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            m.function([a, b], lambda x, y: 0.5 if str(x) == str(y) else 1.0, name=f"{a}|{b}")
    message = _fault(lambda: compile_program(m))
    assert message == ("crowd.py: inference: exact inference over mug, kettle, teabag, guest0, guest1, guest2, "
                       "guest3, guest4, guest5 by variable elimination needs a table of 134,217,728 entries "
                       "(elimination width 8), above the budget of 50,000,000; refused (no approximation is made)")


def test_help_is_enough_to_start():
    text = pydoc.render_doc(fg.Program, renderer=pydoc.plaintext)
    for word in ("location", "state", "variable", "factor", "table", "remove", "replace", "compile_program"):
        assert word in text
    text = pydoc.render_doc(fg.compile_program, renderer=pydoc.plaintext)
    assert "budget" in text and "Returns" in text
    for name in ("Program", "program_from_model", "compile_program", "CompiledModel", "plan_text"):
        assert name in fg.__all__ and getattr(fg, name) is not None


def test_vectorised_functions_give_the_looped_tables(scenario):
    m = Program.from_scenario(scenario, source="vec.py")
    m.location("mug")
    m.location("kettle")
    m.state("mug.dirty")
    m.variable("guests", [0, 1, 2])
    m.variable("weather", ["dry", "wet"])
    counter = m.site("kitchen_counter")
    pairs = [
        (("mug", "kettle"), lambda a, b: 4.0 if a.room == b.room else 1.0,
         lambda a, b: np.where(a.room == b.room, 4.0, 1.0)),
        (("mug", "kettle"), lambda a, b: 0.2 if a == b else 1.0, lambda a, b: np.where(a == b, 0.2, 1.0)),
        (("mug",), lambda a: 3.0 if a.distance(counter) <= 1.5 else 1.0,
         lambda a: np.where(a.distance(counter) <= 1.5, 3.0, 1.0)),
        (("mug", "mug.dirty"), lambda a, d: 5.0 if d and a.furniture == "counter" else 1.0,
         lambda a, d: np.where(d & (a.furniture == "counter"), 5.0, 1.0)),
        (("kettle",), lambda a: 1.0 / (1 + (a.capacity or 99)), lambda a: 1.0 / (1 + np.where(np.isinf(a.capacity),
                                                                                                   99, a.capacity))),
        (("guests", "weather"), lambda g, w: 1.0 + g if w == "wet" else 1.0,
         lambda g, w: np.where(w == "wet", 1.0 + g, 1.0)),
        (("mug", "kettle"), lambda a, b: a.distance(b) + 0.1, lambda a, b: a.distance(b) + 0.1),
    ]
    for n, (scope, looped, vector) in enumerate(pairs):
        a = m.function(scope, looped, name=f"loop{n}")
        b = m.function(scope, vector, name=f"vec{n}", vectorised=True)
        np.testing.assert_allclose(b.table, a.table, rtol=0, atol=1e-15)
        assert b.table.shape == a.table.shape
    assert _fault(lambda: m.function(["mug", "kettle"], lambda a, b: 4.0 if a.room == b.room else 1.0,
                                     name="ambiguous", vectorised=True)).startswith(
        "vec.py: factor 'ambiguous': raised ValueError: The truth value of an array")
    assert _fault(lambda: m.function(["mug"], lambda a: np.ones(3), name="shape", vectorised=True)) == \
        "vec.py: factor 'shape': returned weights of shape (3,), not broadcastable to (8,)"
    assert _fault(lambda: m.function(["guests"], lambda g: 1.0 - g, name="neg", vectorised=True)) == \
        "vec.py: factor 'neg': weight -1.0 at guests=2 (weights must be finite and >= 0)"
    assert _fault(lambda: m.function(["guests"], lambda g: np.zeros(3), name="zero", vectorised=True)) == \
        "vec.py: factor 'zero': every weight is zero (the program would be impossible)"


def test_the_engines_evidence_enters_the_compiled_graph(scenario):
    """Misses (eq. 5) and state readings (eqs. 23-24), built by the engine's own factor
    constructors, give the engine's posterior and MAP on the joint model; gtsam agrees."""
    from fg_tea.beliefs.compiled_gtsam import gtsam_agreement
    from fg_tea.beliefs.factors import miss_factor, state_observation

    model = fg.load_model("joint")
    engine = BeliefEngine(scenario, model)
    compiled = compile_program(program_from_model(scenario, model))
    k = len(scenario.sites)
    for site, missed in (("kitchen_counter", ("mug", "kettle")), ("side_table", ("teabag",)),
                         ("kitchen_counter", ("mug",))):
        engine.observe_site(site, {o: False for o in missed})
        j = scenario.site_index(site)
        for o in missed:
            compiled = compiled.observe(o, miss_factor(o, j, k, model.miss_likelihood).table)
    sensor = model.sensor("state")
    engine.observe_state("kettle.contains_water", True, sensor)
    reading = state_observation("kettle.contains_water", True, sensor.sensitivity, sensor.specificity)
    compiled = compiled.observe("kettle.contains_water", reading.table)
    for o in scenario.object_names:
        np.testing.assert_allclose(compiled.marginal(o), engine.location(o), rtol=0, atol=1e-12)
    assert compiled.marginal("kettle.contains_water")[1] == pytest.approx(engine.state("kettle.contains_water"),
                                                                          abs=1e-12)
    best = compiled.map()
    assert {o: best.values[o].name for o in scenario.object_names} == engine.map_estimate()
    assert gtsam_agreement(compiled) < 1e-12
