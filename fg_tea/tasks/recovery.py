"""Failure and recovery of task actions (docs/design.md §7.6): retries, re-inspections, excluded
sites, transient failures, task-level reopenings, alternative sites, and consumables found used up
(:mod:`fg_tea.tasks.consumables`).

:class:`TaskRecovery` holds these rules for :class:`~fg_tea.tasks.executor.TaskExecutor`, which
is built from it: they read and write the executor's graph, belief, symbolic object state and
event list, declared below, so each half of the executor says what it is for (choosing and
completing actions there, recovering from their failures here).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import replace
from typing import TYPE_CHECKING

from fg_tea.tasks.actions import TRANSIENT_REASONS, UNREACHABLE_REASONS, TaskAction
from fg_tea.tasks.consumables import USED_UP, run_out, stuck_note
from fg_tea.tasks.methods import switch as switch_method
from fg_tea.tasks.records import ObjectState, RecoveryDecision, Violation

if TYPE_CHECKING:
    from fg_tea.beliefs.engine import BeliefEngine
    from fg_tea.model.spec import Model
    from fg_tea.tasks.graph import TaskGraph
    from fg_tea.world.interface import ActionRequest
    from fg_tea.world.scenario import Scenario

#: Failure reasons that are evidence about where an object is not (a miss at the site).
NOT_AT_SITE_REASONS = {"object_not_at_site": "object", "destination_not_at_site": "destination"}


class TaskRecovery:
    """What to do after an action fails (module docstring); a part of the task executor."""

    # The executor's state these rules use (TaskExecutor.__init__ sets it).
    graph: TaskGraph
    belief: BeliefEngine
    scenario: Scenario
    model: Model
    events: list[dict]
    objects: dict[str, ObjectState]
    excluded_sites: list[str]
    attempts: Counter[str]
    transient_failures: Counter[str]
    max_reopenings: int
    reopenings: int
    _reopened: set[str]
    _full_sites: set[str]
    _verifications: Counter[tuple[str, str]]

    if TYPE_CHECKING:  # the executor's own checks and moves, which recovery calls
        def unmet_preconditions(self, action: TaskAction) -> list[Violation]: ...

        def request(self, action: TaskAction) -> ActionRequest: ...

        def _stuck(self, reason: str) -> None: ...

        def _require_runnable(self, action: TaskAction, verbs: tuple[str, ...] | None = None) -> None: ...

        def _move(self, obj: str, site: str | None) -> None: ...

    # ------------------------------------------------------------------ failure and recovery
    def fail(self, action: TaskAction, reason: str, site: str | None = None) -> RecoveryDecision:
        """Record that the environment could not carry out `action`; decide the recovery.

        The node is marked failed; a ``*_not_at_site`` reason is absorbed as a miss at the
        site (eqs. 5-6) and reopens the object's search; an unreachable site is excluded from the
        search candidates when the policy says so. Then, within the retry budget, the node is
        pending again and the decision lists the states to re-inspect first; beyond it, the
        executor is stuck with the reason ``"<id> failed <n> times: <reason>"``.

        Args:
            action: the failed action (pending or active).
            reason: the environment's machine-readable reason (``ActionResult.reason``).
            site: the site concerned, if the runner knows better than the request (e.g. the
                unreachable site of a search inspection).

        Returns:
            The :class:`RecoveryDecision` (also logged as a ``fail`` event).
        """
        self._require_runnable(action)
        self.graph.set_status(action.id, "failed")
        self.attempts[action.id] += 1
        attempt = self.attempts[action.id]
        policy = action.recovery
        request_site = None
        if action.verb not in ("SEARCH", "INSPECT"):
            request_site = self.request(action).site
        site = site or request_site

        reopened = None
        role = NOT_AT_SITE_REASONS.get(reason)
        if role is not None and site is not None:
            obj = action.object if role == "object" else action.destination
            if obj is not None and not self.objects[obj].held:
                self.belief.observe_site(site, {obj: False})
                state = self.objects[obj]
                state.resolved_site = None
                self._move(obj, None)
                for node in self.graph.search_nodes(obj):
                    self.graph.set_status(node, "pending")
                reopened = obj

        excluded = None
        if reason in UNREACHABLE_REASONS and policy.exclude_site and site is not None:
            excluded = site
            if site not in self.excluded_sites:
                self.excluded_sites.append(site)

        # Task-level recovery: a precondition that verification could not restore means a goal
        # an earlier action relied on does not hold; redo the chain that produces it.
        suffix = ""
        if reason == "precondition_unmet":
            plan = self.reopen_plan(action)
            if plan and self.reopenings < self.max_reopenings:
                nodes = self._reopen(action, plan)
                decision = RecoveryDecision(action.id, reason, attempt, True, (), excluded,
                                            reopened, reopened=nodes)
                self.events.append({"event": "fail", **decision.to_json(),
                                    "graph": self.graph.to_json()})
                return decision
            suffix = (f" (task-level recovery spent: {self.reopenings} of {self.max_reopenings} "
                      "reopenings used)" if plan else
                      " (no earlier action can restore the unmet precondition)")

        # A full site: place (and do everything else planned there) on another free site that
        # affords the object, instead of retrying a place that cannot succeed.
        alternative = None
        if reason == "site_full" and action.verb == "PLACE" and action.site is not None:
            self._full_sites.add(action.site)
            alternative = self.alternative_site(action)
            if alternative is None:
                suffix = f" (no other free site affords {action.object})"
            else:
                self._retarget(action, alternative)
                decision = RecoveryDecision(action.id, reason, attempt, True, (), excluded,
                                            reopened, alternative_site=alternative)
                self.graph.set_status(action.id, "pending")
                self.events.append({"event": "fail", **decision.to_json(),
                                    "graph": self.graph.to_json()})
                return decision

        if reason == USED_UP:  # its object has no use left: a retry cannot help (fg_tea.tasks.consumables)
            if run_out(self, action) is not None:  # a substitute takes its place; the action is pending
                decision = RecoveryDecision(action.id, reason, attempt, True, (), excluded, reopened)
                self.events.append({"event": "fail", **decision.to_json(), "graph": self.graph.to_json()})
                return decision
            suffix = stuck_note(action)

        if reason in TRANSIENT_REASONS:
            # The action did not happen and nothing changed: retry it on the same evidence (no
            # re-inspection), up to k tries in a row from the model's failure model.
            self.transient_failures[action.id] += 1
            run, tries = self.transient_failures[action.id], self.transient_tries()
            if run < tries:
                self.graph.set_status(action.id, "pending")
                decision = RecoveryDecision(action.id, reason, attempt, True, (), excluded, reopened)
            else:
                rate = self.model.retries.failure_rate
                stuck = (f"{action.id} failed {run} times: {reason} (a doable action fails "
                         f"{tries} tries with probability <= {rate:g}^{tries} = {rate ** tries:.2g})")
                decision = RecoveryDecision(action.id, reason, attempt, False, (), excluded,
                                            reopened, stuck)
        elif reason != USED_UP and attempt - self.transient_failures[action.id] <= policy.max_retries:
            self.graph.set_status(action.id, "pending")
            decision = RecoveryDecision(action.id, reason, attempt, True, policy.reinspect,
                                        excluded, reopened)
        else:
            stuck = f"{action.id} failed {attempt} times: {reason}{suffix}"
            decision = RecoveryDecision(action.id, reason, attempt, False, (), excluded, reopened,
                                        stuck)
        method = switch_method(self, action) if decision.stuck_reason is not None else None
        if method is not None:  # another way to do it (fg_tea.tasks.methods): pending again
            decision = replace(decision, retry=True, stuck_reason=None)
        if method is not None:  # before the decision, which the runner merges into action_failed
            self.events.append(method)
        self.events.append({"event": "fail", **decision.to_json(), "graph": self.graph.to_json()})
        if decision.stuck_reason is not None:
            self._stuck(decision.stuck_reason)
        return decision

    # ------------------------------------------------------------------ transient failures
    def practical_runs(self) -> int:
        """M: action runs an episode may make (each non-search action once per reopening round)."""
        practical = sum(1 for n in self.graph if self.graph.action(n).verb not in ("SEARCH", "INSPECT"))
        return practical * (1 + self.max_reopenings)

    def transient_tries(self) -> int:
        """k, the tries of one action before a run of transient failures ends the episode.

        From the model's failure model (:class:`fg_tea.model.spec.RetryModel`): the smallest k with
        M x failure_rate^k <= tolerance for M = :meth:`practical_runs`.
        """
        return self.model.retries.tries(self.practical_runs())

    # ------------------------------------------------------------------ task-level recovery
    def _threshold(self, state: str) -> float | None:
        """The largest goal threshold any action of the task declares for `state`, or None."""
        values = [c.at_least for n in self.graph for c in self.graph.action(n).goals
                  if c.state == state]
        return max(values) if values else None

    def _producer(self, state: str, consumer: str) -> str | None:
        """The latest finished action `consumer` depends on whose effect can make `state` true."""
        for node in reversed(self.graph.ancestors(consumer)):
            action = self.graph.action(node)
            if action.verb in ("SEARCH", "INSPECT") or not self.graph.is_finished(node):
                continue
            if any(e.state == state and e.value for e in action.effects):
                return node
        return None

    def reopen_plan(self, trigger: TaskAction) -> dict[str, dict]:
        """Which finished actions to redo because a state `trigger` needs no longer holds.

        Starting from the unmet belief preconditions of `trigger` (eq. 20), each state z with
        q(z = true) below its threshold theta is traced to its producer: the latest finished
        action the consumer depends on whose effect sets z true (eq. 27). The producer is
        reopened, and the states its effect on z ``requires`` and its own preconditions are
        traced in turn when their belief is below theta' — the producer's precondition
        threshold, else the goal threshold the task declares for that state, else theta (z can
        only become true through the producer when the required state holds, so q(z) >= theta
        after it needs about q(required) >= theta). The beliefs are over the current time slice,
        so a state an action has since used up (the kettle's water after pouring) is traced too:
        producing z again needs it again.

        Returns:
            action id -> why: ``{"state", "belief", "threshold", "needed_by"}``, in the order
            found; empty when nothing upstream can restore the unmet preconditions.
        """
        queue = [(v.state, float(v.threshold), trigger.id)
                 for v in self.unmet_preconditions(trigger)
                 if v.state is not None and v.threshold is not None]  # belief violations: always
        plan: dict[str, dict] = {}
        seen: set[str] = set()
        while queue:
            state, theta, consumer = queue.pop(0)
            if state in seen:
                continue
            seen.add(state)
            producer = self._producer(state, consumer)
            if producer is None:
                continue
            plan.setdefault(producer, {"state": state, "belief": self.belief.state(state),
                                       "threshold": theta, "needed_by": consumer})
            action = self.graph.action(producer)
            own = {c.state: c.at_least for c in action.preconditions}
            needed = [r for e in action.effects if e.state == state for r in e.requires]
            for r in dict.fromkeys(needed + list(own)):
                if r == state:
                    continue
                declared = self._threshold(r)
                theta_r = own.get(r, declared if declared is not None else theta)
                if self.belief.state(r) < theta_r:
                    queue.append((r, theta_r, producer))
        return plan

    def _reopen(self, trigger: TaskAction, plan: dict[str, dict]) -> tuple[str, ...]:
        """Reopen the planned producers and every finished or failed action after them."""
        self.reopenings += 1
        downstream: dict[str, list[str]] = {}
        for producer in plan:
            for node in self.graph.descendants(producer):
                if node not in plan:
                    downstream.setdefault(node, []).append(producer)
        nodes = [n for n in self.graph if n in plan or n in downstream or n == trigger.id]
        reopened = []
        for node in nodes:
            action = self.graph.action(node)
            if action.verb == "SEARCH":
                continue
            status = self.graph.status(node)
            if status == "pending":
                continue
            self.graph.set_status(node, "pending")
            self.attempts.pop(node, None)
            self.transient_failures.pop(node, None)
            for key in [k for k in self._verifications if k[0] == node]:
                del self._verifications[key]
            self._reopened.add(node)
            reopened.append(node)
            event = {"event": "reopen", "action": node, "previous_status": status,
                     "round": self.reopenings, "max_reopenings": self.max_reopenings,
                     "trigger": {"action": trigger.id,
                                 "unmet": [v.to_json() for v in self.unmet_preconditions(trigger)]}}
            if node in plan:
                event.update(plan[node], reason="goal_no_longer_holds")
            else:
                event.update(reason="depends_on_reopened", upstream=downstream.get(node, []))
            self.events.append(event)
        return tuple(reopened)

    # ------------------------------------------------------------------ alternative sites
    def _expected_occupants(self, site: str) -> float:
        """Objects believed to stand on `site` now (placed ones exactly, the others by belief)."""
        j = self.scenario.site_index(site)
        total = 0.0
        for name, state in self.objects.items():
            if state.held or state.contained_in is not None:
                continue
            if state.current_site is not None or state.resolved_site is not None:
                total += float(state.current_site == site)
            else:
                total += float(self.belief.location(name)[j])
        return total

    def alternative_site(self, action: TaskAction) -> str | None:
        """A free site other than the full one(s) whose affordance prior admits the object.

        Candidates: sites not known full, not excluded as unreachable, whose affordance weight
        a_ic for the object's category is positive (the house says such objects belong there,
        eq. 2) and whose believed occupants leave room (capacity minus expected occupants at
        least 1; no capacity = room). Preference: the same room as the full site, then the
        larger affordance weight, then scenario order.
        """
        category = self.scenario.object(action.object).category
        assert action.site is not None  # only actions at a site meet a full one
        room = self.scenario.site(action.site).room
        best, best_key = None, None
        for k, site in enumerate(self.scenario.sites):
            if site.name in self._full_sites or site.name in self.excluded_sites:
                continue
            weight = float(site.affordances.get(category, 0.0))
            if weight <= 0.0:
                continue
            if site.capacity is not None and site.capacity - self._expected_occupants(site.name) < 1:
                continue
            key = (site.room != room, -weight, k)
            if best_key is None or key < best_key:
                best, best_key = site.name, key
        return best

    def _retarget(self, action: TaskAction, site: str) -> None:
        """Point `action` and every unfinished action aimed at its site to `site`; log it."""
        old = action.site
        moved = []
        for node in self.graph:
            other = self.graph.action(node)
            if other.site == old and not self.graph.is_finished(node):
                self.graph.replace_action(node, replace(other, site=site))
                moved.append(node)
        self.events.append({"event": "alternative_site", "action": action.id, "full_site": old,
                            "site": site, "retargeted": moved,
                            "full_sites": sorted(self._full_sites)})


__all__ = ["TaskRecovery", "NOT_AT_SITE_REASONS"]
