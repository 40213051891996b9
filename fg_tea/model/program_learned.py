"""A model program with its learnable tables learned from episodes (docs/design.md §12.6).

``fg-tea learn --base my_model.py LOGS --out learned.py`` writes a small program file that names
the program it learned from (path and SHA-256), the counts of every learnable table and the prior
strength S. That file is itself a model program: :func:`learned_model` builds the source program
for the scenario and replaces each counted table by its Dirichlet posterior mean,

    table' = (S * table / sum(table) + N) / (S + sum(N)),

the declared table (normalised) being the prior mean with S pseudo-counts and N the counts of the
table's cells (eq. 50's rule, for any table). A table that is the only factor over its scope (a
prior) is then learned exactly as a TOML model's priors are; a table that shares its scope with
other factors is re-estimated from the observed joint of its scope, which other factors then
multiply again (said in the learned file, and in docs/design.md §12.6).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from fg_tea.common.errors import InputError

#: Default pseudo-count mass S of a declared table (as for a TOML model's location prior).
PRIOR_STRENGTH = 5.0


def apply_counts(program: Any, counts: Mapping[str, Any], prior_strength: float = PRIOR_STRENGTH,
                 source: str = "<learned>") -> Any:
    """`program` with each counted learnable table replaced by its posterior mean (module docstring).

    Raises:
        InputError: a counted factor is unknown, not learnable, or its counts have another shape
            or a negative or non-finite cell.
    """
    if not (np.isfinite(prior_strength) and prior_strength > 0):
        raise InputError(source, "PRIOR_STRENGTH", f"expected a positive number, got {prior_strength}")
    for name, cells in counts.items():
        factor = program.factor_named(name)
        if not factor.learnable:
            raise InputError(source, f"COUNTS[{name!r}]", "the program does not mark this factor learnable")
        table = np.asarray(factor.table, dtype=float)
        n = np.asarray(cells, dtype=float)
        if n.shape != table.shape:
            raise InputError(source, f"COUNTS[{name!r}]", f"counts of shape {n.shape}, the table has {table.shape}")
        if not np.all(np.isfinite(n)) or np.any(n < 0):
            raise InputError(source, f"COUNTS[{name!r}]", "counts must be finite and non-negative")
        mean = prior_strength * table / table.sum() + n
        program.replace(name, mean / mean.sum())
    return program


def learned_model(source: str, sha256: str, counts: Mapping[str, Any],
                  prior_strength: float = PRIOR_STRENGTH, here: str | None = None) -> tuple[str, Callable[[Any], Any]]:
    """``(base, model)`` for a learned program file: the source program's base model, and the
    function of the scenario that builds the source program and applies the counts. A relative
    ``.py`` source is found from the folder of `here` (the learned file).

    Raises:
        InputError: the source program's file no longer has the SHA-256 it was learned from.
    """
    from fg_tea.model.program_file import load_program_source

    if here is not None and source.endswith(".py") and not Path(source).is_absolute():
        source = str(Path(here).resolve().parent / source)
    program = load_program_source(source)
    if sha256 and program.sha256 != sha256:
        raise InputError(source, "sha256", f"the program changed since it was learned from (was {sha256[:12]}, "
                         f"now {program.sha256[:12]}); learn again from its logs")

    def model(scenario: Any) -> Any:
        return apply_counts(program.function(scenario), counts, prior_strength, program.spec)

    return program.base, model


def with_counts(model: Any, counts: Mapping[str, Any], prior_strength: float = PRIOR_STRENGTH) -> Any:
    """A program model whose learnable tables carry `counts` (the lifelong sweep's in-memory
    learning, docs/design.md §12.4 and §12.6); `model` itself is left as it is."""
    from dataclasses import replace

    source = model.program
    frozen = {name: np.array(n, dtype=float) for name, n in counts.items()}

    def function(scenario: Any) -> Any:
        return apply_counts(source.function(scenario), frozen, prior_strength, source.spec)

    return replace(model, program=replace(source, function=function))


__all__ = ["PRIOR_STRENGTH", "apply_counts", "learned_model", "with_counts"]
