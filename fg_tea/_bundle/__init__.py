"""Where does the bundled data live? In the subpackages of this package.

``fg_tea._bundle.scenarios`` (with ``tasks`` and ``worlds``), ``fg_tea._bundle.models`` (with
``ablations``) and ``fg_tea._bundle.cameras`` hold the bundled JSON and TOML files, read through
:mod:`importlib.resources` by :mod:`fg_tea.common.resources`. In an installed wheel they are
folders beside this file (the build maps the repository's top-level ``scenarios/``, ``models/``
and ``cameras/`` here, see ``pyproject.toml``). In a source checkout, or an editable install of
one, they are the top-level folders themselves: this package's search path then also names the
checkout's root, so the same import finds them.
"""

from __future__ import annotations

from pathlib import Path

_here = Path(__file__).resolve().parent
if not (_here / "scenarios").is_dir():  # a source checkout: the data sits at the repository root
    __path__.append(str(_here.parent.parent))  # noqa: F821 - a package's module-level __path__
