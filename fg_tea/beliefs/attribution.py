"""Which factors moved an object's location belief: exact leave-one-factor-out attribution
(docs/design.md §4.8, shown by the episode explorer, §9.2).

At a belief step the location block is a product of factors: each object's prior (the baseline,
never attributed), the factors a model adds to it (relations, a program's own factors, a
coupling's message from the task states), the looks' evidence and, under occlusion, the coupled
looks' factor (evidence too). For every added factor F, the block without F is solved exactly and
each object's marginal compared with the belief's by total variation,

    TV_o(F) = 1/2 Σ_k |q_o(k) - q_o^{-F}(k)|.

An object's entry lists the factors with TV above :data:`MOVED_BY_TV`, largest first. A coupling
between task states and locations is attributed as one factor (its message g, design §4.8: without
it the location block is the block with no coupling at all). Both solves go through the compiled
exact engine (:func:`~fg_tea.beliefs.compiled.compile_factors`, the engine's ``compiled``
backend), so an attribution is exact; a step whose solves would together build more than
:data:`ATTRIBUTION_BUDGET` table entries is skipped with a note, never approximated.

A model with no factor beyond priors and evidence (the bundled factorised models) has nothing to
attribute: no solve is made and nothing is written.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from fg_tea.beliefs.compiled import CompiledModel, compile_factors
from fg_tea.beliefs.coupling import MESSAGE_LABEL
from fg_tea.beliefs.factors import Evidence, location_var
from fg_tea.beliefs.graph import DENSE_LIMIT, _summed_out  # _summed_out: the graph's own sum of own variables
from fg_tea.common.errors import ContradictionError, InputError

#: Total variation above which a factor is said to have moved an object's belief.
MOVED_BY_TV = 0.01
#: Table entries all the solves of one belief step may build together (one solve per attributed
#: factor, plus the belief's own); above it the step is skipped with a note.
ATTRIBUTION_BUDGET = 20_000_000
#: Largest disagreement between the attribution's solve of the whole block and the belief's own
#: marginals; above it (a factor the attribution does not know) the step is skipped with a note.
AGREEMENT = 1e-6

#: (label, scope of location variables, table, attributed?)
_Part = tuple[str, tuple[str, ...], np.ndarray, bool]


def _baseline(obj: str) -> tuple[str, str]:
    """The labels of an object's own prior: a program's ``prior <obj>``, the graph's ``prior L[obj]``."""
    return f"prior {obj}", f"prior {location_var(obj)}"


def _normalised(table: np.ndarray) -> np.ndarray:
    return np.asarray(table, dtype=float) / float(np.sum(table))


def _unary_parts(graph: Any, program: Any) -> tuple[dict[str, list[tuple[str, np.ndarray]]], list[str]]:
    """Each object's unary factors as the program states them, a group of factors over the program's
    own variables summed out onto the object counting as one (the graph multiplies them all into
    one prior); the graph's prior as one part where they do not multiply to it (never expected;
    listed in the second value, and noted)."""
    parts: dict[str, list[tuple[str, np.ndarray]]] = {}
    merged: list[str] = []
    summed: list[tuple[str, tuple[str, ...], np.ndarray]] = []
    if program is not None:
        # The groups over the program's own variables, summed out as the graph sums them
        # (graph_from_program): a group left over one location is a unary part of it.
        tracked = {f.variables[0] for f in graph.state_priors}
        kinds = {v.name: v.kind for v in program.variables}
        hidden = [f for f in program.factors if any(kinds[s] != "location" and s not in tracked for s in f.scope)]
        summed = _summed_out(program, hidden, kinds, tracked) if hidden else []
    for i, obj in enumerate(graph.objects):
        prior = graph.location_priors[i]
        own = [] if program is None else [(f.name, np.asarray(f.table, dtype=float)) for f in program.factors
                                          if tuple(f.scope) == (obj,)]
        own += [(label, np.asarray(table, dtype=float)) for label, scope, table in summed if scope == (obj,)]
        if own:
            product = np.prod([table for _, table in own], axis=0)
            if product.sum() > 0 and np.allclose(_normalised(product), _normalised(prior.table),
                                                 rtol=1e-9, atol=1e-12):
                parts[obj] = own
                continue
            merged.append(obj)
        parts[obj] = [(prior.label, prior.table)]
    return parts, merged


def _unique(labels: Sequence[str]) -> list[str]:
    """The labels, a repeated one numbered (``capacity (2)``) so each names one factor."""
    seen: dict[str, int] = {}
    out = []
    for label in labels:
        seen[label] = seen.get(label, 0) + 1
        out.append(label if seen[label] == 1 else f"{label} ({seen[label]})")
    return out


def _cost(model: CompiledModel) -> int:
    """Table entries one solve of `model`'s marginals builds (its plan's tables)."""
    total = 0
    for c in model.components:
        if c.method == "elimination":
            total += c.largest * max(1, len(c.ids))
        else:
            total += c.states if c.method == "dense joint" else 0
    return max(total, 1)


