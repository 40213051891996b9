"""The exact method each query of a belief uses, as the episode log records it
(``episode_start.inference``, docs/log-format.md; docs/design.md §4.8).

The engine chooses the method once, when it is built (:attr:`BeliefEngine.location_method`):
``independent`` (closed forms: no factor couples two locations), ``dense`` (the K^N joint table),
``structured`` (the subset dynamic program of site- or room-local relations), ``elimination``
(variable elimination with a min-fill order), ``gtsam`` (gtsam's discrete elimination) or
``compiled`` (the compiled program of the location block, whose components each have their own
method: closed form, dense joint or elimination). Task-state queries are the state block's: a
dense contraction of its few binary variables (``dense``), or gtsam's elimination under
``--solver gtsam``. Every query on the location block (marginals, pairwise joints, the planners'
hypothetical posteriors) uses the location method.
"""

from __future__ import annotations

from typing import Any


def _components(engine: Any) -> list[dict[str, Any]]:
    """The compiled location block's components and their methods (``compiled`` only)."""
    from fg_tea.beliefs.compiled_location import compiled_block

    out = []
    for c in compiled_block(engine).components:
        item: dict[str, Any] = {"variables": list(c.variables), "method": c.method, "states": int(c.states)}
        if c.method == "elimination":
            item.update(order=list(c.order), width=int(c.width), largest=int(c.largest))
        out.append(item)
    return out


def inference_record(engine: Any, attribution: Any = None) -> dict[str, Any]:
    """What ``episode_start.inference`` says about `engine`.

    Args:
        engine: the episode's :class:`~fg_tea.beliefs.engine.BeliefEngine`.
        attribution: its :class:`~fg_tea.beliefs.attribution.FactorAttribution`, or None.

    Returns:
        ``solver`` (the backend asked for), ``locations`` (the location block's method),
        ``states`` (the state block's), ``components`` for the compiled method, and
        ``attribution`` (:meth:`FactorAttribution.record`) when one is given.
    """
    method = engine.location_method
    return {"solver": engine.backend, "locations": method,
            "states": "gtsam" if engine.backend == "gtsam" else "dense",
            **({"components": _components(engine)} if method == "compiled" else {}),
            **({"attribution": attribution.record()} if attribution is not None else {})}


__all__ = ["inference_record"]
