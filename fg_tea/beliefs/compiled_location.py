"""The belief engine's location block answered by a compiled program (docs/design.md §4.8).

``BeliefEngine(scenario, model, backend="compiled")`` (``--solver compiled``) keeps every
location factor the engine keeps (priors, relations, the coupled-looks factor of occlusion, one
merged evidence factor per object) and answers the location marginals and pairwise joints from
:class:`~fg_tea.beliefs.compiled.CompiledModel` instead of the engine's own methods; the task
states, planning and everything else are the numpy path's. The compiled model of the factors
that are not evidence is built once and kept while they are the same objects; each object's
evidence is then added in log space (:meth:`CompiledModel.observe_logs`), which keeps the
compiled plan and the caches of the components it does not touch. Every number agrees with the
numpy path to rounding; the golden episodes run through it give the golden logs
(tests/test_compiled_location.py).

Where the block's relations are site- or room-local and its joint is above the engine's dense
preference, the engine answers it by the subset program instead (``BeliefEngine._method``),
which the planners' joint gains read too; where the block is one dense table, the planners'
dense joint is that table (:func:`compiled_joint`). No decision builds a second model
(docs/design.md §4.8).
"""

from __future__ import annotations

from typing import Any, cast

import numpy as np

from fg_tea.beliefs.compiled import CompiledModel, compile_factors
from fg_tea.beliefs.factors import Evidence, location_var

#: Joint states up to which a location component is answered from its dense table (a compiled
#: program's default is 2^16): three objects in a 44-site house (85,184 states, a 0.7 MB table)
#: whose relations are not site- or room-local are, so each pairwise joint is a sum over that
#: table, not an elimination of its own (measured in experiments/results/bench_paths.md).
DENSE_STATES = 1 << 18


def _base(engine: Any) -> CompiledModel:
    """The compiled model of the location factors other than evidence (kept on the engine)."""
    fixed = [f for f in engine._loc_factors if not isinstance(f, Evidence)] + list(engine.graph.relational)
    key = (*fixed, engine._company)  # the same objects (compared by identity), the same model
    held = getattr(engine, "_compiled_base", None)
    if held is not None and len(held[0]) == len(key) and all(a is b for a, b in zip(held[0], key)):
        return held[1]
    names = [location_var(o) for o in engine.objects]
    factors = [(f.label, f.variables, f.table) for f in fixed]
    if engine._company is not None:
        factors.append(("company", tuple(names), engine._company.dense()))
    model = compile_factors([(n, engine.sites) for n in names], factors, "location block",
                            dense_states=DENSE_STATES)
    engine._compiled_base = (key, model)
    return model


def compiled_block(engine: Any) -> CompiledModel:
    """The location block with every object's evidence, cached until the next evidence; built
    from the block before that evidence where the other factors are the same (only the change
    of each object's evidence is added), else from the compiled factors."""
    cached = engine._cache.get("compiled")
    if cached is None:
        evidence: dict[str, np.ndarray] = {f.variables[0]: cast(np.ndarray, f.log_table)
                                           for f in engine._loc_factors if isinstance(f, Evidence)}
        base = _base(engine)
        previous = engine._cache.get("compiled_previous")
        if previous is not None and previous[0] is base and set(previous[1]) <= set(evidence):
            change = {v: _change(previous[1].get(v), log) for v, log in evidence.items()
                      if previous[1].get(v) is not log}
            block = previous[2].observe_logs(change) if change else previous[2]
        else:
            block = base.observe_logs(evidence) if evidence else base
        cached = (base, evidence, block)
        engine._cache["compiled"] = cached
    return cached[2]


def _change(old: np.ndarray | None, new: np.ndarray) -> np.ndarray:
    """The log evidence to add to a block holding `old` for it to hold `new`: evidence only
    accumulates, so where `old` is -inf `new` is too, and nothing is added there."""
    if old is None:
        return new
    with np.errstate(invalid="ignore"):
        return np.where(np.isneginf(old), 0.0, new - old)


def compiled_marginals(engine: Any) -> np.ndarray:
    """(N, K) location marginals, objects in the engine's order. Where the objects share one
    component the pairwise joints are computed first (one pass each over its table, which the
    planner asks for next) and the marginals read from them."""
    block = compiled_block(engine)
    names = [location_var(o) for o in engine.objects]
    if len(names) > 1 and len({id(block.component(n)) for n in names}) == 1:
        pairs = compiled_pairwise(engine)
        return np.stack([pairs[o, o].diagonal() for o in range(len(names))])
    return np.stack([block.marginal(n) for n in names])


def compiled_joint(engine: Any) -> np.ndarray:
    """The joint P(L_1, ..., L_N), axes in the engine's object order: where the block is one
    dense component, its cached table (transposed, no new sum), which the planners' dense joint
    gains then read instead of a second table of the engine's."""
    names = [location_var(o) for o in engine.objects]
    return compiled_block(engine).joint(names)


def compiled_pairwise(engine: Any) -> np.ndarray:
    """(N, N, K, K) pairwise joints; diagonal blocks diag(q_o). Kept with the block."""
    held = engine._cache.get("compiled_pairwise")
    if held is not None and held[0] is compiled_block(engine):
        return held[1]
    block = compiled_block(engine)
    names = [location_var(o) for o in engine.objects]
    n, k = len(names), len(engine.sites)
    out = np.empty((n, n, k, k))
    for o in range(n):
        for p in range(o + 1, n):
            out[o, p] = block.joint([names[o], names[p]])
            out[p, o] = out[o, p].T
    for o in range(n):
        m = out[o, (o + 1) % n].sum(axis=1) if n > 1 else block.marginal(names[o])
        out[o, o] = np.diag(m)
    engine._cache["compiled_pairwise"] = (block, out)
    return out


__all__ = ["compiled_block", "compiled_joint", "compiled_marginals", "compiled_pairwise"]
