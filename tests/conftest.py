"""Fixtures shared by test files: the system's headless Chromium, driven by Playwright.

Locally the browser tests skip with a one-line reason when Chromium or Playwright is missing;
under CI (``FG_TEA_BROWSER_REQUIRED=1``, set by .ci/run) a missing browser is a failure.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REQUIRED = os.environ.get("FG_TEA_BROWSER_REQUIRED") == "1"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
#: Chromium's flags on a machine with no network and no display (docs/guide/tests.md).
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run", "--disable-dev-shm-usage"]


def _missing() -> str | None:
    if CHROMIUM is None:
        return "no chromium on PATH (Debian: apt-get install chromium)"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "the playwright package is not installed (pip install -e '.[test]')"
    return None


@pytest.fixture(scope="module")
def browser():
    why = _missing()
    if why is not None:
        if REQUIRED:
            pytest.fail(f"the browser tests must run under CI: {why}")
        pytest.skip(why)
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        yield b
        b.close()


def run_cli(*args, cwd):
    """``python -m fg_tea.cli ARGS`` in `cwd`; asserts it succeeded and returns the process."""
    proc = subprocess.run([sys.executable, "-m", "fg_tea.cli", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc


def open_explorer(browser, path: Path, width: int = 1400):
    """An explorer page opened and ready, and the console errors, warnings and page errors seen."""
    page = browser.new_page(viewport={"width": width, "height": 1000})
    problems: list[str] = []
    page.on("console", lambda m: problems.append(f"{m.type}: {m.text}") if m.type in ("error", "warning") else None)
    page.on("pageerror", lambda e: problems.append(f"pageerror: {e}"))
    page.goto(path.as_uri())
    page.wait_for_function("document.body.dataset.ready === '1'", timeout=10_000)
    return page, problems

