"""Fixtures shared by test files: the system's headless Chromium, driven by Playwright.

Locally the browser tests skip with a one-line reason when Chromium or Playwright is missing;
under CI (``FG_TEA_BROWSER_REQUIRED=1``, set by .ci/run) a missing browser is a failure.
"""

from __future__ import annotations

import os
import shutil

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
