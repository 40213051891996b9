"""Behaviour kept (docs/design.md §1.2): the logs of `fg-tea run` on three houses, both models,
three seeds, and the CSV of `fg-tea compare --quick --env fake`, against golden copies.

The golden files (tests/golden/README.md says how they were made and from which commit) hold the
logs' events and the comparison's rows. A log is compared event by event, a CSV row by row (by
its ``key``): decisions, actions, observations, candidates, counts and every other string,
integer, boolean, key and list length must be the same; floats must agree to 9 significant digits
(tests/golden_match.py), so another CPU or a newer numpy/scipy/opencv, which move last bits, pass,
and a moved decision or number fails, naming the log, the event (index and kind) and the field.

The first event drops what names the machine or the checkout: ``versions``, ``git`` and
``inputs`` (whose sha256 of a bundled file changes with its comments).

Record them afresh (only for a change of behaviour that is meant, said in CHANGELOG.md):
``python tests/test_golden_logs.py --out runs/golden``, check the differences the tests report,
then copy the two files into tests/golden/ and update its README.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import io
import json
import sys
from pathlib import Path

import pytest

from fg_tea.cli.main import main
from golden_match import (csv_differences, event_differences, logs_text, read_logs, read_xz_text, report,
                          write_xz_text)

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "tests" / "golden"
LOGS, COMPARE = GOLDEN / "episode_logs.jsonl.xz", GOLDEN / "compare_quick_episodes.csv.xz"
NAMES = [f"{scenario}-{model}-{seed}" for scenario in ("default_apartment", "generated_small", "milk_sugar_apartment")
         for model in ("factorised", "joint") for seed in (0, 1, 2)]


@functools.cache
def golden_logs() -> dict[str, list[dict]]:
    return read_logs(LOGS)


def run_log(name: str, out: Path) -> list[dict]:
    """The events of `fg-tea run` for a golden log's name, without the machine's details."""
    scenario, model, seed = name.rsplit("-", 2)
    task = ["--task", "make_tea_milk_sugar"] if scenario == "milk_sugar_apartment" else []
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["run", scenario, "--model", model, "--seed", seed, *task, "--no-video",
                     "--out", str(out)]) == 0
    events = [json.loads(line) for line in (out / "episode.jsonl").read_text().splitlines()]
    for key in ("versions", "git", "inputs"):
        events[0].pop(key, None)
    return events


def run_compare(out: Path) -> str:
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["compare", "--quick", "--env", "fake", "--out", str(out)]) == 0
    return (out / "episodes.csv").read_text()


def test_the_golden_file_holds_every_log():
    assert sorted(golden_logs()) == sorted(NAMES)
    assert all(events[0]["event"] == "episode_start" and events[-1]["event"] == "metrics"
               for events in golden_logs().values())


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_a_golden_episode_log_is_unchanged(name, tmp_path):
    found = event_differences(golden_logs()[name], run_log(name, tmp_path))
    assert not found, report(f"{LOGS.relative_to(ROOT)} [{name}]", found)


@pytest.mark.slow
def test_the_golden_quick_comparison_is_unchanged(tmp_path):
    found = csv_differences(read_xz_text(COMPARE), run_compare(tmp_path), key="key")
    assert not found, report(COMPARE.relative_to(ROOT), found)


def record(out: Path) -> None:
    """Write both golden files into `out`, from this checkout's code."""
    out.mkdir(parents=True, exist_ok=True)
    logs = {name: run_log(name, out / "work" / name) for name in NAMES}
    write_xz_text(out / LOGS.name, logs_text(logs))
    write_xz_text(out / COMPARE.name, run_compare(out / "work" / "compare"))
    for path in (out / LOGS.name, out / COMPARE.name):
        print(f"{path}: {path.stat().st_size} bytes")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description="Record the golden logs and comparison CSV afresh.")
    parser.add_argument("--out", type=Path, default=Path("runs/golden"), help="folder to write (runs/golden)")
    record(parser.parse_args().out)
    sys.exit(0)
