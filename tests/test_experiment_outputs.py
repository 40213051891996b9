"""Where do the experiment scripts write when nobody says where?

Every script in ``experiments/`` writes under ``runs/`` (``runs/experiments/<script>/``, relative
to the working directory like every fg-tea output) unless ``--out`` says otherwise, so the
committed results in ``experiments/results/`` (and the README's figures in ``docs/``) change only
when a command names them. The scripts' own argument parsing is run up to the parsed namespace
(``ArgumentParser.parse_args`` is wrapped to stop there), so no experiment runs; one script,
``inspect_marginals.py``, also runs end to end without ``--out`` in an empty folder.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXPERIMENTS = ROOT / "experiments"
SCRIPTS = sorted(p.name for p in EXPERIMENTS.glob("*.py"))
#: Scripts that only print a table and write no file (they have no --out).
PRINT_ONLY = {"bench_episode.py", "bench_house.py", "bench_planning.py"}


class _Parsed(Exception):
    """Raised by the wrapped parse_args with the namespace, so the script stops there."""

    def __init__(self, namespace: argparse.Namespace) -> None:
        super().__init__("parsed")
        self.namespace = namespace


def _module(name: str):
    spec = importlib.util.spec_from_file_location(f"_experiment_{Path(name).stem}", EXPERIMENTS / name)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module     # dataclasses look their module up while a class is built
    spec.loader.exec_module(module)
    return module


def _parse(module, argv: list[str], monkeypatch) -> argparse.Namespace:
    """The namespace the script's ``main(argv)`` parses, without running the script."""
    original = argparse.ArgumentParser.parse_args

    def stop(self, args=None, namespace=None):
        raise _Parsed(original(self, args, namespace))

    monkeypatch.setattr(argparse.ArgumentParser, "parse_args", stop)
    with pytest.raises(_Parsed) as parsed:
        module.main(argv)
    monkeypatch.undo()
    return parsed.value.namespace


def _default_output(name: str, module, argv: list[str], monkeypatch) -> Path | None:
    args = _parse(module, argv, monkeypatch)
    if name in ("bench_inference.py", "planner_frontier.py"):
        return module.output_path(args)          # resolved after parsing (none for --quick; by yardstick)
    return None if getattr(args, "out", None) is None else Path(args.out)


def _assert_under_runs(out: Path) -> None:
    assert not out.is_absolute() and out.parts[0] == "runs", out
    resolved = (ROOT / out).resolve()
    assert (ROOT / "runs") in resolved.parents
    assert (ROOT / "experiments" / "results") not in resolved.parents and resolved.parent != ROOT


@pytest.mark.parametrize("name", SCRIPTS)
def test_default_output_lies_under_runs(name, monkeypatch):
    monkeypatch.chdir(ROOT)
    module = _module(name)
    args = _parse(module, [], monkeypatch)
    if name in PRINT_ONLY:
        assert not hasattr(args, "out"), f"{name} gained --out: give it a default under runs/"
        return
    out = _default_output(name, module, [], monkeypatch)
    assert out is not None, f"{name} writes files but has no default output"
    _assert_under_runs(out)
    assert out.parts[:3] == ("runs", "experiments", Path(name).stem)
    if hasattr(module, "DEFAULT_OUT"):
        assert out == Path(module.DEFAULT_OUT)


def test_ablations_example_does_not_touch_the_committed_results(monkeypatch):
    module = _module("ablations.py")
    out = _default_output("ablations.py", module, ["--worlds", "3", "--ablations", "no_epistemic",
                                                   "weak_negative"], monkeypatch)
    assert out == Path("runs/experiments/ablations")
    _assert_under_runs(out)
    named = _default_output("ablations.py", module, ["--out", "experiments/results/ablations"], monkeypatch)
    assert named == Path("experiments/results/ablations")


def test_compare_beliefs_default_and_an_explicit_out(monkeypatch):
    module = _module("compare_beliefs.py")
    assert Path(_parse(module, ["--worlds", "3"], monkeypatch).out) == Path("runs/experiments/compare_beliefs")
    named = _parse(module, ["--out", "experiments/results/compare"], monkeypatch).out
    assert Path(named) == Path("experiments/results/compare")


def test_bench_inference_writes_no_file_on_quick_and_runs_otherwise(monkeypatch):
    module = _module("bench_inference.py")
    assert _default_output("bench_inference.py", module, ["--quick"], monkeypatch) is None
    full = _default_output("bench_inference.py", module, [], monkeypatch)
    assert full == Path("runs/experiments/bench_inference/bench_inference.md")
    named = _default_output("bench_inference.py", module,
                            ["--out", "experiments/results/bench_inference.md"], monkeypatch)
    assert named == Path("experiments/results/bench_inference.md")


def test_inspect_marginals_without_out_writes_only_under_runs(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, str(EXPERIMENTS / "inspect_marginals.py"), "--model",
                           "factorised", "--seed", "1"],
                          capture_output=True, text=True, timeout=300, env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    png = tmp_path / "runs" / "experiments" / "inspect_marginals" / "inspect_marginals.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["runs"]


#: Scripts whose --out is one file (the others take a folder).
FILE_OUTPUT = {"bench_inference.py", "bench_paths.py", "bench_program_scale.py", "bench_sweep_driver.py",
               "bench_throughput.py", "bench_video.py",
               "derive_relations.py", "inspect_marginals.py", "profile_video.py", "video_renderers.py",
               "video_stages.py", "video_tinyrenderer.py"}


@pytest.mark.parametrize("name", sorted(set(SCRIPTS) - PRINT_ONLY))
def test_an_unwritable_out_is_refused_before_any_work(name, tmp_path, capsys):
    """--out is checked while the options are read: one line, exit 2, nothing run. (It used to be
    found out only when the results were written, after every episode.)"""
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder\n")
    out = tmp_path if name in FILE_OUTPUT else blocker / "sub"
    module = _module(name)
    try:
        status = module.main(["--out", str(out)])
    except SystemExit as exc:  # argparse: "NAME: error: argument --out: ..."
        status = exc.code
    assert status == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--out" in err[0], err  # compare_beliefs.py is fg-tea compare's parser
    assert ("is a folder; name a file" if name in FILE_OUTPUT else "cannot create folder") in err[0]


def test_the_calibration_script_takes_a_markdown_file_as_out(tmp_path, monkeypatch):
    """Its committed output is one .md file (the CSV beside it): --out x.md is a file, not a folder."""
    module = _module("check_detector_calibration.py")
    args = _parse(module, ["--out", str(tmp_path / "cal.md")], monkeypatch)
    assert args.out == str(tmp_path / "cal.md") and not (tmp_path / "cal.md").exists()
