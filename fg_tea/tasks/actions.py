"""Declarative task actions: what should happen, never how (docs/design.md §7.1).

A :class:`TaskAction` is pure data: a verb from the simulator-independent vocabulary (SEARCH,
INSPECT, PICK, NAVIGATE, PLACE, INSERT, FILL, POUR, USE, WAIT), the object it acts on, an optional
target site or destination object, and the belief conditions the executor evaluates:

- belief goals, skip the action when every goal already holds,
  satisfied(z, theta) <=> q(z = true) >= theta                                            [19]
- belief preconditions, which must hold before the action may complete (e.g. boiling needs
  q(kettle.contains_water = true) >= 0.85)                                                 [20]
- belief effects, P(z' | z, a) with success probability rho (or the direct form q'(z) = rho)
                                                                                  [27; 25, 26]

All state names here are concrete (``kettle.contains_water``): the loader
(:mod:`fg_tea.tasks.load`) fills the model's role templates ``{object}`` and ``{destination}``
before building an action. Nothing in this module calls a simulator or reads truth.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from fg_tea.model.spec import Condition, Effect, Sensor

#: Failure reasons (``ActionResult.reason``) that mean a site cannot be reached.
UNREACHABLE_REASONS = ("unreachable", "site_unreachable")

#: Failure reasons that say the action did not happen and nothing changed, with no cause the agent
#: could act on: retrying is the same draw again. Their retries follow the model's failure model
#: (:class:`fg_tea.model.spec.RetryModel`) instead of the action's ``max_retries``.
TRANSIENT_REASONS = ("injected_failure",)


@dataclass(frozen=True)
class RecoveryPolicy:
    """What to do when the environment reports that an action failed (docs/design.md §7.6).

    Attributes:
        max_retries: how many times the failed action may be tried again (0 = never); the
            action is attempted at most ``max_retries + 1`` times.
        reinspect: concrete state names (``kettle.contains_water``) to observe before each retry,
            so the retry (or its skip, eq. 19) rests on fresh evidence.
        exclude_site: on an unreachable-site failure, remove the site from the search candidates.
    """

    max_retries: int = 0
    reinspect: tuple[str, ...] = ()
    exclude_site: bool = False

    def to_json(self) -> dict:
        """JSON-serialisable form for logs."""
        return {"max_retries": self.max_retries, "reinspect": list(self.reinspect),
                "exclude_site": self.exclude_site}


@dataclass(frozen=True)
class TaskAction:
    """One declarative node of a household task graph.

    Attributes:
        id: unique name within the task (``fill_kettle``).
        verb: one of :data:`fg_tea.env.base.VERBS`.
        object: the acted-on object (a scenario object name).
        site: target site (NAVIGATE, PLACE), ``$preparation_site`` already substituted; None
            when the site follows from where the object is believed to be.
        destination: the receiving object (INSERT, POUR, WAIT for steeping), or None.
        transition: name of the model transition supplying effects, goals and preconditions.
        state: for INSPECT, the concrete state observed (``kettle.contains_water``).
        sensor: for INSPECT, the noisy binary sensor (sensitivity, specificity) of eqs. 23-24.
        effects: belief effects with concrete state names (eq. 27).
        goals: belief goals; the action is skipped when all hold (eq. 19). Empty = never skipped.
        preconditions: belief preconditions checked before completion (eq. 20).
        requires_affordance: for USE and WAIT, the affordance the object must have (``heatable``).
        recovery: what to do if the environment reports failure.
        description: the human-readable role (docs/design.md §7.2).
    """

    id: str
    verb: str
    object: str
    site: str | None = None
    destination: str | None = None
    transition: str | None = None
    state: str | None = None
    sensor: Sensor | None = None
    effects: tuple[Effect, ...] = ()
    goals: tuple[Condition, ...] = ()
    preconditions: tuple[Condition, ...] = ()
    requires_affordance: str | None = None
    recovery: RecoveryPolicy = field(default_factory=RecoveryPolicy)
    description: str = ""

    def states(self) -> tuple[str, ...]:
        """Every concrete state the action reads or writes, in first-mention order."""
        names: list[str] = []
        for e in self.effects:
            names += [e.state, *e.requires]
        names += [c.state for c in self.goals + self.preconditions]
        if self.state is not None:
            names.append(self.state)
        names += list(self.recovery.reinspect)
        return tuple(dict.fromkeys(names))

    def to_json(self) -> dict:
        """JSON-serialisable form for logs (parameters included, so a log explains the action)."""
        out: dict = {"id": self.id, "verb": self.verb, "object": self.object}
        for key in ("site", "destination", "transition", "state", "requires_affordance"):
            value = getattr(self, key)
            if value is not None:
                out[key] = value
        if self.sensor is not None:
            out["sensor"] = {"sensitivity": self.sensor.sensitivity,
                             "specificity": self.sensor.specificity}
        if self.effects:
            out["effects"] = [{"state": e.state, "value": e.value, "success": e.success,
                               "requires": list(e.requires)} for e in self.effects]
        if self.goals:
            out["goals"] = [{"state": c.state, "at_least": c.at_least} for c in self.goals]
        if self.preconditions:
            out["preconditions"] = [{"state": c.state, "at_least": c.at_least}
                                    for c in self.preconditions]
        out["recovery"] = self.recovery.to_json()
        return out
