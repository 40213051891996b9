"""The task states a belief holds: their queries, state readings and action effects
(docs/design.md §3.6, §4.2, eqs. 21-27).

:class:`StateBlock` is the state part of :class:`~fg_tea.beliefs.engine.BeliefEngine`, which is
built from it: it reads and writes the engine's state factors, time slices and caches, declared
below, through the engine's solver and trial rollback.
"""

from __future__ import annotations

from contextlib import AbstractContextManager
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from fg_tea.beliefs.factors import (
    Evidence,
    Factor,
    as_evidence,
    effect_factor,
    merge_evidence,
    state_observation,
)
from fg_tea.beliefs.updates import StateUpdate
from fg_tea.model.spec import Effect, Model, Sensor


class UnknownVariableError(KeyError):
    """A belief query named an object, state or variable the belief does not hold.

    A ``KeyError`` (as before), whose message names the valid names in full.
    """

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class StateBlock:
    """Task-state queries and evidence (module docstring); a part of the belief engine."""

    # The engine's state these use (BeliefEngine.__init__ sets it).
    model: Model
    _cards: dict[str, int]
    _keys: dict[str, int]
    _serial: int
    _slice: dict[str, str]
    _state_factors: list[Factor]
    _cache: dict[str, Any]
    _coupling: Any
    _start: dict[str, str]

    if TYPE_CHECKING:  # the engine's own solver and bookkeeping
        def _trial(self) -> AbstractContextManager[None]: ...

        def _solver(self, backend: str | None = None) -> Any: ...

        @property
        def state_names(self) -> tuple[str, ...]: ...

        def _coupled_state_factors(self) -> list[Factor]: ...

        def _after_state_change(self) -> None: ...

    # ------------------------------------------------------------------ state queries
    def _state_marginals(self) -> dict[str, float]:
        cached = self._cache.get("states")
        if cached is None:
            names = list(self._slice.values())
            factors = self._state_factors + self._coupled_state_factors()
            marg = self._solver().marginals(factors, names, self._cards)
            cached = {s: float(marg[v][1]) for s, v in self._slice.items()}
            self._cache["states"] = cached
        return cached

    def state(self, name: str) -> float:
        """q(z = true) for a task state such as ``kettle.contains_water``."""
        try:
            return self._state_marginals()[name]
        except (KeyError, TypeError):
            raise UnknownVariableError(f"no task state {name!r} in the belief (states: "
                                       f"{', '.join(self.state_names) or 'none'})") from None

    def states(self) -> dict[str, float]:
        """q(z = true) of every task state, name -> probability."""
        return dict(self._state_marginals())

    def has_state(self, name: str) -> bool:
        """True when the belief holds task state `name`."""
        return name in self._slice

    def state_joint(self, names: Sequence[str]) -> np.ndarray:
        """The joint of a few task states, shape (2,) * len(names), axis order as given."""
        for name in names:
            if name not in self._slice:
                raise UnknownVariableError(f"no task state {name!r} in the belief (states: "
                                           f"{', '.join(self.state_names) or 'none'})")
        factors = self._state_factors + self._coupled_state_factors()
        return self._solver().joint(factors, [self._slice[n] for n in names], self._cards)


    # ------------------------------------------------------------------ state evidence and actions
    def _commit_states(self, factors: list[Factor], kind: str, touched: Sequence[str],
                       detail: Mapping[str, object]) -> StateUpdate:
        before = {s: self.state(s) for s in touched}
        with self._trial():
            self._state_factors = factors
            self._cache.pop("states", None)
            self._after_state_change()
            after = {s: self.state(s) for s in touched}
        return StateUpdate(kind, before, after, detail)

    def observe_state(self, state: str, value: bool, sensor: Sensor) -> StateUpdate:
        """Absorb a noisy binary reading of `state` (eqs. 23, 24).

        Raises:
            ContradictionError: the reading has probability zero under the belief (unchanged).
        """
        var = self._slice[state] if state in self._slice else None
        if var is None:
            raise KeyError(f"no task state {state!r} in the belief")
        f = state_observation(var, bool(value), sensor.sensitivity, sensor.specificity)
        # Repeated readings of one slice merge into one evidence factor, summed in log space:
        # the graph stays bounded (dense contraction has an operand limit) and exact (the
        # product of thousands of readings underflows).
        factors = list(self._state_factors)
        pos = next((i for i, g in enumerate(factors)
                    if isinstance(g, Evidence) and g.variables == (var,)), None)
        if pos is None:
            factors.append(merge_evidence(None, f))
        else:
            factors[pos] = merge_evidence(as_evidence(factors[pos]), f)
        return self._commit_states(factors, "observe", [state],
                                   {"state": state, "value": bool(value),
                                    "sensitivity": sensor.sensitivity,
                                    "specificity": sensor.specificity})

    def apply_effects(self, effects: Sequence[Effect], direct: bool | None = None) -> StateUpdate:
        """Advance the task states through one action's effects, P(z'|z,a) (eq. 27).

        `effects` carry concrete state names (role templates already filled in). Each target gets
        a new time slice; all effects read the old slice; then the old slices of the targets are
        summed out, leaving one factor over the current slice.

        Args:
            effects: the action's effects.
            direct: use the direct form q'(z) = rho (docs/design.md eqs. (25), (26)); default: the model's.
        """
        import gtsam

        direct = (self.model.transition_form == "direct") if direct is None else direct
        targets = [e.state for e in effects]
        if len(set(targets)) != len(targets):
            raise ValueError(f"an action sets one state twice: {targets}")
        for e in effects:
            for s in (e.state, *e.requires):
                if s not in self._slice:
                    raise KeyError(f"effect refers to unknown task state {s!r}")
        new_names, factors = {}, []
        for e in effects:
            name = f"{e.state}@{self._serial}"
            self._keys[name] = gtsam.symbol("z", self._serial)
            self._cards[name] = 2
            self._serial += 1
            new_names[e.state] = name
            factors.append(effect_factor(name, self._slice[e.state],
                                         tuple(self._slice[r] for r in e.requires),
                                         e.value, e.success, direct))
        start = set(self._start.values()) if self._coupling is not None else set()
        old = [self._slice[t] for t in targets if self._slice[t] not in start]  # a coupled start stays
        merged = self._solver().sum_out(self._state_factors + factors, old, self._cards,
                                        "states after " + ", ".join(targets))
        before = {s: self.state(s) for s in targets}
        with self._trial():
            self._slice.update(new_names)
            self._state_factors = [merged]
            self._cache.pop("states", None)
            self._after_state_change()
            after = {s: self.state(s) for s in targets}
        return StateUpdate("transition", before, after,
                           {"form": "direct" if direct else "full",
                            "effects": [{"state": e.state, "value": e.value, "success": e.success,
                                         "requires": list(e.requires)} for e in effects]})


__all__ = ["StateBlock", "UnknownVariableError"]
