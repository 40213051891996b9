"""Progress displays (fg_tea.common.progress): `fg-tea run`'s bar fills with the task and names the
action under way on a terminal; off a terminal a sweep writes whole lines and an episode nothing."""

from __future__ import annotations

import io

import fg_tea as fg
from fg_tea.cli.common import Progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_the_bar_is_full_when_the_task_is_done_and_names_the_action_under_way():
    scenario, model = fg.load_scenario("default_apartment"), fg.load_model("factorised")
    stream = _Terminal()
    progress = Progress(50_000, stream)
    with fg.make_env(scenario, model, "fake") as env:
        runner = fg.EpisodeRunner(scenario, model, env, fg.RunConfig(seed=0))
        runner.run(progress)
    progress.close()
    lines = [line.strip() for line in stream.getvalue().split("\r") if line.strip()]
    assert runner.reason == "complete"
    total = len(runner.agent.graph)
    assert lines[-1].startswith("episode: |" + "#" * Progress.WIDTH + "|"), lines[-1]
    assert f"{total}/{total} actions" in lines[-1] and "/50,000" in lines[-1]
    # Every step of the episode but the last names the action it is carrying out; the first
    # look already belongs to a search (it used to show "-").
    named = [line.split(" · ")[-1].strip() for line in lines[:-1]]
    assert named and all(name != "-" for name in named), named
    assert named[0].startswith("search"), named[0]
    bars = [line.split("|")[1].count("#") for line in lines]
    assert bars == sorted(bars)  # the bar never goes back


def test_off_a_terminal_a_sweep_writes_whole_lines_and_an_episode_nothing():
    from fg_tea.common.progress import progress

    stream = io.StringIO()
    shown = progress(3, "sweep", "episodes", initial=1, stream=stream, every=0.0, note="(1 resumed)")
    shown.update()
    shown.update()
    shown.close()
    lines = stream.getvalue().splitlines()
    assert "\r" not in stream.getvalue() and lines, stream.getvalue()
    assert lines[0].startswith("sweep: 2/3 episodes (1 resumed)") and lines[-1].startswith("sweep: 3/3 episodes")
    assert all(" · ETA " in line for line in lines)
    idle = io.StringIO()
    progress(5, "sweep", "episodes", stream=idle, every=0.0).close()  # refused before any job
    assert idle.getvalue() == ""
    quiet = io.StringIO()
    Progress(100, quiet)(None)  # off a terminal the episode bar never looks at the runner
    assert quiet.getvalue() == ""
