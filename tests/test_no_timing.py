"""No test asserts a wall-clock time: how long something takes belongs in experiments/ (benchmarks).

A timing assertion fails on a loaded or slower machine while the code is right. This scans every
tests/*.py for an ``assert`` (or an ``if`` that fails the test) whose comparison reads a clock
(``time.perf_counter``, ``time.time``, ``time.monotonic``, ``time.process_time`` and their ``_ns``
forms, however imported) directly or through a name assigned from one (``start``, ``elapsed``).
Hang guards are allowed: an alarm, a ``timeout=`` or a loop that stops at a deadline fails a call
that never returns, not a slow one.
"""

from __future__ import annotations

import ast
import textwrap
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent
CLOCKS = {"perf_counter", "time", "monotonic", "process_time", "perf_counter_ns", "time_ns", "monotonic_ns",
          "process_time_ns"}


def _is_clock_call(node: ast.AST) -> bool:
    if not isinstance(node, ast.Call):
        return False
    f = node.func
    if isinstance(f, ast.Attribute):  # time.perf_counter()
        return f.attr in CLOCKS and isinstance(f.value, ast.Name) and f.value.id == "time"
    return isinstance(f, ast.Name) and f.id in CLOCKS - {"time"}  # from time import perf_counter


def _reads_clock(node: ast.AST, clocked: set[str]) -> bool:
    return any(_is_clock_call(n) or (isinstance(n, ast.Name) and n.id in clocked) for n in ast.walk(node))


def timing_assertions(source: str) -> list[int]:
    """Line numbers of assertions on a wall-clock time in `source` (a test module's text)."""
    tree = ast.parse(source)
    clocked: set[str] = set()
    for _ in range(3):  # names assigned from a clock, or from names that were (elapsed = now - start)
        for node in ast.walk(tree):
            if isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)) and node.value is not None \
                    and _reads_clock(node.value, clocked):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                clocked |= {n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Assert):
            checks = [node.test]
        elif isinstance(node, ast.If) and any(
                isinstance(n, ast.Raise) or (isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute)
                                             and n.func.attr == "fail") for b in node.body for n in ast.walk(b)):
            checks = [node.test]
        else:
            continue
        for test in checks:
            if any(isinstance(n, ast.Compare) and _reads_clock(n, clocked) for n in ast.walk(test)):
                found.append(node.lineno)
    return found


@pytest.mark.parametrize("path", sorted(TESTS.glob("*.py")), ids=lambda p: p.name)
def test_no_test_asserts_a_wall_clock_time(path):
    lines = timing_assertions(path.read_text(encoding="utf-8"))
    assert not lines, (f"{path.name}: lines {lines} assert a wall-clock time; a slow machine fails them. "
                       "Keep a generous hang guard (an alarm or timeout=) and put timing in experiments/.")


def test_the_scan_finds_timing_assertions_and_leaves_hang_guards_alone():
    timed = textwrap.dedent("""
        import time
        from time import perf_counter
        def test_a():
            start = time.perf_counter()
            work()
            assert time.perf_counter() - start < 45
        def test_b():
            t0 = perf_counter()
            work()
            elapsed = perf_counter() - t0
            assert ok and elapsed <= 30
        def test_c():
            began = time.monotonic()
            if time.monotonic() - began > 5:
                pytest.fail("too slow")
    """)
    assert timing_assertions(timed) == [7, 12, 15]
    guards = textwrap.dedent("""
        import time
        def test_a():
            deadline = time.monotonic() + 600  # a hang guard
            while time.monotonic() < deadline:
                if done():
                    break
                time.sleep(0.2)
            assert done()
            subprocess.run(["x"], timeout=600)
            assert json.loads(text)["episode_s"] >= 0
            print(f"took {time.perf_counter() - deadline:.1f} s")
    """)
    assert timing_assertions(guards) == []
