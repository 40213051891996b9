"""Task states coupled with several objects' locations are exact (docs/design.md §4.8,
fg_tea/beliefs/coupling.py): "when the kettle is full, the mug and the teabag are in one room".

Random model programs hold one factor F over one or two task states and the locations of two
(sometimes three) objects, its scope in a random order, a random positive table (some with hard
zeros). Random looks at any object, readings and transitions of the coupled states are given to the
belief engine and, independently, to a brute-force enumeration of the joint over every object's
location and every time slice of the coupled states (tests/test_coupling_exact.py's, with F over
several locations). Every object's marginal, the coupled objects' joint and the states agree to
1e-12, on factorised and joint bases, by the dense joint and by variable elimination, and when two
coupling factors make one F; gtsam agrees on the same factors (and as the engine's backend); every
hypothetical look equals the posterior of making it. What stays refused is refused in one line.
"""

from __future__ import annotations

import itertools
import subprocess
import sys

import numpy as np
import pytest

import fg_tea as fg
from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.beliefs.graph import build_graph
from fg_tea.common.errors import ContradictionError, InputError
from fg_tea.model.spec import Effect
from tests.test_coupling_exact import K, SCENARIO, SITES, _Brute

OBJECTS = list(SCENARIO.object_names)  # mug, kettle, teabag
#: Coupled states and the transitions among them (target, value, success, requires).
STATES = ("kettle.contains_water", "kettle.water_hot", "mug.tea_brewed")
EFFECTS = (("kettle.contains_water", True, 0.9, ()), ("kettle.water_hot", True, 0.8, ("kettle.contains_water",)),
           ("mug.tea_brewed", True, 0.7, ("kettle.water_hot",)), ("kettle.contains_water", False, 0.6, ()),
           ("mug.tea_brewed", False, 0.95, ()))


class _Several(_Brute):
    """tests/test_coupling_exact.py's brute force with F over several objects' locations: the
    joint over L (every object's site, flattened; `sites_of[o]` maps it to o's site) and every
    slice of the coupled states."""

    def __init__(self, prior_l, sites_of, state_priors, scope, table):
        states = [v for v in scope if v in state_priors]
        located = [v for v in scope if v not in state_priors]
        moved = np.transpose(table, [scope.index(v) for v in states + located])  # states first
        flat = moved[(Ellipsis,) + tuple(sites_of[o] for o in located)]
        super().__init__(prior_l, np.arange(len(prior_l)), state_priors, states, flat)
        self.sites_of = sites_of

    def look_at(self, obj, j, seen, mu, fp):
        row = np.full(K, fp) if seen else np.ones(K)
        row[j] = 1 - mu if seen else mu
        self._mul(["L"], row[self.sites_of[obj]])

    def location(self, obj):
        return np.bincount(self.sites_of[obj], self.marginal("L"), minlength=K)

    def location_joint(self, objs):
        p_l = self.marginal("L")
        out = np.zeros((K,) * len(objs))
        np.add.at(out, tuple(self.sites_of[o] for o in objs), p_l)
        return out


def _program(tmp_path, base, scope, table, n, detection=""):
    np.save(tmp_path / f"s{n}.npy", table)
    name = f"{base}_likelihood{n if detection else ''}"
    (tmp_path / f"{name}.toml").write_text(
        f'extends = "{base}"\nname = "{name}"\n[detection]\npositive_update = "likelihood"\n{detection}')
    base_path = str(tmp_path / f"{name}.toml")
    path = tmp_path / f"several{n}.py"
    path.write_text(f'''import numpy as np
import fg_tea as fg
base = {base_path!r}


def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))
    m.table({list(scope)!r}, np.load({str(tmp_path / f"s{n}.npy")!r}), name="together when")
    return m
''')
    return fg.load_model(str(path)), fg.load_model(base_path)


def _random_program(tmp_path, base, rng, n, objects=None):
    states = list(rng.choice(STATES, size=1 + int(rng.integers(0, 2)), replace=False))
    located = objects or list(rng.choice(OBJECTS, size=3 if rng.random() < 0.25 else 2, replace=False))
    scope = [str(v) for v in rng.permutation(states + located)]
    table = rng.uniform(0.05, 3.0, [2 if v in states else K for v in scope])
    if rng.random() < 0.3:  # hard zeros: some arrangements impossible in some states
        table = table * (rng.random(table.shape) < 0.7)
        table[(0,) * table.ndim] = 1.0
    model, plain = _program(tmp_path, base, scope, table, n)
    return model, plain, states, located, scope, table


