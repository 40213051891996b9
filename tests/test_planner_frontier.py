"""experiments/planner_frontier.py: writes the table and plot, resumes without re-running, and
summarises what is on disk with --summary-only."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _script():
    spec = importlib.util.spec_from_file_location("planner_frontier", ROOT / "experiments" / "planner_frontier.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_frontier_runs_resumes_and_summarises(tmp_path, capsys):
    frontier = _script()
    args = ["--yardstick", "optimal", "--worlds", "2", "--models", "factorised_close", "--planners",
            "optimal", "efe", "lookahead:nodes=5", "--out", str(tmp_path)]
    assert frontier.main(args) == 0
    episodes = sorted((tmp_path / "episodes").glob("*.json"))
    assert len(episodes) == 6
    row = json.loads(episodes[0].read_text())
    assert len(row["decision_seconds"]) == len(row["decision_cpu_seconds"]) >= 1
    table = (tmp_path / "frontier.md").read_text()
    assert "| lookahead:nodes=5 | 2 |" in table and "| optimal | 2 | " in table
    assert (tmp_path / "frontier.png").stat().st_size > 0
    stamps = [p.stat().st_mtime_ns for p in episodes]
    assert frontier.main(args) == 0  # resumes: nothing is run again
    assert [p.stat().st_mtime_ns for p in episodes] == stamps
    episodes[-1].unlink()
    assert frontier.main(args[:-2] + ["--out", str(tmp_path), "--summary-only"]) == 0
    assert not episodes[-1].exists()  # --summary-only runs nothing
    capsys.readouterr()


@pytest.mark.slow
def test_the_frontier_against_the_limit_writes_its_study_and_resumes(tmp_path, capsys):
    """The default yardstick: the search-limit study, with the frontier drawn against the limit;
    the limit's own policy (``exact``) costs the limit, one-step EFE more."""
    frontier = _script()
    args = ["--worlds", "2", "--planners", "efe", "exact", "--tasks", "find_mug", "--out", str(tmp_path)]
    assert frontier.main(args) == 0
    for name in ("summary.md", "episodes.csv", "frontier.png"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert not (tmp_path / "gaps.md").exists()  # only with --gaps
    episodes = sorted((tmp_path / "episodes").glob("*.json"))
    assert len(episodes) == 4
    table = (tmp_path / "summary.md").read_text()
    assert "Regenerate: `python experiments/planner_frontier.py --worlds 2" in table
    ratios = {line.split(" | ")[0].strip("| "): [float(x) for x in line.split(" | ")[2].strip("[]").split(", ")]
              for line in table.splitlines() if line.startswith(("| efe |", "| exact |"))}
    assert 1.0 <= ratios["exact"][0] <= ratios["exact"][1] <= 1.01 < ratios["efe"][0]
    stamps = [p.stat().st_mtime_ns for p in episodes]
    assert frontier.main(args + ["--gaps", "efe"]) == 0  # resumes: nothing is run again
    assert [p.stat().st_mtime_ns for p in episodes] == stamps
    gaps = (tmp_path / "gaps.md").read_text()
    regret = float(next(line for line in gaps.splitlines() if line.startswith("| efe | find_mug |"))
                   .split(" | ")[4])
    assert regret > 0  # one-step EFE is not the exact policy: its decisions cost something
    from fg_tea.common.errors import InputError
    with pytest.raises(InputError, match="world 'independent', not 'correlated'"):
        frontier.main(args + ["--world", "correlated"])  # another world's episodes are not reused
    capsys.readouterr()


def test_the_decision_clock_times_every_decision_and_passes_results_and_errors_through():
    from fg_tea.study.frontier import DecisionClock

    class Planner:
        def choose(self, x):
            if x < 0:
                raise ValueError("refused")
            return 2 * x

    planner = Planner()
    clock = DecisionClock(planner)
    assert planner.choose(3) == 6 and planner.choose(4) == 8
    with pytest.raises(ValueError, match="refused"):
        planner.choose(-1)
    assert len(clock.wall) == len(clock.cpu) == 3 and all(t >= 0 for t in clock.wall + clock.cpu)


def test_budget_rule_tabulates_and_picks(tmp_path, capsys):
    """experiments/lookahead_budget.py runs the ladder per house, then picks the smallest budget
    that is not detectably worse than the largest on every house and model."""
    spec = importlib.util.spec_from_file_location("lookahead_budget", ROOT / "experiments" / "lookahead_budget.py")
    budget = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(budget)
    args = ["--houses", "correlated:3", "--ladder", "2", "20", "--models", "factorised_close",
            "--out", str(tmp_path)]
    assert budget.main(args) == 0
    assert len(list((tmp_path / "correlated" / "episodes").glob("*.json"))) == 6
    text = (tmp_path / "budget.md").read_text()
    assert "| 20 | 3 |" in text and "+0.00 [+0.00, +0.00]" in text  # the largest against itself
    chosen = text.strip().splitlines()[-1]
    assert chosen.startswith("Smallest budget passing on every house and model: ")
    assert chosen.rstrip(".").split(": ")[1] in ("2", "20")
    import numpy as np

    from fg_tea.common.stats import bootstrap_interval
    lo, hi = bootstrap_interval(np.array([1.0, 2.0, 3.0]))
    assert 1.0 <= lo <= 2.0 <= hi <= 3.0
    capsys.readouterr()



def _refuses_each(script, cases, tmp_path):
    """Every (flags, word) case exits 2 with one stderr line naming `word`, writing nothing."""
    import subprocess
    import sys

    for bad, field in cases:
        proc = subprocess.run([sys.executable, f"experiments/{script}", *bad, "--out", str(tmp_path)],
                              capture_output=True, text=True, cwd=ROOT, stdin=subprocess.DEVNULL,
                              timeout=300)
        assert proc.returncode == 2, (bad, proc.stderr)
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and field in lines[0], (bad, proc.stderr)
    assert not any(tmp_path.iterdir())  # nothing run, nothing written


@pytest.mark.slow
def test_budget_rule_refuses_bad_input_with_one_line_before_any_episode(tmp_path):
    _refuses_each("lookahead_budget.py", (
        (["--houses", "nowhere:3"], "nowhere"), (["--houses", "correlated:x"], "--houses"),
        (["--ladder", "20"], "--ladder"), (["--ladder", "0", "20"], "--ladder"),
        (["--models", "no_such_model"], "no_such_model")), tmp_path)


@pytest.mark.slow
def test_frontier_refuses_bad_input_with_one_line_before_any_episode(tmp_path):
    _refuses_each("planner_frontier.py", (
        (["--world", "nowhere"], "--world"), (["--planners", "nope"], "nope"),
        (["--worlds", "0"], "--worlds"), (["--models", "no_such_model"], "no_such_model")), tmp_path)


def test_settings_a_yardstick_cannot_use_are_refused_before_any_episode(tmp_path, capsys):
    """In process (the one-line, exit-2 path is the one the test above runs as a user would)."""
    from fg_tea.common.errors import InputError

    frontier = _script()
    for bad, fault in (
            # settings the chosen yardstick has no use for
            (["--env", "pybullet"], "--env"), (["--miss-rate", "0.1"], "--miss-rate"),
            (["--summary-only"], "--summary-only"),
            (["--models", "factorised_close", "joint_close"], "takes one"),
            (["--yardstick", "optimal", "--tasks", "find_mug"], "--tasks"),
            (["--yardstick", "optimal", "--gaps", "lookahead"], "--gaps"),
            # the limit needs a factorised belief
            (["--models", "joint_close", "--worlds", "1"], "correlated"),
            (["--yardstick", "optimal", "--world", "nowhere"], "--world")):
        with pytest.raises(InputError, match=fault):
            frontier.main(bad + ["--out", str(tmp_path)])
    with pytest.raises(SystemExit) as stop:  # not a search-only task: argparse's choices
        frontier.main(["--tasks", "make_tea", "--out", str(tmp_path)])
    assert stop.value.code == 2 and "--tasks" in capsys.readouterr().err
    assert not any(tmp_path.rglob("*.json"))


def test_the_frontier_figure_names_planners_in_a_legend_and_its_log_ticks_do_not_collide(tmp_path, monkeypatch):
    """At --worlds 2 the point labels sat on top of each other and the log-axis labels ran
    together: the planners are now a legend, the ticks few and plain, and the figure says n < 5."""
    from fg_tea.study import analysis, frontier

    figures = []
    monkeypatch.setattr(analysis, "save_figure", lambda fig, path, dpi=120: figures.append(fig) or path)
    rows = [{"world": "correlated", "env": "fake", "miss_rate": 0.05, "model": m, "planner": p,
             "seed": s, "search_distance": d * (1 + 0.1 * s), "inspections": 3, "success": True,
             "spl": 0.5, "decision_seconds": [t], "decision_cpu_seconds": [t]}
            for m in ("factorised", "joint") for s in (0, 1)
            for p, d, t in (("optimal", 10.0, 0.5), ("efe", 11.0, 0.0011), ("lookahead", 10.5, 0.0012),
                            ("nearest", 12.0, 0.00105))]
    frontier.summarise(rows, tmp_path)
    fig = figures[0]
    fig.canvas.draw()
    (ax,) = fig.axes
    assert not ax.texts  # no label on a point
    assert len(ax.get_legend().get_texts()) == 8
    renderer = fig.canvas.get_renderer()
    boxes = [t.get_window_extent(renderer) for t in ax.get_xticklabels() if t.get_text()]
    assert 2 <= len(boxes) <= 6
    assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
    assert "n = 2 worlds" in ax.get_title()


def test_the_limit_frontier_gives_every_planner_its_own_style_and_a_legend(tmp_path, monkeypatch):
    """Thirteen planners: a colour per family and a marker per variant, so no two share a style
    (the eleventh used to repeat the first's); every planner in the legend, the sampled ones
    with their interval."""
    from types import SimpleNamespace

    from fg_tea.study import analysis, yardstick

    planners = ["efe", "lookahead", "lookahead:relook=1", "lookahead:relook=1,nodes=60", "exact",
                "exact:cap=2", "optimal", "pouct:100", "pouct:1000", "pouct:3000", "pomcp:100",
                "pomcp:1000", "pomcp:3000"]
    styles = yardstick.planner_styles(planners)
    assert len(set(styles.values())) == len(planners)
    assert styles["pouct:100"][0] == styles["pouct:3000"][0] != styles["pomcp:100"][0]
    figures = []
    monkeypatch.setattr(analysis, "save_figure", lambda fig, path, dpi=120: figures.append(fig) or path)
    rows = [{"task": "find_mug", "planner": p, "seed": s, "cost": 10.0 + i + s,
             "decision_cpu_seconds": [1e-4 * (i + 1)]} for i, p in enumerate(planners) for s in range(3)]
    limits = {"find_mug": (SimpleNamespace(lower=9.9, upper=10.1), ["mug"])}
    policies = {("find_mug", p): SimpleNamespace(cost=10.0 + i) for i, p in enumerate(planners)
                if p.split(":")[0] not in yardstick.RANDOMISED}
    yardstick.draw_frontier(rows, limits, policies, tmp_path / "f.png")
    (fig,) = figures
    (ax,) = [a for a in fig.axes if a.get_xlabel()]
    assert ax.get_legend_handles_labels()[1] == planners
    assert len(ax.containers) == len(planners)  # every planner drawn as its interval to the optimum
