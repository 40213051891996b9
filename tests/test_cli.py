"""The command line as a user meets it: `fg-tea list`, help for every argument, option names
(``--solver``, ``--executor`` and their deprecated alias ``--backend``), bundled names accepted by
every command, and a quiet end when the reader of the output goes away."""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import subprocess
import sys
from pathlib import Path

import pytest

from fg_tea.cli import build_parser, main
from fg_tea.common.resources import KINDS, bundled, bundled_names, resolve_model

ROOT = Path(__file__).resolve().parent.parent


def cli(argv) -> tuple[int, str, str]:
    """Run ``fg-tea argv`` in-process; return (exit status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main([str(a) for a in argv])
        except SystemExit as exc:  # argparse: usage errors and --help
            status = exc.code
    return status, out.getvalue(), err.getvalue()


def _walk(parser: argparse.ArgumentParser, prefix: str = "fg-tea"):
    """(command, action) for every action of `parser` and of its subcommands, recursively."""
    for action in parser._actions:
        yield prefix, action
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _walk(sub, f"{prefix} {name}")


def test_every_argument_of_every_command_has_help():
    actions = list(_walk(build_parser()))
    commands = {command for command, _ in actions}
    assert {"fg-tea list", "fg-tea run", "fg-tea compare", "fg-tea validate", "fg-tea preview",
            "fg-tea beliefs", "fg-tea render", "fg-tea house"} <= commands
    missing = [f"{command}: {action.option_strings or action.dest}" for command, action in actions
               if not action.help or action.help == argparse.SUPPRESS]
    assert not missing, missing


def test_the_help_check_can_fail():
    parser = argparse.ArgumentParser()
    parser.add_argument("--bare")
    assert [a.dest for _, a in _walk(parser) if not a.help] == ["bare"]


def test_list_prints_every_bundled_name_by_kind():
    status, out, err = cli(["list"])
    assert status == 0 and err == ""
    for kind in KINDS:
        assert f"{kind} (" in out
        names = bundled_names(kind)
        assert names, kind
        for name in names:
            assert f"  {name}  " in out or f"  {name} " in out, (kind, name)
    assert "no_epistemic" in out and "correlated" in out and "make_tea_milk_sugar" in out
    line = next(line for line in out.splitlines() if line.strip().startswith("default_apartment"))
    assert "Four-room apartment" in line  # the one-line description


def test_list_paths_and_kinds():
    status, out, _ = cli(["list", "--paths", "ablations"])
    assert status == 0
    paths = [Path(p) for p in out.splitlines()]
    assert paths == bundled("models/ablations", ".toml") and all(p.is_file() for p in paths)
    status, _, err = cli(["list", "nonsense"])
    assert status == 2 and "unknown kind 'nonsense'" in err and len(err.splitlines()) == 1


def test_every_bundled_model_and_ablation_name_resolves():
    for name in bundled_names("models") + bundled_names("ablations"):
        path = resolve_model(name)
        assert path.is_file() and path.stem == name


@pytest.mark.parametrize("name", ["no_epistemic", "weak_negative"])
def test_run_accepts_an_ablation_name(tmp_path, name):
    status, out, err = cli(["run", "--no-video", "--model", name, "--max-frames", "60",
                            "--out", tmp_path])
    assert status in (0, 1), err  # the frame limit may end it early; the name must resolve
    assert "Traceback" not in err and "not found" not in err
    start = (tmp_path / "episode.jsonl").read_text().splitlines()[0]
    assert f'"{name}"' in start


def test_beliefs_accepts_an_ablation_name_and_the_solver_option():
    status, out, err = cli(["beliefs", "--model", "no_relevance", "--solver", "gtsam"])
    assert status == 0, err
    assert "model no_relevance" in out and "solver gtsam" in out and err == ""


def test_validate_accepts_bundled_names():
    status, out, err = cli(["validate", "make_tea", "no_epistemic", "generated_small"])
    assert status == 0, err
    lines = out.splitlines()
    assert any("make_tea.json: ok (task)" in line for line in lines)
    assert any("no_epistemic.toml: ok (model)" in line for line in lines)
    # a scenario and a world distribution share this name: both are checked
    assert any(line.endswith("generated_small.json: ok (scenario)") for line in lines)
    assert any(line.endswith("generated_small.json: ok (world)") for line in lines)
    status, _, err = cli(["validate", "no_such_thing"])
    assert status == 2 and len(err.splitlines()) == 1


def test_backend_is_a_deprecated_alias_of_solver():
    parser = build_parser()
    args = parser.parse_args(["run", "--backend", "gtsam"])
    assert args.solver == "gtsam" and not hasattr(args, "backend")
    assert parser.parse_args(["run"]).solver == "numpy"
    assert parser.parse_args(["beliefs", "--solver", "gtsam"]).solver == "gtsam"
    status, out, err = cli(["beliefs", "--backend", "gtsam"])
    assert status == 0
    assert err.splitlines() == ["fg-tea: note: --backend is deprecated; use --solver"]
    assert "solver gtsam" in out


def test_backend_is_a_deprecated_alias_of_executor():
    parser = build_parser()
    args = parser.parse_args(["compare", "--backend", "serial"])
    assert args.executor == "serial"
    assert parser.parse_args(["compare"]).executor == "process"
    assert parser.parse_args(["compare", "--executor", "ray"]).executor == "ray"


def test_a_deprecated_alias_leaves_no_note_when_the_command_line_is_bad():
    status, _, err = cli(["run", "--backend", "gtsam", "--seed", "-1"])
    assert status == 2 and len(err.splitlines()) == 1 and err.startswith("fg-tea: error: ")


def test_a_deprecated_alias_and_a_later_input_fault_are_still_one_line(tmp_path):
    status, _, err = cli(["compare", "--backend", "serial", "--world", "inf", "--env", "fake",
                          "--out", tmp_path / "x"])
    assert status == 2 and len(err.splitlines()) == 1, err
    assert "unknown world 'inf'" in err and "(note: --backend is deprecated; use --executor)" in err


def test_compare_with_the_old_executor_name_still_runs(tmp_path):
    status, out, err = cli(["compare", "--backend", "serial", "--env", "fake", "--worlds", "1",
                            "--planners", "nearest", "--models", "factorised", "no_epistemic",
                            "--out", tmp_path])
    assert status == 0, err
    assert err.splitlines()[-1] == "fg-tea: note: --backend is deprecated; use --executor"
    assert "no_epistemic" in (tmp_path / "episodes.csv").read_text()


def test_a_broken_pipe_ends_quietly():
    """``fg-tea list | head -0``: the reader has gone before anything is written; no traceback,
    no message, and the status a shell gives a pipeline whose reader left (128 + SIGPIPE)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "fg_tea.cli", "list"], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader goes away before the interpreter has even started
    err = proc.stderr.read().decode()
    status = proc.wait(timeout=300)
    assert err == "", err
    assert status == 141


def test_blas_threads_default_to_one_but_a_users_setting_stays():
    from fg_tea.cli.main import BLAS_THREAD_VARIABLES, single_threaded_blas_defaults

    env = {"OMP_NUM_THREADS": "4"}
    chosen = single_threaded_blas_defaults(env)
    assert env["OMP_NUM_THREADS"] == "4" and "OMP_NUM_THREADS" not in chosen
    assert all(env[v] == "1" for v in BLAS_THREAD_VARIABLES if v != "OMP_NUM_THREADS")


def test_the_command_line_module_loads_without_numpy():
    # main() sets the BLAS thread defaults first; they take effect only if numpy is not loaded
    # yet, so importing the command line must not import it.
    import subprocess
    import sys

    code = "import sys, fg_tea.cli; print('numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