class FactorAttribution:
    """The leave-one-factor-out attribution of one belief engine's location block.

    Args:
        engine: the :class:`~fg_tea.beliefs.engine.BeliefEngine` (read, never changed).
        program: the model program the engine's graph was built from (its unary factors are
            attributed one by one), or None for a TOML model.
    """

    def __init__(self, engine: Any, program: Any = None) -> None:
        self._parts, self._merged = _unary_parts(engine.graph, program)
        self.notes: list[str] = []
        if self._merged:
            self.notes.append("the unary factors of " + ", ".join(self._merged) + " do not multiply to the "
                              "engine's prior: held as one prior, not attributed one by one")
        held = True
        try:
            relational = list(engine.graph.relational)
        except ValueError:  # a capacity factor only the subset program holds
            relational, held = [], False
            graph = engine.graph
            self.notes.append(f"nothing attributed: the capacity factor over {len(graph.objects)} objects x "
                              f"{len(graph.sites)} sites is held only by the subset program ({graph.joint_size:,} "
                              f"joint states, above the dense limit {DENSE_LIMIT:,} of an exact solve by tables)")
        coupling = engine._coupling
        baseline = {label for o in engine.objects for label in _baseline(o)}
        added = [label for parts in self._parts.values() for label, _ in parts if label not in baseline]
        added += [self._label(f.label) for f in relational]
        if coupling is not None and not coupling.several:
            added.append(", ".join(coupling.labels))
        self.factors = tuple(_unique(added)) if held else ()

    @staticmethod
    def _label(label: str) -> str:
        """A coupling's message is named by the coupling's own factors."""
        return label[len(MESSAGE_LABEL) + 1:] if label.startswith(MESSAGE_LABEL + " ") else label

    def record(self) -> dict[str, Any]:
        """What ``episode_start.inference.attribution`` says: the factors attributed, the threshold,
        the budget and any note."""
        return {"factors": list(self.factors), "threshold_tv": MOVED_BY_TV, "budget": ATTRIBUTION_BUDGET,
                **({"notes": list(self.notes)} if self.notes else {})}

    # ------------------------------------------------------------------ one belief step
    def _block(self, engine: Any) -> tuple[list[_Part], dict[str, np.ndarray]]:
        """The location block now: its factors other than evidence, and each object's evidence (log)."""
        baseline = {label for o in engine.objects for label in _baseline(o)}
        parts: list[_Part] = []
        for obj in engine.objects:
            for label, table in self._parts[obj]:
                parts.append((label, (location_var(obj),), table, label not in baseline))
        coupling = engine._coupling
        if coupling is not None and not coupling.several:
            g = coupling.g(engine._states_joint())
            parts.append((", ".join(coupling.labels), (location_var(coupling.object),), g, True))
        for f in engine.graph.relational:
            parts.append((self._label(f.label), tuple(f.variables), f.table, True))
        if engine._company is not None:
            names = tuple(location_var(o) for o in engine.objects)
            parts.append(("company", names, engine._company.dense(), False))
        labels = _unique([p[0] for p in parts])
        parts = [(label, p[1], p[2], p[3]) for label, p in zip(labels, parts)]
        evidence = {f.variables[0]: np.asarray(f.log_table, dtype=float)
                    for f in engine._loc_factors if isinstance(f, Evidence)}
        return parts, evidence

    @staticmethod
    def _compile(engine: Any, parts: Sequence[_Part]) -> CompiledModel:
        names = [location_var(o) for o in engine.objects]
        return compile_factors([(n, engine.sites) for n in names], [(p[0], p[1], p[2]) for p in parts],
                               "factor attribution")

    @staticmethod
    def _marginals(engine: Any, model: CompiledModel, evidence: dict[str, np.ndarray]) -> np.ndarray:
        block = model.observe_logs(evidence) if evidence else model
        return np.stack([block.marginal(location_var(o)) for o in engine.objects])

    def moved_by(self, engine: Any) -> tuple[dict[str, dict[str, float]], str | None]:
        """Each object's factors with TV above :data:`MOVED_BY_TV` (label -> TV, largest first;
        objects with none left out), and a note when the step was skipped (else None)."""
        if not self.factors:
            return {}, None
        parts, evidence = self._block(engine)
        attributed = [i for i, p in enumerate(parts) if p[3]]
        if not attributed:
            return {}, None
        try:
            whole = self._compile(engine, parts)
            cost = _cost(whole) * (len(attributed) + 1)
            if cost > ATTRIBUTION_BUDGET:
                return {}, (f"skipped: {len(attributed) + 1} exact solves of this block would build "
                            f"{cost:,} table entries (budget {ATTRIBUTION_BUDGET:,})")
            q = self._marginals(engine, whole, evidence)
            held = np.stack([engine.location(o) for o in engine.objects])
            gap = float(np.max(np.abs(q - held)))
            if not gap <= AGREEMENT:
                return {}, f"skipped: the attribution's block disagrees with the belief by {gap:.2e}"
            out: dict[str, dict[str, float]] = {}
            for i in attributed:
                without = self._marginals(engine, self._compile(engine, parts[:i] + parts[i + 1:]), evidence)
                tv = 0.5 * np.abs(q - without).sum(axis=1)
                for o, obj in enumerate(engine.objects):
                    if tv[o] > MOVED_BY_TV:
                        out.setdefault(obj, {})[parts[i][0]] = round(float(tv[o]), 9)
        except (InputError, ContradictionError) as exc:
            return {}, f"skipped: {str(exc).splitlines()[0]}"
        return {o: dict(sorted(v.items(), key=lambda kv: (-kv[1], kv[0]))) for o, v in out.items()}, None

    def fields(self, engine: Any) -> dict[str, Any]:
        """The fields a belief record gains: ``moved_by`` where some factor moved some object's
        belief, ``moved_by_note`` where the step was skipped; nothing otherwise."""
        moved, note = self.moved_by(engine)
        return {**({"moved_by": moved} if moved else {}), **({"moved_by_note": note} if note else {})}


def total_variation(p: np.ndarray, q: np.ndarray) -> float:
    """1/2 Σ |p - q| of two distributions over the same values."""
    return 0.5 * float(np.abs(np.asarray(p, dtype=float) - np.asarray(q, dtype=float)).sum())


__all__ = ["ATTRIBUTION_BUDGET", "MOVED_BY_TV", "FactorAttribution", "total_variation"]
