"""The compiled plan of a program as text (what ``fg-tea validate my_model.py`` prints).

One section each for the variables, the factors and the components; every query on a
component's variables (marginals, joints, hypothetical posteriors, K best) uses the component's
method (docs/design.md §4.8).
"""

from __future__ import annotations

import math
from typing import Any, Sequence


def _values(labels: Sequence[str], limit: int = 6) -> str:
    shown = ", ".join(labels[:limit])
    return shown + (f", ... ({len(labels)} values)" if len(labels) > limit else "")


def plan_lines(model: Any, variables: Sequence[Any], factors: Sequence[Any]) -> list[str]:
    """The plan's lines for a :class:`~fg_tea.beliefs.compiled.CompiledModel`."""
    shown = [v for v in variables if not v.hidden]
    hidden = len(variables) - len(shown)
    learnable = sum(1 for f in factors if f.learnable)
    lines = [f"program {model.source}: {len(shown)} variables"
             + (f" (+{hidden} earlier copies left by transitions)" if hidden else "")
             + f", {len(factors)} factors ({learnable} learnable)",
             f"budget: {model.budget:,} table entries; dense joint up to {model.dense_states:,} states"
             f" (method: {model.method})", "variables:"]
    width = max((len(v.name) for v in variables), default=0)
    for v in shown:
        lines.append(f"  {v.name:<{width}}  {len(v.values)} values: {_values(v.labels)}")
    lines.append("factors:")
    for f in factors:
        scope = ", ".join(variables[i].name for i in f.scope)
        entries = math.prod(variables[i].card for i in f.scope)
        mark = ", learnable" if f.learnable else ""
        lines.append(f"  {f.label} ({scope}): {entries:,} entries, {f.origin}{mark}")
    lines.append("queries (marginals, joints, hypothetical posteriors, K best) by component:")
    for n, c in enumerate(model.components, 1):
        names = ", ".join(c.variables) or "(hidden only)"
        if c.method == "closed form":
            how = "closed form (normalised product of its unary factors)"
        elif c.method == "dense joint":
            how = f"dense joint of {c.states:,} states"
        else:
            how = (f"variable elimination, min-fill order {', '.join(c.order)}; "
                   f"elimination width {c.width}, largest table: {c.largest:,} entries")
        lines.append(f"  {n}. {names}: {how}")
    largest = max((c.largest for c in model.components), default=0)
    width_all = max((c.width if c.method == "elimination" else len(c.ids) - 1 for c in model.components),
                    default=0)
    lines.append(f"elimination width {width_all}; largest table: {largest:,} entries")
    return lines
