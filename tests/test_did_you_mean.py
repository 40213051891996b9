"""A mistyped planner or option gets "did you mean", in one line with exit 2 (bundled names:
tests/test_cli.py)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from fg_tea.cli.main import main

ROOT = Path(__file__).resolve().parent.parent


def _status(argv) -> int:
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


@pytest.mark.parametrize("argv, hint", [
    (["run", "--planner", "efee", "--no-video"], "did you mean 'efe'?"),
    (["compare", "--planners", "lookahed"], "did you mean 'lookahead'?"),
    (["run", "--no-vidoe"], "--no-vidoe: did you mean --no-video?"),
    (["compare", "--planers", "efe"], "--planers: did you mean --planners?"),
    (["run", "--max-fames=20"], "--max-fames: did you mean --max-frames?"),
    # an option of another command is no typo: it used to suggest itself
    (["run", "--scenario", "x"], "--scenario: not an option of this command, see its --help"),
])
def test_fg_tea_suggests_the_planner_or_option_meant(argv, hint, capsys, tmp_path):
    assert _status([*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and hint in err[0], err


def test_an_experiment_script_suggests_the_option_meant(capsys):
    spec = importlib.util.spec_from_file_location("_ablations", ROOT / "experiments" / "ablations.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert _status_of(module.main, ["--wrolds", "3"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["ablations.py: error: unrecognized arguments: --wrolds 3 (--wrolds: did you mean --worlds?)"]


def _status_of(fn, argv) -> int:
    try:
        return fn(argv)
    except SystemExit as exc:
        return int(exc.code)
