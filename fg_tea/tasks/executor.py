"""The task executor: which action next, what can be skipped, and what an action changes.

The executor walks a :class:`~fg_tea.tasks.graph.TaskGraph` against the agent's beliefs. It never
reads truth and never calls a simulator: the episode runner carries actions out in the
environment and reports back observations and outcomes. It owns

- **skipping** [19]: before returning the next action, every ready action whose belief goals all
  hold, q(z = true) >= theta, is completed with a structured ``skip`` event;
- **checks** before completion: affordances (docs/design.md §7.5: PICK graspable, INSERT a
  container destination, FILL fillable, POUR a held pourable source and a container
  destination, USE/WAIT the declared affordance), symbolic relations (PICK with free hands,
  PLACE/INSERT/POUR a held object) and belief preconditions [20]. A failed check raises
  :class:`AffordanceError` or :class:`PreconditionError` naming the action, the state, its belief
  and the threshold, and leaves beliefs, graph and object state exactly as they were;
- **belief effects** through the belief engine's transition factors, the full
  q'(z') = sum_z P(z'|z, a) q(z) [27] by default, the direct q'(z) = rho, 1 - rho [25, 26] when the
  model's ``transition_form`` is ``"direct"``; **observations** of INSPECT actions through the
  noisy binary sensor [23, 24];
- **symbolic object state** (docs/design.md §7.5): held, current site, contained in (an inserted
  teabag shares the mug's site, and contents travel with their container);
- **recovery** (docs/design.md §7.6): a failed action is marked failed, beliefs learn from the failure
  where it carries evidence (``object_not_at_site`` is a miss at that site, eqs. 5-6, and reopens
  the object's search), and the action's declared policy decides: retry (bounded), re-inspect
  states first, or exclude an unreachable site from the search candidates. A transient failure
  (``TRANSIENT_REASONS``: nothing happened, no cause) is retried on the same evidence up to the
  model's failure-model budget k instead (:meth:`TaskExecutor.transient_tries`, docs/design.md
  eq. 49). With no retries left
  the executor is stuck with a logged reason, so an episode ends instead of looping.

How the episode runner drives it::

    while True:
        action = executor.next_action()          # skips satisfied goals, marks the action active
        if action is None:                        # executor.done, or executor.stuck_reason
            break
        if action.verb == "SEARCH":               # plan over executor.pending_search_objects()
            ...                                   # with executor.search_relevance() and without
            executor.confirm_search(obj, site)    # executor.excluded_sites; confirm each object
            continue                              # an inspection resolves
        if action.verb == "INSPECT":
            reading = env.observe_state(action.object, action.state,
                                        executor.inspection_site(action.object), ...)
            executor.observe(action, reading.value)
            continue
        while states := executor.verification_inspections(action):   # bounded, see below
            for state in states:                   # at executor.inspection_site(object of state)
                executor.observe_state(state, env.observe_state(...).value)
        result = env.execute(executor.request(action))
        if result.ok:
            executor.complete(action, result)      # may raise AffordanceError/PreconditionError
        else:
            decision = executor.fail(action, result.reason)
            for state in decision.inspections:    # re-inspect before the retry
                executor.observe_state(state, env.observe_state(...).value, purpose="recovery")
            # decision.exclude_site: drop it from search candidates (executor.excluded_sites);
            # decision.stuck_reason: next_action() returns None; end the episode with it.

Verification inspections: with full transitions, a chain of practical actions can leave a belief
just short of a later precondition although every action succeeded (in the filled-kettle world,
pouring and steeping leave q(mug.tea_brewed) near 0.86 < 0.90 at serving). Rather than failing,
the runner asks :meth:`TaskExecutor.verification_inspections` for the unmet precondition states
that can be observed (the object is located or held), reads them, and tries again; each (action,
state) pair is offered at most ``max_verifications`` times, after which the list is empty and
:meth:`TaskExecutor.complete` raises the :class:`PreconditionError` (the runner may then call
:meth:`TaskExecutor.fail` with reason ``"precondition_unmet"``).
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.model.give_up import look_budget, remaining_below
from fg_tea.model.spec import Condition, Model, Sensor
from fg_tea.tasks.actions import TaskAction
from fg_tea.tasks.graph import TaskGraph
from fg_tea.tasks.records import AffordanceError, ObjectState, PreconditionError, TaskError, Violation
from fg_tea.tasks.recovery import TaskRecovery
from fg_tea.tasks.substitutes import switch as switch_to_substitute
from fg_tea.world.interface import ActionRequest, ActionResult
from fg_tea.world.scenario import Scenario

#: Prefix of the end reason when a search is given up (the object is almost surely not findable).
NOT_FOUND = "not_found: "

#: Default bound on task-level reopenings per episode. A reopening redoes a chain of actions
#: after a verification reading showed that a goal it relied on does not hold. With sensors of
#: specificity 0.95, a reading misleads with probability about 0.05, so a second round is needed
#: in about 5 % of recoveries and a third in about 0.25 %; two rounds cover all but a small
#: fraction while keeping every episode's length bounded.
MAX_REOPENINGS = 2


class TaskExecutor(TaskRecovery):
    """Executes a task graph against the agent's beliefs (docs/design.md §7, §3.6).

    Args:
        graph: the task (fresh: every action pending).
        belief: the belief engine; the executor writes it only through its public update methods.
        scenario: the house (object affordances and names; never its hidden truth).
        model: the generative model (transition form, sensors, search give-up rule).
        max_verifications: how often one (action, state) pair may be offered for verification.
        max_reopenings: how many task-level reopenings an episode may make (see :meth:`fail`).
    """

    def __init__(self, graph: TaskGraph, belief: BeliefEngine, scenario: Scenario, model: Model,
                 max_verifications: int = 3, max_reopenings: int = MAX_REOPENINGS) -> None:
        if max_reopenings < 0:
            raise ValueError(f"max_reopenings must be non-negative, got {max_reopenings}")
        self.graph = graph
        self.belief = belief
        self.scenario = scenario
        self.model = model
        self.max_verifications = max_verifications
        self.max_reopenings = max_reopenings
        self.reopenings = 0
        self._reopened: set[str] = set()
        self._full_sites: set[str] = set()
        for state, prior in graph.declared_states.items():
            belief.ensure_state(state, prior)
        self.objects: dict[str, ObjectState] = {
            spec.name: ObjectState(spec.name, frozenset(spec.affordances)) for spec in scenario.objects}
        self.events: list[dict] = []
        self.excluded_sites: list[str] = []
        self.attempts: Counter[str] = Counter()
        #: transient failures (``TRANSIENT_REASONS``) per action since it last succeeded or reopened
        self.transient_failures: Counter[str] = Counter()
        self._verifications: Counter[tuple[str, str]] = Counter()
        self._stuck_reason: str | None = None

    # ------------------------------------------------------------------ status
    @property
    def done(self) -> bool:
        """True when every action is complete or skipped."""
        return self.graph.done

    @property
    def stuck_reason(self) -> str | None:
        """Why no action can run although the task is unfinished, or None."""
        return self._stuck_reason

    def holding(self) -> str | None:
        """The object the agent holds, or None."""
        return next((o for o, s in self.objects.items() if s.held), None)

    def object_state(self) -> dict:
        """Symbolic object state as JSON: object -> fields of :class:`ObjectState`."""
        return {name: s.to_json() for name, s in self.objects.items()}

    def graph_state(self) -> dict:
        """Task graph state as JSON: statuses, counts, attempts, exclusions, stuck reason."""
        return {"task": self.graph.name, "nodes": self.graph.to_json(),
                "counts": self.graph.status_counts(), "attempts": dict(self.attempts),
                "excluded_sites": list(self.excluded_sites), "done": self.done,
                "stuck_reason": self._stuck_reason}

    # ------------------------------------------------------------------ choosing actions
    def goals_hold(self, action: TaskAction) -> bool:
        """True when the action has goals and every one holds (eq. 19)."""
        return bool(action.goals) and all(self.belief.state(c.state) >= c.at_least
                                          for c in action.goals)

    def _condition_json(self, c: Condition) -> dict:
        return {"state": c.state, "belief": self.belief.state(c.state), "threshold": c.at_least}

    def next_action(self) -> TaskAction | None:
        """The next action to carry out, after skipping every ready action whose goals hold [19].

        The returned action is marked active; an action that is already active (a search still
        under way) is returned again. Ties break by insertion order. Whether a SEARCH is given up
        first is the agent's decision (fg_tea/agent/give_up.py), between :meth:`ready_action` and
        :meth:`activate`.

        Returns:
            The action, or None when the task is done or stuck (see :attr:`done`,
            :attr:`stuck_reason`).
        """
        action = self.ready_action()
        return None if action is None else self.activate(action.id)

    def activate(self, node: str) -> TaskAction:
        """Mark the ready action `node` active (an ``activate`` event, unless it already is)."""
        if self.graph.status(node) == "pending":
            self.graph.set_status(node, "active")
            self.events.append({"event": "activate", "action": node})
        return self.graph.action(node)

    def ready_action(self) -> TaskAction | None:
        """The next ready action, after skipping every ready action whose goals hold [19], not yet
        marked active; None when the task is done or stuck."""
        if self._stuck_reason is not None:
            return None
        while True:
            frontier = self.graph.frontier()
            satisfied = [n for n in frontier if self.goals_hold(self.graph.action(n))]
            for node in satisfied:
                action = self.graph.action(node)
                self.graph.set_status(node, "skipped")
                self._reopened.discard(node)
                self.events.append({"event": "skip", "action": node,
                                    "goals": [self._condition_json(c) for c in action.goals],
                                    "graph": self.graph.to_json()})
            if satisfied:
                continue
            # A reopened relational action whose relation already holds (the kettle is still in
            # the hand, the teabag still in the mug) is finished as it stands: repeating it
            # would be physically wrong (picking a held object), not merely redundant.
            holding = [(n, r) for n in frontier if n in self._reopened
                       and (r := self._relation_holds(self.graph.action(n))) is not None]
            for node, relation in holding:
                self.graph.set_status(node, "skipped")
                self._reopened.discard(node)
                self.events.append({"event": "skip", "action": node, "goals": [],
                                    "relation": relation, "graph": self.graph.to_json()})
            if holding:
                continue
            if not frontier:
                if not self.graph.done:
                    blocked = [n for n in self.graph if not self.graph.is_finished(n)]
                    failed = [n for n in blocked if self.graph.status(n) == "failed"]
                    self._stuck(f"no action can run: {', '.join(blocked)} wait on failed "
                                f"action(s) {', '.join(failed) or 'none'}")
                return None
            return self.graph.action(frontier[0])

    def _relation_holds(self, action: TaskAction) -> str | None:
        """For a relational action, a sentence saying its outcome already holds, else None."""
        state = self.objects[action.object]
        if action.verb == "PICK" and state.held:
            return f"{action.object} is already held"
        if action.verb == "PLACE" and not state.held and state.current_site == action.site:
            return f"{action.object} already stands on {action.site}"
        if action.verb == "INSERT" and state.contained_in == action.destination:
            return f"{action.object} is already in {action.destination}"
        return None

    # ------------------------------------------------------------------ search give-up
    def search_budget(self) -> int | None:
        """Looks that may miss one object before its search is given up (None = no budget):
        ``max_inspections_per_object``, or if 0, K x (ceil(log p / log mu) + 1) (docs/design.md §7.8)."""
        return look_budget(self.model.planning, self.model.miss_likelihood, len(self.scenario.sites))

    def search_outlook(self, obj: str) -> dict:
        """R_o (the remaining probability of `obj` at a reachable site), its looks, and the R_o to give
        up below (under the cost rule the safety net, F_o of eq. 58 below give_up_probability, §7.8)."""
        remaining, looks = self.belief.unseen_probability(obj, self.excluded_sites)
        return {"object": obj, "remaining_probability": remaining, "looks": looks,
                "threshold": remaining_below(self.model.planning), "budget": self.search_budget()}

    def give_up(self, obj: str, outlook: dict, why: str) -> str | None:
        """End the search for `obj` (a ``give_up`` event, then stuck); return the end reason, or
        None when the task switched to a substitute (:mod:`fg_tea.tasks.substitutes`)."""
        if (reason := self._given_up(obj, outlook, why)) is not None:
            self._stuck(reason)
        return reason

    def _given_up(self, obj: str, outlook: dict, why: str) -> str | None:
        remaining = outlook.get("remaining_probability")
        self.events.append({"event": "give_up", **outlook, "why": why})
        if switch_to_substitute(self, obj) is not None:
            return None
        return (f"{NOT_FOUND}{obj} (remaining probability {'n/a' if remaining is None else f'{remaining:.3g}'} "
                f"after {outlook.get('looks')} looks; {why})")

    def _stuck(self, reason: str) -> None:
        self._stuck_reason = reason
        self.events.append({"event": "stuck", "reason": reason, "graph": self.graph.to_json()})

    # ------------------------------------------------------------------ search
    def pending_search_objects(self) -> list[str]:
        """Objects whose SEARCH action is not finished, in insertion order."""
        return list(dict.fromkeys(self.graph.action(n).object for n in self.graph.search_nodes()
                                  if not self.graph.is_finished(n)))

    def search_relevance(self) -> dict[str, float]:
        """r_o for every object with an unfinished search (eqs. 14, 15)."""
        return self.graph.relevance()

    def confirm_search(self, obj: str, site: str) -> dict:
        """Record that an inspection found `obj` at `site`; complete its SEARCH actions.

        Called for every object an inspection resolves, whichever search the planner was serving
        (docs/design.md §6.1). Search actions are completed whatever their status.

        Returns:
            The ``confirm_search`` event.
        """
        state = self._object(obj)
        self.scenario.site_index(site)
        before = state.to_json()
        state.resolved_site = site
        if not state.held:
            self._move(obj, site)
        completed = [n for n in self.graph.search_nodes(obj) if not self.graph.is_finished(n)]
        for node in completed:
            self.graph.set_status(node, "complete")
        event = {"event": "confirm_search", "object": obj, "site": site, "completed": completed,
                 "object_before": before, "object_after": state.to_json(),
                 "graph": self.graph.to_json()}
        self.events.append(event)
        return event

    # ------------------------------------------------------------------ checks
    def _object(self, name: str) -> ObjectState:
        try:
            return self.objects[name]
        except KeyError:
            raise KeyError(f"no object named {name!r} in scenario {self.scenario.name!r}") from None

    def unmet_preconditions(self, action: TaskAction) -> list[Violation]:
        """Belief preconditions of `action` that do not hold now (eq. 20)."""
        out = []
        for c in action.preconditions:
            p = self.belief.state(c.state)
            if p < c.at_least:
                out.append(Violation(
                    "belief", action.id,
                    f"{action.id}: precondition q({c.state} = true) >= {c.at_least:g} fails: "
                    f"belief is {p:.4f}", state=c.state, belief=p, threshold=c.at_least))
        return out

    def _needs(self, action: TaskAction, obj: str | None, affordance: str, role: str) -> list[Violation]:
        assert obj is not None, f"{action.id}: {action.verb} names its {role} (checked on loading)"
        have = self._object(obj).affordances
        if affordance in have:
            return []
        return [Violation("affordance", action.id,
                          f"{action.id}: {action.verb} needs {role} {obj!r} to be {affordance!r}; "
                          f"it affords {', '.join(sorted(have)) or 'nothing'}",
                          object=obj, affordance=affordance)]

    def _held(self, action: TaskAction) -> list[Violation]:
        if self._object(action.object).held:
            return []
        return [Violation("relation", action.id,
                          f"{action.id}: {action.verb} needs {action.object!r} to be held; the "
                          f"agent holds {self.holding() or 'nothing'}",
                          object=action.object, affordance="held")]

    def check(self, action: TaskAction) -> list[Violation]:
        """Every failed check of `action`: affordances and relations first, then beliefs."""
        v: list[Violation] = []
        verb, obj, dest = action.verb, action.object, action.destination
        if verb == "PICK":
            v += self._needs(action, obj, "graspable", "object")
            other = self.holding()
            if other is not None and other != obj:
                v.append(Violation("relation", action.id,
                                   f"{action.id}: PICK needs free hands; the agent holds {other!r}",
                                   object=other, affordance="free_hands"))
        elif verb == "INSERT":
            v += self._needs(action, dest, "container", "destination")
            v += self._held(action)
        elif verb == "FILL":
            v += self._needs(action, obj, "fillable", "object")
        elif verb == "POUR":
            v += self._needs(action, obj, "pourable", "source")
            v += self._held(action)
            v += self._needs(action, dest, "container", "destination")
        elif verb == "PLACE":
            v += self._held(action)
        if verb in ("USE", "WAIT") and action.requires_affordance is not None:
            v += self._needs(action, obj, action.requires_affordance, "object")
        return v + self.unmet_preconditions(action)

    def _raise_first(self, violations: list[Violation]) -> None:
        first = violations[0]
        cls = PreconditionError if first.kind == "belief" else AffordanceError
        raise cls(first.message, tuple(violations))

    def verification_inspections(self, action: TaskAction) -> list[str]:
        """Unmet precondition states of `action` that the runner may observe before completing.

        A state is offered when its object is located (held, or on a known site) and the pair
        (action, state) has been offered fewer than ``max_verifications`` times; each call counts
        as one offer per returned state. Empty when every precondition holds.
        """
        out = []
        for v in self.unmet_preconditions(action):
            assert v.state is not None  # a belief violation names its state
            obj = self._object(v.state.partition(".")[0])
            located = obj.held or obj.current_site is not None
            key = (action.id, v.state)
            if located and self._verifications[key] < self.max_verifications:
                self._verifications[key] += 1
                out.append(v.state)
        return out

    # ------------------------------------------------------------------ requests for the runner
    def inspection_site(self, obj: str) -> str | None:
        """Where to observe `obj`: None when held, else its site (or its most probable site)."""
        state = self._object(obj)
        if state.held:
            return None
        if state.current_site is not None:
            return state.current_site
        q = self.belief.location(obj)
        return self.belief.sites[int(np.argmax(q))]

    def request(self, action: TaskAction) -> ActionRequest:
        """The environment request for a practical action (not SEARCH or INSPECT).

        PICK goes where the object is believed to be; NAVIGATE and PLACE to the action's site;
        INSERT and POUR to the destination's site; FILL and USE to the object unless it is held.
        The transition name doubles as the environment's truth effect.
        """
        if action.verb in ("SEARCH", "INSPECT"):
            raise TaskError(f"{action.id}: {action.verb} is carried out by inspections, not by "
                            "an action request")
        site: str | None = None
        if action.verb == "PICK":
            site = self.inspection_site(action.object)
        elif action.verb in ("NAVIGATE", "PLACE"):
            site = action.site
        elif action.verb in ("INSERT", "POUR"):
            assert action.destination is not None  # INSERT and POUR name one (checked on loading)
            site = self.inspection_site(action.destination)
        elif action.verb in ("FILL", "USE"):
            site = action.site or self.inspection_site(action.object)
        return ActionRequest(action.verb, action.object, site, action.destination, action.transition)

    # ------------------------------------------------------------------ completing
    def _require_runnable(self, action: TaskAction, verbs: tuple[str, ...] | None = None) -> None:
        if action.id not in self.graph or self.graph.action(action.id) != action:
            raise TaskError(f"{action.id}: not an action of task {self.graph.name!r}")
        status = self.graph.status(action.id)
        if status not in ("pending", "active"):
            raise TaskError(f"{action.id}: cannot run an action whose status is {status!r}")
        if not self.graph.dependencies_met(action.id):
            waiting = [d for d in self.graph.dependencies(action.id) if not self.graph.is_finished(d)]
            raise TaskError(f"{action.id}: not ready, waiting on {', '.join(waiting)}")
        if verbs is not None and action.verb not in verbs:
            raise TaskError(f"{action.id}: expected a {' or '.join(verbs)} action, got {action.verb}")

    def _move(self, obj: str, site: str | None) -> None:
        self.objects[obj].current_site = site
        for inner, s in self.objects.items():
            if s.contained_in == obj:
                self._move(inner, site)

    def _apply_relations(self, action: TaskAction) -> None:
        state = self.objects[action.object]
        if action.verb == "PICK":
            state.held, state.contained_in = True, None
            self._move(action.object, None)
        elif action.verb == "NAVIGATE" and state.held:
            self._move(action.object, action.site)
        elif action.verb == "PLACE":
            state.held = False
            self._move(action.object, action.site)
        elif action.verb == "INSERT":
            assert action.destination is not None  # INSERT names one (checked on loading)
            state.held, state.contained_in = False, action.destination
            self._move(action.object, self.objects[action.destination].current_site)

    def complete(self, action: TaskAction, outcome: ActionResult | None = None) -> dict:
        """Complete a practical action: check it, apply its belief effects and relations.

        Args:
            action: the action (PICK, NAVIGATE, PLACE, INSERT, FILL, POUR, USE or WAIT).
            outcome: the environment's result, recorded in the event; must be ok.

        Returns:
            The ``complete`` event: graph, object state and belief before and after.

        Raises:
            AffordanceError: a missing affordance or relation (nothing changes).
            PreconditionError: a belief precondition fails (nothing changes).
            TaskError: the action is not runnable, is SEARCH/INSPECT, or the outcome failed.
        """
        self._require_runnable(action)
        if action.verb == "SEARCH":
            raise TaskError(f"{action.id}: a search completes through confirm_search")
        if action.verb == "INSPECT":
            raise TaskError(f"{action.id}: an inspection completes through observe")
        if outcome is not None and not outcome.ok:
            raise TaskError(f"{action.id}: the environment reported failure "
                            f"({outcome.reason or 'no reason'}); call fail() instead")
        violations = self.check(action)
        if violations:
            self._raise_first(violations)
        graph_before, objects_before = self.graph.to_json(), self.object_state()
        belief_before = self.belief.states()
        update = None
        if action.effects:
            update = self.belief.apply_effects(action.effects,
                                               direct=self.model.transition_form == "direct")
        self._apply_relations(action)
        self.graph.set_status(action.id, "complete")
        event = {"event": "complete", "action": action.id, "verb": action.verb,
                 "parameters": action.to_json(),
                 "outcome": None if outcome is None else {"ok": outcome.ok, "reason": outcome.reason},
                 "graph_before": graph_before, "graph_after": self.graph.to_json(),
                 "objects_before": objects_before, "objects_after": self.object_state(),
                 "belief_before": belief_before, "belief_after": self.belief.states(),
                 "transition": None if update is None else dict(update.detail)}
        self.events.append(event)
        return event

    def observe_state(self, state: str, value: bool, sensor: Sensor | None = None,
                      purpose: str = "verification") -> dict:
        """Absorb one noisy reading of `state` (eqs. 23, 24), outside any INSPECT action.

        Used for verification inspections and recovery re-inspections.

        Args:
            state: concrete state name.
            value: the reading.
            sensor: the sensor; default the model's ``"state"`` sensor.
            purpose: why it was read (``"verification"``, ``"recovery"``), for the log.

        Returns:
            The ``observe_state`` event.
        """
        sensor = sensor or self.model.sensor("state")
        update = self.belief.observe_state(state, bool(value), sensor)
        event = {"event": "observe_state", "purpose": purpose, "state": state, "value": bool(value),
                 "sensitivity": sensor.sensitivity, "specificity": sensor.specificity,
                 "before": update.before[state], "after": update.after[state]}
        self.events.append(event)
        return event

    def observe(self, action: TaskAction, value: bool) -> dict:
        """Absorb the reading of an INSPECT action with its sensor and complete the action.

        Returns:
            The ``inspect`` event with the belief before and after, and the graph after.
        """
        self._require_runnable(action, ("INSPECT",))
        graph_before = self.graph.to_json()
        assert action.state is not None and action.sensor is not None  # INSPECT names both
        update = self.belief.observe_state(action.state, bool(value), action.sensor)
        self.graph.set_status(action.id, "complete")
        event = {"event": "inspect", "action": action.id, "state": action.state,
                 "value": bool(value), "sensitivity": action.sensor.sensitivity,
                 "specificity": action.sensor.specificity,
                 "before": update.before[action.state], "after": update.after[action.state],
                 "graph_before": graph_before, "graph_after": self.graph.to_json()}
        self.events.append(event)
        return event