def _brute_for(model, plain, states, scope, table):
    graph = build_graph(SCENARIO, model)
    priors = {f.variables[0]: float(f.table[1] / f.table.sum()) for f in graph.state_priors
              if f.variables[0] in states}
    # A(L) of every object: the uncoupled base model's joint (checked against enumeration elsewhere).
    joint = BeliefEngine(SCENARIO, plain).location_joint()
    sites_of = {o: np.indices(joint.shape)[i].ravel() for i, o in enumerate(graph.objects)}
    return _Several(joint.ravel(), sites_of, priors, scope, table)


def _compare(engine, brute, states, located):
    for o in OBJECTS:
        np.testing.assert_allclose(engine.location(o), brute.location(o), rtol=0, atol=1e-12)
    np.testing.assert_allclose(engine.joint(located), brute.location_joint(located), rtol=0, atol=1e-12)
    for s in states:
        assert engine.state(s) == pytest.approx(brute.marginal(brute.current[s])[1], abs=1e-12)


def _steps(engine, brute, model, states, located, rng) -> int:
    """1-6 random looks at any object, readings and transitions of the coupled states; every
    marginal compared after each. Returns the steps checked."""
    sensor, checked = model.sensors["state"], 0
    effects = [Effect(t, v, p, r) for t, v, p, r in EFFECTS if t in states and set(r) <= set(states)]
    for _ in range(int(rng.integers(1, 7))):
        op = int(rng.integers(0, 4))
        if op == 3 and not effects:
            op = 1
        try:
            if op <= 1:
                obj, j, seen = str(rng.choice(OBJECTS)), int(rng.integers(0, K)), bool(rng.random() < 0.3)
                engine.observe_site(SITES[j], {obj: seen})
                brute.look_at(obj, j, seen, model.miss_likelihood, model.false_positive_rate)
            elif op == 2:
                s, v = str(rng.choice(states)), bool(rng.random() < 0.5)
                engine.observe_state(s, v, sensor)
                brute.read(s, v, sensor.sensitivity, sensor.specificity)
            else:
                e = effects[int(rng.integers(0, len(effects)))]
                engine.apply_effects([e], direct=False)
                brute.effect(e)
        except ContradictionError:
            break
        _compare(engine, brute, states, located)
        checked += 1
    return checked


@pytest.mark.parametrize("base", ["factorised", "joint"])
def test_several_coupled_locations_match_brute_force(tmp_path, base):
    rng = np.random.default_rng(21 if base == "factorised" else 22)
    checked, three, solvers = 0, 0, set()
    for n in range(60):
        model, plain, states, located, scope, table = _random_program(tmp_path, base, rng, n)
        solver = "elimination" if n % 3 == 2 else "auto"
        engine = BeliefEngine(SCENARIO, model, location_solver=solver)
        solvers.add(engine.location_method)
        brute = _brute_for(model, plain, states, scope, table)
        _compare(engine, brute, states, located)
        checked += 1 + _steps(engine, brute, model, states, located, rng)
        three += len(located) == 3
        if n % 4 == 0:
            assert engine.check_against_gtsam() < 1e-9  # gtsam on the same factors, g included
    assert checked >= 150 and three >= 5 and solvers == {"dense", "elimination"}


def test_several_coupling_factors_form_one(tmp_path):
    """Two factors — one over a state and two locations, one over the other state and the third
    object (or over the two states only) — are held as one F over their union."""
    rng = np.random.default_rng(25)
    for n in range(12):
        base = ("factorised", "joint")[n % 2]
        s1, s2 = [str(v) for v in rng.choice(STATES, size=2, replace=False)]
        o1, o2, o3 = [str(v) for v in rng.permutation(OBJECTS)]
        second = [s2, o3] if n % 3 else [s1, s2]
        t1, t2 = rng.uniform(0.05, 3.0, (2, K, K)), rng.uniform(0.05, 3.0, [2 if v in STATES else K for v in second])
        scope = [s1, s2, o1, o2, o3]
        letters = dict(zip(scope, "abcde"))
        table = np.einsum(f"acd,{''.join(letters[v] for v in second)},e->abcde", t1, t2, np.ones(K))
        np.save(tmp_path / f"first{n}.npy", t1)
        model, plain = _program(tmp_path, base, second, t2, 100 + n)
        path = tmp_path / f"several{100 + n}.py"
        text = path.read_text().replace("    return m\n", f"    m.table({[s1, o1, o2]!r}, np.load("
                                        f"{str(tmp_path / f'first{n}.npy')!r}), name='first')\n    return m\n")
        path.write_text(text)
        model = fg.load_model(str(path))
        assert len(build_graph(SCENARIO, model).couplings) == 2
        engine = BeliefEngine(SCENARIO, model)
        brute = _brute_for(model, plain, [s1, s2], scope, table)
        located = [o1, o2] if second[1] in STATES else [o1, o2, o3]
        _compare(engine, brute, [s1, s2], located)
        _steps(engine, brute, model, [s1, s2], located, rng)


