"""`fg-tea learn --base PROGRAM`: a model program's learnable tables counted from its episodes and
written as a learned program (docs/design.md §12.6, fg_tea/study/program_learning.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import fg_tea as fg
from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.common.errors import InputError
from fg_tea.model.program_learned import apply_counts
from fg_tea.study.program_learning import count_tables, observed_values

PROGRAM = '''import fg_tea as fg
base = "factorised"


def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))
{extra}    return m
'''


def _cli(cwd: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fg_tea.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=600, stdin=subprocess.DEVNULL)



def test_what_an_episode_observed_is_counted_by_the_rules():
    events = [{"event": "episode_start"},
              {"event": "state_reading", "state": "kettle.contains_water", "value": False},
              {"event": "confirm_search", "object": "mug", "site": "sideboard"},
              {"event": "state_reading", "state": "kettle.contains_water", "value": False},
              {"event": "action", "transition": {"effects": [{"state": "kettle.contains_water"}]}},
              {"event": "state_reading", "state": "kettle.contains_water", "value": True},
              {"event": "confirm_search", "object": "mug", "site": "dining_table"},  # moved: not counted
              {"event": "state_reading", "state": "mug.served", "value": True},
              {"event": "state_reading", "state": "mug.served", "value": False}]  # disagree: nothing
    seen = observed_values(events)
    assert seen == {"mug": "sideboard", "kettle.contains_water": False}
    scenario = fg.load_scenario("default_apartment")
    program = fg.program_from_model(scenario, fg.load_model("factorised"))
    counts = count_tables(program, [seen, seen, {"mug": "kitchen_counter"}])
    sites = list(scenario.site_names)
    expected = np.zeros(len(sites))
    expected[sites.index("sideboard")], expected[sites.index("kitchen_counter")] = 2, 1
    np.testing.assert_array_equal(counts["prior mug"], expected)
    np.testing.assert_array_equal(counts["prior kettle.contains_water"], [2, 0])
    assert counts["prior kettle"].sum() == 0 and counts["prior mug.served"].sum() == 0


def test_a_learned_location_table_approaches_the_true_distribution():
    scenario = fg.load_scenario("default_apartment")
    sites = list(scenario.site_names)
    truth = np.array([0.05, 0.05, 0.1, 0.5, 0.2, 0.05, 0.03, 0.02])
    rng = np.random.default_rng(3)
    episodes = [{"mug": sites[int(rng.choice(len(sites), p=truth))]} for _ in range(2000)]
    errors = []
    for n in (20, 200, 2000):
        program = fg.program_from_model(scenario, fg.load_model("factorised"))
        apply_counts(program, count_tables(program, episodes[:n]), 5.0)
        errors.append(np.abs(program.factor_named("prior mug").table - truth).sum())
    assert errors[0] > errors[1] > errors[2] and errors[2] < 0.05, errors


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_learn_then_run_then_learn_on(tmp_path):
    (tmp_path / "prog.py").write_text(PROGRAM.format(extra=""))
    for seed in (0, 1):
        done = _cli(tmp_path, "run", "--env", "fake", "--no-video", "--model", "prog.py", "--seed", str(seed),
                    "--out", f"runs/s{seed}")
        assert done.returncode == 0, done.stderr
    learned = _cli(tmp_path, "learn", "--base", "prog.py", "runs/s0/episode.jsonl", "runs/s1/episode.jsonl",
                   "--out", "out/learned.py")
    assert learned.returncode == 0, learned.stderr
    assert "prior mug: 2 episode(s) counted" in learned.stdout
    scenario = fg.load_scenario("default_apartment")
    before = BeliefEngine(scenario, fg.load_model(str(tmp_path / "prog.py"))).location_map("mug")
    after = BeliefEngine(scenario, fg.load_model(str(tmp_path / "out" / "learned.py"))).location_map("mug")
    assert after["sideboard"] == pytest.approx((5 * before["sideboard"] + 2) / 7)  # found there twice
    again = _cli(tmp_path, "run", "--env", "fake", "--no-video", "--model", "out/learned.py", "--out", "runs/l")
    assert again.returncode == 0, again.stderr
    on = _cli(tmp_path, "learn", "--base", "out/learned.py", "runs/l/episode.jsonl", "--out", "learned2.py")
    assert on.returncode == 0, on.stderr
    third = BeliefEngine(scenario, fg.load_model(str(tmp_path / "learned2.py"))).location_map("mug")
    assert third["sideboard"] == pytest.approx((5 * before["sideboard"] + 3) / 8)  # the counts add up
    # A log of another program, and a program changed since it was learned from, are one line.
    (tmp_path / "other.py").write_text(PROGRAM.format(extra="    # another program\n"))
    other = _cli(tmp_path, "learn", "--base", "other.py", "runs/s0/episode.jsonl", "--out", "x.py")
    assert other.returncode == 2 and "$.program.sha256" in other.stderr and len(other.stderr.splitlines()) == 1
    (tmp_path / "prog.py").write_text(PROGRAM.format(extra="    # edited\n"))
    stale = _cli(tmp_path, "beliefs", "--model", "out/learned.py")
    assert stale.returncode == 2 and "changed since it was learned" in stale.stderr
    assert len(stale.stderr.splitlines()) == 1


def test_what_cannot_be_learned_is_refused_in_one_line(tmp_path):
    hidden = '''    m.variable("guests", ["none", "some"])
    m.table("guests", [0.8, 0.2], name="guests prior", learnable=True)
'''
    (tmp_path / "hidden.py").write_text(PROGRAM.format(extra=hidden))
    done = _cli(tmp_path, "run", "--env", "fake", "--no-video", "--model", "hidden.py", "--out", "r")
    assert done.returncode == 0, done.stderr
    for args, words in ((["--base", "hidden.py", "r/episode.jsonl", "--out", "h.py"], "no episode observes"),
                        (["--base", "hidden.py", "r/episode.jsonl", "--out", "h.toml"], "must end in .py"),
                        (["--base", "hidden.py", "r/episode.jsonl", "--out", "h.py", "--forgetting", "0.5"],
                         "--forgetting")):
        refused = _cli(tmp_path, "learn", *args)
        assert refused.returncode == 2 and words in refused.stderr, refused.stderr
        assert len(refused.stderr.strip().splitlines()) == 1
    program = fg.program_from_model(fg.load_scenario("default_apartment"), fg.load_model("factorised"))
    with pytest.raises(InputError, match="not mark this factor learnable|unknown factor"):
        apply_counts(program, {"nothing": [1.0]})


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_the_how_to_learning_commands_run_as_they_stand(tmp_path):
    """docs/how-to/model-as-program.md, "Learn its tables": the page's model file, then its commands."""
    import re
    import shlex

    page = (Path(__file__).resolve().parents[1] / "docs" / "how-to" / "model-as-program.md").read_text()
    (tmp_path / "my_model.py").write_text(re.findall(r"^```python\n(.*?)^```", page, re.M | re.S)[0])
    section = page[page.index("## Learn its tables"):]
    commands = re.findall(r"^```bash\n(.*?)^```", section, re.M | re.S)[0].strip().splitlines()
    assert [c.split()[1] for c in commands] == ["run", "learn", "run"]
    for line in commands:
        done = _cli(tmp_path, *shlex.split(line)[1:])
        assert done.returncode == 0, (line, done.stderr)
    assert (tmp_path / "runs" / "learned" / "episode.jsonl").is_file()
