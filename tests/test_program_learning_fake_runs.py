"""A model program's learnable location table learned from fake-house episodes converges to the
site distribution the worlds were drawn from (docs/design.md §12.6, fg_tea/study/program_learning.py)."""

from __future__ import annotations

import pytest
import numpy as np

import fg_tea as fg
from fg_tea.model.program_learned import apply_counts
from fg_tea.study.households import HouseholdSpec, _episode
from fg_tea.study.program_learning import count_tables, observed_values
from fg_tea.world.distributions import load_world


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_a_location_table_learned_from_fake_runs_converges_to_the_worlds_site_distribution():
    world = load_world("independent")
    sites = list(world.sample(0).site_names)
    drawn = np.zeros(len(sites))
    for s in range(3000):  # the distribution the episodes' mug sites are drawn from, by sampling it
        drawn[sites.index({o.name: o.true_site for o in world.sample(10_000 + s).objects}["mug"])] += 1
    truth = drawn / drawn.sum()
    model = fg.load_model("factorised")
    spec = HouseholdSpec(source="independent", fixed=False, model="factorised", household=0, episodes=1)
    seen, stood = [], []
    for k in range(120):  # fake-house episodes, one drawn world each
        scenario = world.sample(k)
        events, _ = _episode(spec, model, scenario, k)
        seen.append(observed_values(events))
        stood.append({o.name: o.true_site for o in scenario.objects}["mug"])
    assert [s.get("mug") for s in seen] == stood  # each episode counts the site where the mug stood
    wrong = np.zeros(len(sites))
    wrong[-1] = 1000.0  # start from a prior sure of the least likely site
    errors = []
    for n in (0, 10, 40, 120):
        program = fg.program_from_model(world.sample(0), model)
        apply_counts(program, {"prior mug": wrong}, 1.0)
        if n:
            counts = count_tables(program, seen[:n])
            expected = np.bincount([sites.index(s) for s in stood[:n]], minlength=len(sites))
            np.testing.assert_array_equal(counts["prior mug"], expected)
            apply_counts(program, counts, 5.0)
        errors.append(float(np.abs(program.factor_named("prior mug").table - truth).sum()))
    assert errors[0] > 1.9 and errors == sorted(errors, reverse=True) and errors[-1] < 0.25, errors


HABIT = '''import fg_tea as fg
base = "factorised"


def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))
    m.table("mug", [1.0] * len(scenario.site_names), name="mug habit")
    return m
'''


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_a_learned_file_naming_an_unknown_or_fixed_table_is_one_line(tmp_path):
    import subprocess
    import sys

    def cli(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "fg_tea.cli", *args], cwd=tmp_path, capture_output=True,
                              text=True, timeout=600, stdin=subprocess.DEVNULL)

    (tmp_path / "habit.py").write_text(HABIT)
    assert cli("run", "--env", "fake", "--no-video", "--model", "habit.py", "--out", "r").returncode == 0
    done = cli("learn", "--base", "habit.py", "r/episode.jsonl", "--out", "learned.py")
    assert done.returncode == 0, done.stderr
    assert "mug habit" not in done.stdout  # declared without learnable=True: never counted
    text = (tmp_path / "learned.py").read_text()
    assert cli("beliefs", "--model", "learned.py").returncode == 0
    for name, fault in (("no such table", "unknown factor"), ("mug habit", "does not mark this factor learnable")):
        (tmp_path / "edited.py").write_text(text.replace('"prior mug":', f'"{name}":'))
        refused = cli("beliefs", "--model", "edited.py")
        assert refused.returncode == 2 and fault in refused.stderr and name in refused.stderr, refused.stderr
        assert len(refused.stderr.strip().splitlines()) == 1
