"""The Agent is the only door (docs/design.md §1.1): the runner, study/ and the experiments that
drive an agent reach the belief engine, the task executor and the view geometry only through the
Agent's public verbs (and its labelled belief, read only), never the parts themselves."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: The agent's parts: read through an agent or a runner, they bypass the agent's verbs.
PARTS = {"executor", "views", "graph", "planner_spec", "_navigator", "_handed_out"}
#: Modules whose classes are the agent's parts (names a caller may still import from them). A
#: study may build a belief of its own from a scenario (a prior to score), never an executor or
#: views; the runner builds none.
PART_MODULES = {"fg_tea.beliefs.detection": set(), "fg_tea.tasks.executor": {"NOT_FOUND"}}
RUNNER_PART_MODULES = {**PART_MODULES, "fg_tea.beliefs.engine": set()}
#: What a runner or a study reads through the runner's agent besides its verbs.
HOLDERS = {"agent", "runner", "child"}


def _holder(node: ast.expr) -> str | None:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    return None


def reach_throughs(source: str, filename: str = "<source>", modules=RUNNER_PART_MODULES) -> list[str]:
    """Every place `source` reads an agent's part or imports a part's class from `modules`, as
    'line: what', in line order."""
    out: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(source, filename)):
        if isinstance(node, ast.Attribute) and node.attr in PARTS and _holder(node.value) in HOLDERS:
            out.append((node.lineno, f"{_holder(node.value)}.{node.attr}"))
        elif isinstance(node, ast.Attribute) and node.attr == "belief" and _holder(node.value) == "runner":
            out.append((node.lineno, "runner.belief"))
        elif isinstance(node, ast.ImportFrom) and node.module in modules:
            bad = [a.name for a in node.names if a.name not in modules[node.module]]
            if bad:
                out.append((node.lineno, f"from {node.module} import {', '.join(bad)}"))
        elif isinstance(node, ast.Attribute) and node.attr == "events" and _holder(node.value) == "executor":
            out.append((node.lineno, "executor.events"))
    return [f"{line}: {what}" for line, what in sorted(out)]


def _checked_files() -> dict[Path, dict]:
    """The runner, every study module, the rest of episode/, cli/ and render/, and the experiments
    that drive an agent or a runner."""
    files = {ROOT / "fg_tea" / "episode" / "runner.py": RUNNER_PART_MODULES}
    for path in sorted((ROOT / "fg_tea" / "study").glob("*.py")):
        files[path] = PART_MODULES
    for folder in ("episode", "cli", "render"):  # every other reader of an agent: its attributes only
        for path in sorted((ROOT / "fg_tea" / folder).glob("*.py")):
            files.setdefault(path, {})
    for path in sorted((ROOT / "experiments").glob("*.py")):
        if "Agent(" in (text := path.read_text()) or "EpisodeRunner(" in text:
            files[path] = {}  # a benchmark may build parts of its own to time a planner on
    return files


def test_the_checker_finds_a_reach_through():
    sample = ("from fg_tea.tasks.executor import TaskExecutor\n"
              "objects = runner.agent.executor.pending_search_objects()\n"
              "names = agent.views.names\n"
              "q = runner.belief.location_matrix()\n"
              "n = len(runner.graph)\n")
    assert reach_throughs(sample) == ["1: from fg_tea.tasks.executor import TaskExecutor",
                                      "2: agent.executor", "3: agent.views", "4: runner.belief",
                                      "5: runner.graph"]
    assert reach_throughs("q = runner.agent.belief.location_matrix()\nobjects = agent.searching()\n") == []


def test_runner_and_study_use_only_the_agents_verbs():
    checked = _checked_files()
    assert ROOT / "experiments" / "inspect_marginals.py" in checked
    found = {str(p.relative_to(ROOT)): hits for p, modules in checked.items()
             if (hits := reach_throughs(p.read_text(), str(p), modules))}
    assert found == {}


def test_the_runner_keeps_no_pass_through_properties():
    from fg_tea.episode.runner import EpisodeRunner

    for name in ("belief", "executor", "graph", "planner", "views", "last_decision"):
        assert not hasattr(EpisodeRunner, name), name
