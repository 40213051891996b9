"""The layers of docs/design.md §1, checked from the code's own imports.

1. The agent side never imports the simulator (truth lives only in the environment): every module
   under common/, world/, model/, beliefs/, planning/ and tasks/, and the simulator-free
   environment modules (base, truth, adapter, verbs, motion, fake), is checked statically (its import
   statements, parsed with ast) and dynamically (imported in a fresh interpreter, after which
   'pybullet' must not be in sys.modules).
2. Folder rules: each folder of fg_tea/ imports only the folders below it (``LAYERS``), the import
   graph has no cycle, the top of the package holds packages, and no module is over 600 lines.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
AGENT_DIRS = ("fg_tea/common", "fg_tea/world", "fg_tea/model", "fg_tea/beliefs", "fg_tea/planning",
              "fg_tea/tasks", "fg_tea/agent")
AGENT_FILES = ("fg_tea/env/base.py", "fg_tea/env/truth.py", "fg_tea/env/adapter.py", "fg_tea/env/verbs.py",
               "fg_tea/env/motion.py", "fg_tea/env/fake.py")
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
                         env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


#: Which folders each folder of fg_tea/ may import from (docs/design.md §1). Lower layers never
#: import higher ones; the agent side (beliefs, planning, tasks) never imports env, episode, render,
#: study or cli. ``fg_tea/__init__.py`` (the public API) and ``cli`` may import everything.
LAYERS = {
    "common": set(),
    "world": {"common"},
    "model": {"common", "world"},
    "beliefs": {"common", "world", "model"},
    "planning": {"common", "world", "model", "beliefs"},
    "tasks": {"common", "world", "model", "beliefs"},
    "agent": {"common", "world", "model", "beliefs", "planning", "tasks"},
    "env": {"common", "world"},
    "episode": {"common", "world", "model", "beliefs", "planning", "tasks", "agent", "env"},
    "render": {"common", "world", "model", "tasks", "env", "episode"},
    "study": {"common", "world", "model", "beliefs", "planning", "tasks", "agent", "env", "episode",
              "render"},
    "cli": {"common", "world", "model", "beliefs", "planning", "tasks", "agent", "env", "episode",
            "render", "study"},
    "_bundle": set(),
}
#: Modules at the top of fg_tea/ besides __init__.py: at most two, and small.
TOP_MODULES = {"_version.py"}
#: Lines a module may have, and characters a line (docs/design.md §1.2); no module is excepted.
MAX_LINES = 600
MAX_LINE_LENGTH = 120


def fg_tea_imports(source: str) -> list[str]:
    """Every fg_tea module `source` imports, at any depth (lazy imports inside functions count)."""
    names = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.append(node.module)
            # from fg_tea.planning import plugins: a module of the package (kept where it is one)
            names += [f"{node.module}.{a.name}" for a in node.names if _is_module(f"{node.module}.{a.name}")]
    return [n for n in names if n == "fg_tea" or n.startswith("fg_tea.")]


def _is_module(name: str) -> bool:
    path = ROOT / name.replace(".", "/")
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def folder_of(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and (ROOT / "fg_tea" / parts[1]).is_dir() else None


def package_files() -> list[Path]:
    return sorted(p for p in (ROOT / "fg_tea").rglob("*.py") if "__pycache__" not in p.parts)


def test_the_layer_check_can_fail():
    assert fg_tea_imports("from fg_tea.env.base import EnvConfig\nimport numpy") == ["fg_tea.env.base"]
    assert fg_tea_imports("def f():\n    from fg_tea import cli") == ["fg_tea", "fg_tea.cli"]
    assert fg_tea_imports("from fg_tea.planning import Decision, plugins") == [
        "fg_tea.planning", "fg_tea.planning.plugins"]
    assert folder_of("fg_tea.env.base") == "env" and folder_of("fg_tea._version") is None


def test_every_folder_has_a_rule():
    folders = {p.name for p in (ROOT / "fg_tea").iterdir() if p.is_dir() and p.name != "__pycache__"}
    assert folders == set(LAYERS), f"give {sorted(folders ^ set(LAYERS))} a rule in LAYERS"


@pytest.mark.parametrize("folder", sorted(LAYERS))
def test_folders_import_only_lower_layers(folder):
    bad = []
    for path in sorted((ROOT / "fg_tea" / folder).rglob("*.py")):
        for name in fg_tea_imports(path.read_text()):
            other = folder_of(name)
            if name == "fg_tea":
                bad.append((path.name, name))
            elif other is not None and other != folder and other not in LAYERS[folder]:
                bad.append((path.name, name))
    assert not bad, f"fg_tea/{folder} imports a higher layer: {bad}"


def test_the_import_graph_has_no_cycle():
    import networkx as nx

    graph = nx.DiGraph()
    for path in package_files():
        me = _module_name(path)
        for name in fg_tea_imports(path.read_text()):
            if name not in (me, "fg_tea") and _is_module(name):
                graph.add_edge(me, name)
    cycles = list(nx.simple_cycles(graph))
    assert not cycles, f"import cycles: {cycles[:5]}"


def test_the_top_of_the_package_holds_packages_and_at_most_two_small_modules():
    loose = {p.name for p in (ROOT / "fg_tea").glob("*.py")} - {"__init__.py"}
    assert loose <= TOP_MODULES and len(loose) <= 2, f"move {sorted(loose - TOP_MODULES)} into a folder"
    for name in loose:
        assert len((ROOT / "fg_tea" / name).read_text().splitlines()) <= 50


def test_no_module_is_longer_than_the_limit():
    long = {str(p.relative_to(ROOT)): n for p in package_files()
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, f"split these modules by what each part is for (design §1.2): {long}"


def test_no_line_is_longer_than_the_limit():
    long = [f"{p.relative_to(ROOT)}:{i}" for p in package_files()
            for i, line in enumerate(p.read_text().splitlines(), 1) if len(line) > MAX_LINE_LENGTH]
    assert not long, f"lines over {MAX_LINE_LENGTH} characters (split by meaning, design §1.2): {long}"
