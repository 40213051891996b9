"""The agent side never imports the simulator (docs/design.md §1: truth lives only in the environment).

Every module under fg_tea/beliefs, fg_tea/planning and fg_tea/tasks, plus fg_tea/scenario.py and
fg_tea/model.py when present, and the simulator-free environment modules (base, truth,
navigation, fake), is checked twice: statically (its import statements, parsed with ast) and
dynamically (imported in a fresh interpreter, after which 'pybullet' must not be in sys.modules).
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
AGENT_DIRS = ("fg_tea/beliefs", "fg_tea/planning", "fg_tea/tasks")
AGENT_FILES = ("fg_tea/scenario.py", "fg_tea/model.py", "fg_tea/learning.py", "fg_tea/env/base.py", "fg_tea/env/truth.py",
               "fg_tea/env/navigation.py", "fg_tea/env/fake.py")
#: Modules that import pybullet themselves: importing them from the agent side is just as bad.
FORBIDDEN = ("pybullet", "pybullet_data", "pybullet_utils", "fg_tea.env.house", "fg_tea.env.assets")


def agent_modules() -> list[Path]:
    files = [ROOT / f for f in AGENT_FILES if (ROOT / f).is_file()]
    for folder in AGENT_DIRS:
        files += sorted((ROOT / folder).rglob("*.py"))
    return files


def forbidden_imports(source: str) -> list[str]:
    """Names of forbidden modules that `source` imports (import, from-import, importlib, __import__)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            names = [node.module] + [f"{node.module}.{alias.name}" for alias in node.names]
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant):
            func = node.func
            called = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if called in ("import_module", "__import__") and isinstance(node.args[0].value, str):
                names = [node.args[0].value]
        found += [n for n in names if any(n == f or n.startswith(f + ".") for f in FORBIDDEN)]
    return found


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def test_the_static_check_can_fail():
    assert forbidden_imports("import pybullet as p") == ["pybullet"]
    assert forbidden_imports("from fg_tea.env import house") == ["fg_tea.env.house"]
    assert forbidden_imports("import importlib\nimportlib.import_module('pybullet_data')") == ["pybullet_data"]
    assert forbidden_imports("import numpy\nfrom fg_tea.env.base import Pose") == []


@pytest.mark.parametrize("path", agent_modules(), ids=lambda p: str(p.relative_to(ROOT)))
def test_agent_module_imports_no_simulator(path):
    assert forbidden_imports(path.read_text()) == []


def test_agent_modules_do_not_load_pybullet_at_run_time():
    modules = [_module_name(p) for p in agent_modules()]
    code = ("import importlib, sys\n"
            f"for name in {modules!r}:\n"
            "    importlib.import_module(name)\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('pybullet', 'pybullet_data')))\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                         env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


#: What the agent side (beliefs, planning, tasks) may import from fg_tea: the layers before it
#: and the agent/environment contract — never the environment, the episode or the renderer.
AGENT_MAY_IMPORT = ("fg_tea.errors", "fg_tea.resources", "fg_tea.scenario", "fg_tea.model", "fg_tea.learning",
                    "fg_tea.interface", "fg_tea.beliefs", "fg_tea.planning", "fg_tea.tasks")


def fg_tea_imports(source: str) -> list[str]:
    names = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.append(node.module)
    return [n for n in names if n == "fg_tea" or n.startswith("fg_tea.")]


def test_the_layer_check_can_fail():
    assert fg_tea_imports("from fg_tea.env.base import EnvConfig\nimport numpy") == ["fg_tea.env.base"]


@pytest.mark.parametrize("folder", AGENT_DIRS)
def test_agent_side_imports_only_earlier_layers(folder):
    for path in sorted((ROOT / folder).rglob("*.py")):
        bad = [n for n in fg_tea_imports(path.read_text())
               if not any(n == ok or n.startswith(ok + ".") for ok in AGENT_MAY_IMPORT)]
        assert not bad, f"{path.relative_to(ROOT)} imports {bad}"
