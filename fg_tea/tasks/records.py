"""What the task executor reports: its errors, the failed checks behind them, the agent's
symbolic picture of each object, and the recovery decided after a failure (docs/design.md §7.5,
§7.6). Each record has ``to_json`` for the log."""

from __future__ import annotations

from dataclasses import dataclass

class TaskError(RuntimeError):
    """An action cannot be completed as asked (wrong status, wrong call, failed check).

    Attributes:
        violations: the failed checks behind the error (empty for a wrong call).
    """

    def __init__(self, message: str, violations: tuple["Violation", ...] = ()) -> None:
        super().__init__(message)
        self.violations = tuple(violations)


class AffordanceError(TaskError):
    """An object lacks an affordance or relation (held, free hands) an action needs (docs/design.md §7.5)."""


class PreconditionError(TaskError):
    """A belief precondition q(z = true) >= theta does not hold (eq. 20)."""


@dataclass(frozen=True)
class Violation:
    """One failed check of an action.

    Attributes:
        kind: ``"affordance"`` (a missing affordance), ``"relation"`` (held / free hands) or
            ``"belief"`` (a belief precondition, eq. 20).
        action: the action id.
        message: a readable sentence naming the action and the fault.
        object: the object lacking the affordance or relation.
        affordance: the missing affordance or relation (``"graspable"``, ``"held"``).
        state: for belief violations, the state name.
        belief: q(state = true) now.
        threshold: the precondition's theta.
    """

    kind: str
    action: str
    message: str
    object: str | None = None
    affordance: str | None = None
    state: str | None = None
    belief: float | None = None
    threshold: float | None = None

    def to_json(self) -> dict:
        return {k: v for k, v in self.__dict__.items() if v is not None}


@dataclass
class ObjectState:
    """The agent's symbolic picture of one object (docs/design.md §7.5).

    Attributes:
        name: the object.
        affordances: what the object affords (from the scenario spec, not truth).
        held: the agent holds it.
        current_site: the site it stands on (or near, while held and carried); None if unknown
            or in the hand before any carrying.
        contained_in: the container it was inserted into, or None.
        resolved_site: where a search found it.
    """

    name: str
    affordances: frozenset[str]
    held: bool = False
    current_site: str | None = None
    contained_in: str | None = None
    resolved_site: str | None = None

    def to_json(self) -> dict:
        return {"held": self.held, "current_site": self.current_site,
                "contained_in": self.contained_in, "resolved_site": self.resolved_site,
                "affordances": sorted(self.affordances)}


@dataclass(frozen=True)
class RecoveryDecision:
    """What the runner must do after a failed action (docs/design.md §7.6).

    Attributes:
        action: the failed action id.
        reason: the failure reason the environment reported.
        attempt: how many times the action has failed so far.
        retry: True when the action is pending again (to be returned by ``next_action``).
        inspections: states to observe (``observe_state``) before the retry.
        exclude_site: a site removed from the search candidates, or None.
        reopened_search: the object whose search was reopened (the failure showed it is not
            where the agent believed), or None.
        stuck_reason: set when no recovery is left; the episode should end with it.
        reopened: task-level recovery: the actions reopened because a goal they relied on no
            longer holds (see :meth:`TaskExecutor.fail`), in graph order.
        alternative_site: a PLACE that found its site full retargets to this free site.
    """

    action: str
    reason: str
    attempt: int
    retry: bool
    inspections: tuple[str, ...] = ()
    exclude_site: str | None = None
    reopened_search: str | None = None
    stuck_reason: str | None = None
    reopened: tuple[str, ...] = ()
    alternative_site: str | None = None

    def to_json(self) -> dict:
        return {"action": self.action, "reason": self.reason, "attempt": self.attempt,
                "retry": self.retry, "inspections": list(self.inspections),
                "exclude_site": self.exclude_site, "reopened_search": self.reopened_search,
                "stuck_reason": self.stuck_reason, "reopened": list(self.reopened),
                "alternative_site": self.alternative_site}


__all__ = ["TaskError", "AffordanceError", "PreconditionError", "Violation", "ObjectState", "RecoveryDecision"]
