"""How was fg_tea installed, and so which command adds an optional extra?

A source checkout installed with ``pip install -e .`` takes ``pip install -e ".[peers]"`` from the
checkout; an installed wheel or sdist takes ``pip install "fg-tea[peers]"``. Every message that
asks for an extra (``peers``, ``ray``, ``gym``, ``docs``) gives the command that fits.
"""

from __future__ import annotations

import json
from importlib import metadata

DIST = "fg-tea"


def editable_install() -> bool:
    """True for an editable install (or a checkout run without installing), False for a wheel."""
    try:
        dist = metadata.distribution(DIST)
    except metadata.PackageNotFoundError:
        return True  # imported from a source tree that was never installed
    try:
        direct = json.loads(dist.read_text("direct_url.json") or "{}")
    except ValueError:
        return False
    return bool(isinstance(direct, dict) and direct.get("dir_info", {}).get("editable"))


def install_command(extra: str) -> str:
    """The pip command that adds the optional `extra` to this installation."""
    return f'pip install -e ".[{extra}]"' if editable_install() else f'pip install "{DIST}[{extra}]"'


__all__ = ["editable_install", "install_command"]
