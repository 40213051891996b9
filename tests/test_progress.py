"""`fg-tea run`'s progress line: the bar fills with the task and names the action under way."""

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
    lines = [line for line in stream.getvalue().split("\r") if line.strip()]
    assert runner.reason == "complete"
    total = len(runner.graph)
    assert lines[-1].startswith("[" + "#" * Progress.WIDTH + "]")
    assert f"{total}/{total} actions" in lines[-1] and "/50,000" in lines[-1]
    # Every step of the episode but the last names the action it is carrying out; the first
    # look already belongs to a search (it used to show "-").
    named = [line.split(" · ")[-1].strip() for line in lines[:-1]]
    assert named and all(name != "-" for name in named), named
    assert named[0].startswith("search"), named[0]
    bars = [line.count("#") for line in lines]
    assert bars == sorted(bars)  # the bar never goes back
