"""Does every experiment script say, under ``--help``, what it is and what each option means?

Each ``experiments/*.py`` builds its parser in ``build_parser()``; the parser is built in-process
(the scripts are imported as modules, as in ``tests/test_experiment_outputs.py``) and checked: the
usage line names the script's file, the description and an epilog citing docs/design.md are
there, and every option has help. One script is also run as a user runs it (``--help`` in a
subprocess): ``compare_beliefs.py``, which reuses the options of ``fg-tea compare``.
"""

from __future__ import annotations

import argparse
import ast
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXPERIMENTS = ROOT / "experiments"
SCRIPTS = sorted(p.name for p in EXPERIMENTS.glob("*.py"))


def _module(name: str):
    spec = importlib.util.spec_from_file_location(f"_experiment_help_{Path(name).stem}", EXPERIMENTS / name)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module     # dataclasses look their module up while a class is built
    spec.loader.exec_module(module)
    return module


def _uses_argparse(name: str) -> bool:
    text = (EXPERIMENTS / name).read_text()
    return "def main" in text and ("argparse" in text or "experiment_parser" in text or "fg_tea.cli" in text)


def test_every_script_is_checked():
    assert SCRIPTS and all(_uses_argparse(n) for n in SCRIPTS)


@pytest.mark.parametrize("name", SCRIPTS)
def test_help_names_the_script_and_explains_every_option(name):
    module = _module(name)
    assert hasattr(module, "build_parser"), f"{name}: expose the parser as build_parser()"
    parser = module.build_parser()
    assert isinstance(parser, argparse.ArgumentParser)
    text = parser.format_help()
    assert text.startswith(f"usage: {name}"), text[:200]
    assert parser.description and parser.description.strip()
    assert parser.epilog and "docs/design.md §" in parser.epilog, parser.epilog
    bare = [a.option_strings or [a.dest] for a in parser._actions
            if not isinstance(a, argparse._HelpAction) and not (a.help or "").strip()]
    assert not bare, f"{name}: options without help: {bare}"
    for action in parser._actions:       # every help string expands (no stray % signs)
        if action.help and action.help is not argparse.SUPPRESS:
            parser._get_formatter()._expand_help(action)


@pytest.mark.parametrize("name", SCRIPTS)
def test_docstring_examples_use_no_deprecated_option(name):
    doc = ast.get_docstring(ast.parse((EXPERIMENTS / name).read_text())) or ""
    examples = [line for line in doc.splitlines() if "experiments/" in line and "python" in line]
    assert not [line for line in examples if "--backend" in line], \
        f"{name}: --backend is the deprecated name of --executor"
    assert not re.search(r"deprecated[^\n]*--backend|--backend[^\n]*deprecated", doc)


def test_docs_use_no_deprecated_backend_option_in_examples():
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        for line in path.read_text().splitlines():
            if re.search(r"(fg-tea compare|experiments/\w+\.py)[^`]*--backend", line):
                pytest.fail(f"{path.relative_to(ROOT)}: example uses --backend: {line.strip()}")


def test_compare_beliefs_help_run_as_a_script():
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, str(EXPERIMENTS / "compare_beliefs.py"), "--help"],
                          capture_output=True, text=True, timeout=300, env=env, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.startswith("usage: compare_beliefs.py"), proc.stdout[:300]
    assert "fg-tea compare" not in proc.stdout.splitlines()[0]
    for option in ("--worlds", "--world", "--models", "--planners", "--executor", "--out", "--quick"):
        assert option in proc.stdout
    assert "runs/experiments/compare_beliefs" in proc.stdout    # its own --out default
