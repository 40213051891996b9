"""Are the experiment scripts a layer on top of the package, held to one set of rules?

docs/how-to/new-experiment.md states the rules: a script imports the installed ``fg_tea`` (it
never edits ``sys.path``), uses only public names (no ``from fg_tea.x import _name``), builds its
parser in ``build_parser()``, and writes under ``runs/`` by default. The page's example script is
run as it stands: ``--help``, a bad flag (one line, exit 2), and a three-world run in the fake
house that writes its table.
"""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted((ROOT / "experiments").glob("*.py"))
PAGE = ROOT / "docs" / "how-to" / "new-experiment.md"


def _path_edits(tree: ast.AST) -> list[int]:
    """Lines that touch ``sys.path`` (an insert, an append, an assignment)."""
    return [node.lineno for node in ast.walk(tree)
            if isinstance(node, ast.Attribute) and node.attr == "path"
            and isinstance(node.value, ast.Name) and node.value.id == "sys"]


def _private_imports(tree: ast.AST) -> list[str]:
    """``module.name`` for every private name imported from fg_tea."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "fg_tea":
            found += [f"{node.module}.{a.name}" for a in node.names if a.name.startswith("_")]
            if any(part.startswith("_") for part in node.module.split(".")[1:]):
                found.append(node.module)
    return found


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_script_imports_the_package_and_only_its_public_names(script: Path):
    tree = ast.parse(script.read_text())
    assert _path_edits(tree) == [], f"{script.name} edits sys.path (docs/how-to/new-experiment.md)"
    assert _private_imports(tree) == [], f"{script.name} imports private names"
    names = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
    assert {"build_parser", "main"} <= names, f"{script.name} lacks build_parser() or main()"


def test_the_rules_catch_what_they_forbid():
    bad = ast.parse("import sys\nsys.path.insert(0, 'x')\nfrom fg_tea.study.sweep import _model, plan\n"
                    "from fg_tea._bundle import x\n")
    assert _path_edits(bad) == [2]
    assert _private_imports(bad) == ["fg_tea.study.sweep._model", "fg_tea._bundle"]


def _page_script() -> str:
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(), re.S)
    assert len(blocks) == 1
    return blocks[0]


def test_the_how_to_example_runs_as_it_stands(tmp_path: Path):
    script = tmp_path / "experiments" / "two_planners.py"
    script.parent.mkdir()
    script.write_text(_page_script())
    env = {**os.environ, "PYTHONHASHSEED": "0"}

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, str(script), *args], cwd=tmp_path, env=env,
                              capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)

    shown = run("--help")
    assert shown.returncode == 0 and "two_planners.py" in shown.stdout and "§11" in shown.stdout
    bad = run("--worlds", "many")
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
    done = run("--worlds", "2")
    assert done.returncode == 0, done.stderr
    table = (tmp_path / "runs" / "experiments" / "two_planners" / "two_planners.md").read_text()
    assert re.search(r"^\| efe \| 2 \| \d+\.\d\d \|$", table, re.M), table
    assert re.search(r"^\| greedy \| 2 \| \d+\.\d\d \|$", table, re.M), table
