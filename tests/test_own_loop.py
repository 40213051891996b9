"""A loop of one's own over the agent, the environment and the log (docs/how-to/own-loop.md)
writes the runner's log byte for byte: the agent's verbs return the records the runner writes."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "how-to" / "own-loop.md"


def _loop_source() -> str:
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(), re.S)
    assert len(blocks) == 1, "the how-to shows one loop"
    return blocks[0]


def _runner_log(path: Path, seed: int, task: str) -> bytes:
    from fg_tea import EventLog, RunConfig, load_model, load_scenario, make_env
    from fg_tea.episode.runner import EpisodeRunner

    scenario, model = load_scenario("default_apartment"), load_model("factorised")
    env = make_env(scenario, model, "fake")
    try:
        with EventLog(path) as log:
            EpisodeRunner(scenario, model, env, RunConfig(seed=seed, task=task), log).run()
    finally:
        env.close()
    return path.read_bytes()


@pytest.mark.parametrize("seed", [3, 0])
def test_the_how_tos_loop_writes_the_runners_log(tmp_path, monkeypatch, seed):
    source = _loop_source()
    assert 'RunConfig(seed=3, task="find_three")' in source
    monkeypatch.chdir(tmp_path)
    exec(compile(source.replace("seed=3", f"seed={seed}"), str(PAGE), "exec"), {"__name__": "own_loop"})
    mine = (tmp_path / "runs" / "own_loop.jsonl").read_bytes()
    runners = _runner_log(tmp_path / "runner.jsonl", seed, "find_three")
    assert mine.count(b"\n") > 10 and b'"event":"observation"' in mine
    assert mine == runners


def test_a_loop_that_forgets_the_agents_records_writes_another_log(tmp_path, monkeypatch):
    source = _loop_source()
    forgetful = source.replace("    for record in confirmed:\n        write(record)\n", "")
    assert forgetful != source
    monkeypatch.chdir(tmp_path)
    exec(compile(forgetful, str(PAGE), "exec"), {"__name__": "own_loop"})
    assert (tmp_path / "runs" / "own_loop.jsonl").read_bytes() != _runner_log(
        tmp_path / "runner.jsonl", 3, "find_three")
