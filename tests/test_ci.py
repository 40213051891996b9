"""CI runs what a new user runs: the README's test command, in a fresh virtual environment.

The README opens with two set-up commands (the first runs a make-tea episode, the second the
tests); `.ci/run` must run the second one exactly, after making a fresh venv, so that a green CI
cannot hide a dependency that only the machine's own Python had. The test command installs with
the lock, requirements/lock-test.txt, as constraints: it must pin every dependency, within the
ranges of pyproject.toml, and say how it was made. `.ci/newest` runs the suite without the lock,
at the newest versions those ranges allow.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parent.parent
LOCK = "requirements/lock-test.txt"


def _readme_setup_commands() -> list[str]:
    text = (ROOT / "README.md").read_text()
    block = re.search(r"```bash\n(.*?)```", text, re.S)
    assert block and text.index(block.group(0)) < 200, "the README opens with the set-up commands"
    return [line.split("  #")[0].strip() for line in block.group(1).splitlines() if line.strip()]


def test_the_readme_opens_with_two_fresh_venv_commands():
    run, tests = _readme_setup_commands()
    venv = "python3.11 -m venv .venv && . .venv/bin/activate && "
    assert run == venv + "pip install -e . && fg-tea run"  # a user's install: the newest allowed versions
    assert tests == venv + f'pip install -c {LOCK} -e ".[test]" && python -m pytest -q'  # CI's: the lock


def test_ci_runs_the_readme_test_command_in_a_fresh_venv():
    script = (ROOT / ".ci" / "run").read_text()
    _, tests = _readme_setup_commands()
    lines = [line.strip() for line in script.splitlines() if line.strip() and not line.startswith("#")]
    assert tests in lines, f".ci/run does not run {tests!r}"
    assert lines.index("rm -rf .venv") < lines.index(tests), "the venv must be made afresh"
    assert ".venv/" in (ROOT / ".gitignore").read_text().split()


def _lock() -> dict[str, str]:
    pins = {}
    for line in (ROOT / LOCK).read_text().splitlines():
        if line.strip() and not line.lstrip().startswith("#"):
            name, sep, version = line.strip().partition("==")
            assert sep and version and " " not in version, f"{LOCK}: {line!r} is not NAME==VERSION"
            pins[canonicalize_name(name)] = version
    return pins


def test_the_lock_pins_every_dependency_within_the_ranges_of_pyproject():
    """Re-lock after changing a dependency: the command is in the lock's header."""
    header = (ROOT / LOCK).read_text().split("\n\n")[0]
    assert "pip-compile" in header and "--extra=test" in header and "pyproject.toml" in header
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    pins = _lock()
    for spec in project["dependencies"] + project["optional-dependencies"]["test"]:
        req = Requirement(spec)
        name = canonicalize_name(req.name)
        assert name in pins, f"{LOCK} does not pin {req.name} (pyproject.toml: {spec})"
        assert req.specifier.contains(pins[name], prereleases=True), \
            f"{LOCK} pins {req.name}=={pins[name]}, outside pyproject.toml's {spec}"


def test_the_newest_allowed_versions_have_their_own_run():
    script = (ROOT / ".ci" / "newest").read_text()
    lines = [line.strip() for line in script.splitlines() if line.strip() and not line.startswith("#")]
    install = next(line for line in lines if line.startswith("pip install"))
    assert "--upgrade" in install and '-e ".[test]"' in install and "-c" not in install.split()
    assert lines.index('rm -rf "$VENV"') < lines.index(install) < lines.index('python -m pytest -q "$@"')
    assert (ROOT / ".ci" / "newest").stat().st_mode & 0o111, ".ci/newest must be executable"
