"""CI runs what a new user runs: the README's test command, in a fresh virtual environment.

The README opens with two set-up commands (the first runs a make-tea episode, the second the
tests); `.ci/run` must run the second one exactly, after making a fresh venv, so that a green CI
cannot hide a dependency that only the machine's own Python had.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _readme_setup_commands() -> list[str]:
    text = (ROOT / "README.md").read_text()
    block = re.search(r"```bash\n(.*?)```", text, re.S)
    assert block and text.index(block.group(0)) < 200, "the README opens with the set-up commands"
    return [line.split("  #")[0].strip() for line in block.group(1).splitlines() if line.strip()]


def test_the_readme_opens_with_two_fresh_venv_commands():
    run, tests = _readme_setup_commands()
    for command in (run, tests):
        assert command.startswith("python3.11 -m venv .venv && . .venv/bin/activate && pip install -e ")
    assert run.endswith("fg-tea run") and tests.endswith("python -m pytest -q")


def test_ci_runs_the_readme_test_command_in_a_fresh_venv():
    script = (ROOT / ".ci" / "run").read_text()
    _, tests = _readme_setup_commands()
    lines = [line.strip() for line in script.splitlines() if line.strip() and not line.startswith("#")]
    assert tests in lines, f".ci/run does not run {tests!r}"
    assert lines.index("rm -rf .venv") < lines.index(tests), "the venv must be made afresh"
    assert ".venv/" in (ROOT / ".gitignore").read_text().split()