def test_a_variable_of_the_programs_own_between_a_state_and_two_locations(tmp_path):
    """T1(state, weather) T2(weather, mug) T3(weather, teabag): weather is summed out, leaving a
    coupling of the state with both locations (fg_tea/beliefs/graph.py's _summed_out)."""
    rng = np.random.default_rng(26)
    for n in range(8):
        base = ("factorised", "joint")[n % 2]
        state = str(rng.choice(STATES))
        t1, t2, t3 = rng.uniform(0.05, 3.0, (2, 3)), rng.uniform(0.05, 3.0, (3, K)), rng.uniform(0.05, 3.0, (3, K))
        for name, t in (("t1", t1), ("t2", t2), ("t3", t3)):
            np.save(tmp_path / f"{name}_{n}.npy", t)
        model, plain = _program(tmp_path, base, [state], np.ones(2), 200 + n)
        path = tmp_path / f"several{200 + n}.py"
        load = {name: f"np.load({str(tmp_path / f'{name}_{n}.npy')!r})" for name in ("t1", "t2", "t3")}
        path.write_text(path.read_text().replace("    return m\n", (
            '    m.variable("weather", ["dry", "wet", "windy"])\n'
            f'    m.table([{state!r}, "weather"], {load["t1"]}, name="state by weather")\n'
            f'    m.table(["weather", "mug"], {load["t2"]}, name="mug by weather")\n'
            f'    m.table(["weather", "teabag"], {load["t3"]}, name="teabag by weather")\n    return m\n')))
        model = fg.load_model(str(path))
        graph = build_graph(SCENARIO, model)
        assert [f.variables for f in graph.couplings] == [(state, "L[mug]", "L[teabag]")] and not graph.extra
        table = np.einsum("aw,wm,wt->amt", t1, t2, t3)
        engine = BeliefEngine(SCENARIO, model)
        brute = _brute_for(model, plain, [state], [state, "mug", "teabag"], table)
        _compare(engine, brute, [state], ["mug", "teabag"])
        _steps(engine, brute, model, [state], ["mug", "teabag"], rng)
        assert engine.check_against_gtsam() < 1e-9


def test_the_gtsam_backend_matches_brute_force(tmp_path):
    rng = np.random.default_rng(23)
    for n in range(6):
        base = ("factorised", "joint")[n % 2]
        model, plain, states, located, scope, table = _random_program(tmp_path, base, rng, n)
        engine = BeliefEngine(SCENARIO, model, backend="gtsam")
        brute = _brute_for(model, plain, states, scope, table)
        _compare(engine, brute, states, located)
        _steps(engine, brute, model, states, located, rng)


def test_hypothetical_looks_equal_making_them(tmp_path):
    rng = np.random.default_rng(24)
    for n in range(8):
        base = ("factorised", "joint")[n % 2]
        model, _, states, located, _, _ = _random_program(tmp_path, base, rng, n)
        engine = BeliefEngine(SCENARIO, model, location_solver="elimination" if n % 4 == 3 else "auto")
        engine.observe_state(states[0], bool(n % 2), model.sensors["state"])
        engine.observe_site(SITES[n % K], {located[0]: False})
        miss, seen = engine.hypothetical_all()
        for o, obj in enumerate(OBJECTS):
            for j in range(K):
                for outcome, table_ in ((False, miss), (True, seen)):
                    after = engine.copy().observe_site(SITES[j], {obj: outcome}).after
                    for p, other in enumerate(OBJECTS):
                        np.testing.assert_allclose(table_[o, j, p], after[other], rtol=0, atol=1e-10)


def test_a_reading_moves_both_objects_and_a_look_moves_the_state(tmp_path):
    rooms = np.array([s.room for s in SCENARIO.sites])
    table = np.ones((2, K, K))
    table[1] = np.where(rooms[:, None] == rooms[None, :], 20.0, 1.0)  # full kettle: mug and teabag together
    model, plain = _program(tmp_path, "factorised", ["kettle.contains_water", "mug", "teabag"], table, 0)
    engine = BeliefEngine(SCENARIO, model)
    assert engine.correlated and engine.location_method == "dense"

    def together(e):
        pair = e.joint(["mug", "teabag"])
        return float(sum(pair[a, b] for a in range(K) for b in range(K) if rooms[a] == rooms[b]))
    before = together(engine)
    engine.observe_state("kettle.contains_water", True, model.sensors["state"])
    assert together(engine) > before + 0.05
    full = engine.state("kettle.contains_water")
    teabag = int(np.argmax(engine.location("teabag")))
    engine.observe_site(SITES[teabag], {"teabag": True})  # the teabag is here: the mug is near it
    mug_room = float(sum(engine.location("mug")[rooms == rooms[teabag]]))
    apart = [j for j in range(K) if rooms[j] != rooms[teabag]]
    engine.observe_site(SITES[apart[0]], {"mug": True})  # the mug is in another room: less likely full
    assert mug_room > 0.2 and engine.state("kettle.contains_water") < full - 0.05
    assert engine.check_against_gtsam() < 1e-9
    uncoupled = BeliefEngine(SCENARIO, plain)
    assert not uncoupled.correlated


