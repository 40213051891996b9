"""The Gymnasium id ``"fg_tea/TeaMaking-v0"``, registered by ``import fg_tea`` (docs/design.md §9.1).

Gymnasium 1.x loads no plug-ins, so ``gymnasium.make("fg_tea/TeaMaking-v0")`` finds the id only if
something registered it. ``import fg_tea`` does, without importing Gymnasium (it stays light):
if Gymnasium is already imported the id is registered at once; otherwise, when Gymnasium is
installed, a finder on ``sys.meta_path`` registers it right after Gymnasium's own import. The
entry point is a string, so the environment's module (and the simulator) loads only on ``make``.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys
from types import ModuleType
from typing import Any

ENV_ID = "fg_tea/TeaMaking-v0"
ENTRY_POINT = "fg_tea.episode.gym_env:TeaEnv"


def register(gymnasium: ModuleType) -> None:
    """Register :data:`ENV_ID` with `gymnasium` unless it is already there."""
    if ENV_ID not in gymnasium.envs.registry:
        gymnasium.register(id=ENV_ID, entry_point=ENTRY_POINT)


class _AfterGymnasium(importlib.abc.MetaPathFinder):
    """Wraps Gymnasium's loader so that :func:`register` runs once its module has executed."""

    def find_spec(self, name: str, path: Any = None, target: Any = None):
        if name != "gymnasium":
            return None
        sys.meta_path.remove(self)  # once: find the real spec, then step aside
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        loader = spec.loader
        real_exec = loader.exec_module

        def exec_module(module: ModuleType) -> None:
            real_exec(module)
            register(module)

        loader.exec_module = exec_module  # type: ignore[method-assign]
        return spec


def install() -> None:
    """Register the id now if Gymnasium is imported, or right after it is (when installed)."""
    gymnasium = sys.modules.get("gymnasium")
    if gymnasium is not None and hasattr(gymnasium, "register"):
        register(gymnasium)
        return
    if any(isinstance(f, _AfterGymnasium) for f in sys.meta_path):
        return
    if importlib.util.find_spec("gymnasium") is not None:
        sys.meta_path.insert(0, _AfterGymnasium())
