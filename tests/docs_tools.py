"""The documentation tools under docs/tools/, loaded by file for the tests that check the docs."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parent.parent


def load_tool(name: str) -> ModuleType:
    """docs/tools/NAME.py as a module (its folder is not a package)."""
    spec = importlib.util.spec_from_file_location(f"_docs_{name}", ROOT / "docs" / "tools" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module