def test_a_failed_update_leaves_the_coupled_belief_unchanged(tmp_path):
    import dataclasses

    table = np.ones((2, K, K))
    table[1] = np.eye(K)  # a full kettle: the mug and the teabag on one site
    model, _ = _program(tmp_path, "factorised", ["kettle.contains_water", "mug", "teabag"], table, 1,
                        "false_positive_rate = 0.0\n")
    exact = dataclasses.replace(model.sensors["state"], sensitivity=1.0, specificity=1.0)
    engine = BeliefEngine(SCENARIO, model)
    engine.observe_site(SITES[0], {"mug": True})
    engine.observe_site(SITES[1], {"teabag": True})  # apart: the kettle is empty
    assert engine.state("kettle.contains_water") == 0.0
    before = (engine.locations(), engine.states(), engine.graph)
    with pytest.raises(ContradictionError):  # a full kettle would need them on one site
        engine.observe_state("kettle.contains_water", True, exact)
    after = (engine.locations(), engine.states(), engine.graph)
    for o in OBJECTS:
        np.testing.assert_array_equal(before[0][o], after[0][o])
    assert before[1] == after[1] and before[2] is after[2]
    engine.observe_state("kettle.contains_water", False, exact)  # still consistent, and still held
    assert engine.state("kettle.contains_water") == 0.0 and engine.check_against_gtsam() < 1e-9


def test_what_stays_unsupported_is_refused_in_one_line(tmp_path, monkeypatch):
    import fg_tea.beliefs.coupling as coupling

    scope = ["kettle.contains_water", "kettle.water_hot", "mug.tea_brewed", "mug.served", "mug", "teabag"]
    model, _ = _program(tmp_path, "factorised", scope, np.ones((2, 2, 2, 2, K, K)), 2)
    with pytest.raises(InputError) as e:
        build_graph(SCENARIO, model)
    assert "couples 4 task states with locations; at most 3" in str(e.value) and "\n" not in str(e.value)
    monkeypatch.setattr(coupling, "MAX_COUPLING_ENTRIES", 1000)  # a table of 2 x 8^3 = 1,024 entries
    model, _ = _program(tmp_path, "factorised", ["kettle.contains_water", "mug", "teabag", "kettle"],
                        np.ones((2, K, K, K)), 3)
    with pytest.raises(InputError) as e:
        build_graph(SCENARIO, model)
    assert "one table of 1,024 entries, above the limit of 1,000" in str(e.value) and "\n" not in str(e.value)


EXAMPLE = "experiments/programs/together_when_full.py"


def test_an_episode_runs_with_a_several_location_coupling(tmp_path):
    from pathlib import Path

    from fg_tea.episode.log import read_log

    program = Path(__file__).resolve().parents[1] / EXAMPLE
    runs = {}
    for name, model in (("coupled", str(program)), ("plain", "factorised")):
        done = subprocess.run([sys.executable, "-m", "fg_tea.cli", "run", "--env", "fake", "--no-video", "--model",
                               model, "--out", name], cwd=tmp_path, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        runs[name] = read_log(tmp_path / name / "episode.jsonl")
    events = runs["coupled"]
    start, end = events[0], next(e for e in events if e["event"] == "episode_end")
    assert end["reason"] == "complete" and end["gtsam_agreement"] < 1e-9
    assert {"name": "together_when_full", "scope": ["kettle.contains_water", "mug", "teabag"]} \
        in start["program"]["factors"]

    def moved(events):
        at = next(i for i, e in enumerate(events) if e["event"] == "state_reading"
                  and e["state"] == "kettle.contains_water")
        before = next(e for e in reversed(events[:at]) if e["event"] == "belief")["locations"]["mug"]
        after = next(e for e in events[at:] if e["event"] == "belief")["locations"]["mug"]
        return max(abs(a - b) for a, b in zip(after, before))
    assert moved(events) > 1e-5 and moved(runs["plain"]) == 0.0  # the reading moves the mug only if coupled
