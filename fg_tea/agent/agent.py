"""The agent: one object that holds the belief, the planner and the task executor (docs/design.md §1).

This module answers *what does the agent believe, what does it do next, and how does it take in
what happened?* It is the agent side of the loop of eq. (1),

    observation o  ->  belief q(s)  ->  decision pi,

with three verbs in the spirit of pomdp-py's ``Agent`` and pymdp's ``Agent``:

- :meth:`Agent.next_action` and :meth:`Agent.decide`: the next task action, and for a SEARCH the
  viewpoint to look from, with its full decision record (every candidate and its terms, §6);
- :meth:`Agent.observe_look` and :meth:`Agent.observe_state`: absorb an observation, an
  inspection result (eqs. 4-6, 30) or a noisy state reading (eqs. 23-24);
- :meth:`Agent.act` / :meth:`Agent.outcome`: what to ask the world to do for a practical action,
  and absorb its outcome (the action's transition, eq. 27, or its recovery, §10).

The agent never sees the world's truth and never imports the simulator: observations are plain
:mod:`fg_tea.world.interface` records, which an environment, a Gymnasium wrapper or a script
that makes them up can supply alike. ``agent.belief`` is the labelled belief (sites, objects and
states by name).
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from fg_tea.agent import records as _records
from fg_tea.agent.give_up import probability_rule, sweep_length, weigh
from fg_tea.beliefs.attribution import FactorAttribution
from fg_tea.beliefs.detection import PixelTable, ViewModel
from fg_tea.beliefs.engine import BeliefEngine, LookUpdate
from fg_tea.beliefs.occlusion import CompanyTable
from fg_tea.model.program_file import program_for
from fg_tea.model.spec import Model
from fg_tea.planning import Decision, DistanceModel, distances_for, make_planner
from fg_tea.planning.base import Planner, accept_decision, call_planner
from fg_tea.tasks.actions import TaskAction
from fg_tea.tasks.executor import MAX_REOPENINGS, NOT_FOUND, TaskExecutor
from fg_tea.tasks.records import RecoveryDecision, Violation
from fg_tea.tasks.load import load_task
from fg_tea.world.interface import ActionRequest, ActionResult, InspectionResult
from fg_tea.world.navigation import Navigator
from fg_tea.world.scenario import Scenario

#: Grid used for geodesic distances when no environment supplies them (metres): the embodiment
#: defaults of docs/design.md §8.6.
_GRID_RESOLUTION, _AGENT_RADIUS = 0.05, 0.22


class _Grid:
    grid_resolution = _GRID_RESOLUTION
    agent_radius = _AGENT_RADIUS


class _GridDistances:
    """Geodesic distances on the floor plan's occupancy grid, from one floor point."""

    def __init__(self, navigator: Navigator, xy: Sequence[float]) -> None:
        self._nav, self._xy = navigator, (float(xy[0]), float(xy[1]))
        self._index = {v.name: k for k, v in enumerate(navigator.scenario.viewpoints)}

    def from_agent(self, site: str) -> float:
        return self._nav.distance(self._index[site], self._xy)

    def between(self, a: str, b: str) -> float:
        return self._nav.distance(self._index[b], self._nav.vantages[self._index[a]])


class Agent:
    """The tea-making agent: belief, planner and task executor, driven by observations.

    Args:
        scenario: the house as the agent may know it (sites, viewpoints, priors; never truth).
        model: the agent's generative model.
        planner: a planner spec (``"efe"``, ``"lookahead:nodes=60"``, ``"module:attr"``...) or a
            planner object satisfying :class:`fg_tea.planning.Planner`.
        task: a task file or bundled task name.
        seed: seeds the planner's random generator (random and sampling planners only).
        preparation_site: where the tea is made (default: the scenario's).
        solver: the exact belief solver, ``"numpy"``, ``"gtsam"`` or ``"compiled"`` (docs/design.md §4).
        max_reopenings: task-level reopenings allowed (docs/design.md §10).
        expected_pixels: what each viewpoint would see of each category (from an environment's
            ``expected_pixel_counts``); needed unless the model makes close looks only. It can also
            be given later, with :meth:`set_view_geometry`.
        company: an environment's ``company_pixel_counts``, needed with it when the model sets
            ``[perception] facing_tolerance`` or ``occlusion`` (docs/design.md §3.4).

    Raises:
        fg_tea.PlannerRefused: the planner cannot plan for this house or belief (too many sites
            for the exact planner, a correlated joint too large for the lookahead).
    """

    def __init__(self, scenario: Scenario, model: Model, planner: str | Planner = "efe",
                 task: str = "make_tea", *, seed: int = 0, preparation_site: str | None = None,
                 solver: str = "numpy", max_reopenings: int = MAX_REOPENINGS,
                 expected_pixels: PixelTable | None = None,
                 company: CompanyTable | None = None) -> None:
        self.scenario, self.model = scenario, model
        self._attribution: FactorAttribution | None = None
        self.belief = BeliefEngine(scenario, model, backend=solver)
        self.graph = load_task(task, model, scenario, preparation_site)
        self.executor = TaskExecutor(self.graph, self.belief, scenario, model,
                                     max_reopenings=max_reopenings)
        self.planner_spec = planner if isinstance(planner, str) else type(planner).__name__
        self.planner: Planner = (make_planner(planner, model, rng=np.random.default_rng([seed, 0x9E7]))
                                 if isinstance(planner, str) else planner)
        check = getattr(self.planner, "check", None)  # optional: a planner without one states no limits
        if check is not None:
            check(self.belief, self.executor.pending_search_objects())
        #: Looks per viewpoint that missed something (the repeat term of eq. 12).
        self.inspected: dict[str, int] = {}
        self.last_decision: Decision | None = None
        self.views: ViewModel | None = None
        self._navigator: Navigator | None = None
        self._sweep: float | None = None  # metres of one sweep of the house (the give-up's unit)
        self._looked_from: tuple[float, float] | None = None  # the last look's vantage
        self._handed_out = 0  # the executor's events already returned by records()
        if expected_pixels is not None or model.close_looks_only:
            self.set_view_geometry(expected_pixels, company)

    # ------------------------------------------------------------------ set-up
    def set_view_geometry(self, expected_pixels: PixelTable | None,
                          company: CompanyTable | None = None) -> ViewModel:
        """Build the viewpoints' detection probabilities from what each one would see.

        Args:
            expected_pixels: viewpoint -> site -> category -> expected pixels per placement slot
                (an environment's ``expected_pixel_counts``); None for a close-looks model.
            company: the environment's ``company_pixel_counts`` (heading offsets and pairs on a
                site), needed when the model sets ``[perception] facing_tolerance`` or
                ``occlusion`` (docs/design.md §3.4).
        """
        self.views = ViewModel(self.scenario, self.model, self.belief.objects, expected_pixels,
                               company)
        self._reweigh()
        return self.views

    def view_geometry_from(self, env: Any) -> ViewModel:
        """:meth:`set_view_geometry` from an environment's pixel tables, the one way every caller
        sets it up: `env`'s ``expected_pixel_counts`` of the belief's categories, and its
        ``company_pixel_counts`` when the model looks with a facing tolerance or occlusion (none
        for a close-looks model). `env` is anything with those verbs (docs/design.md §9.1).
        """
        if self.model.close_looks_only:
            return self.set_view_geometry(None)
        categories = [self.scenario.object(o).category for o in self.belief.objects]
        company = (env.company_pixel_counts(sorted(categories))
                   if self.model.facing_tolerance or self.model.occlusion else None)
        return self.set_view_geometry(env.expected_pixel_counts(sorted(set(categories))), company)

    def _geometry_call(self) -> str:
        company = self.model.facing_tolerance or self.model.occlusion
        return ("set_view_geometry(env.expected_pixel_counts(...)"
                + (", env.company_pixel_counts(...))" if company else ")"))

    def _reweigh(self) -> None:
        """Under ``occlusion``, each look's probabilities are those under the belief of the last
        decision (docs/design.md §3.4, "Facing and company"); a no-op otherwise."""
        if self.views is not None and self.views.belief_dependent:
            b, sites = self.belief, {s: i for i, s in enumerate(self.belief.sites)}
            placed = {i: (None if st.held or st.contained_in else sites.get(st.current_site or ""))
                      for i, o in enumerate(b.objects) if (st := self.executor.objects.get(o)) is not None
                      and (st.held or st.contained_in is not None or st.current_site is not None)}
            self.views.reweigh(b.location_matrix(), b.pairwise() if b.correlated else None, placed)

    # ------------------------------------------------------------------ records
    def records(self) -> list[dict]:
        """The log records the agent made since this was last called, in order: skips,
        activations, searches confirmed, completions, readings, failures and recoveries, give-ups
        (docs/log-format.md). Each record is returned once; a loop writes them as they come."""
        events = self.executor.events
        out, self._handed_out = events[self._handed_out:], len(events)
        return out

    def decision_record(self, action: TaskAction, decision: Decision) -> dict:
        """The ``decision`` record of a SEARCH step (call it right after :meth:`decide`)."""
        return _records.decision_record(self, action, decision)

    def observation_record(self, viewpoint: str, objects: list[str], result: InspectionResult,
                           update: LookUpdate) -> dict:
        """The ``observation`` record of the look :meth:`observe_look` absorbed as `update`;
        `objects` are the decision's (its record's ``objects``)."""
        return _records.observation_record(self, viewpoint, objects, result, update)

    def start_record(self) -> dict:
        """The agent's fields of ``episode_start``: ``task``, ``searched``, ``graph``, ``tasks``,
        ``belief`` (the prior) and ``recovery`` (tries per reason, runs per action)."""
        return _records.start_record(self)

    def end_record(self, gtsam_check: bool = True) -> dict:
        """The agent's fields of ``episode_end``: ``graph``, ``goal_conditions``, ``belief`` and
        ``gtsam_agreement`` (None where gtsam cannot hold the belief or `gtsam_check` is off)."""
        return {"graph": self.graph.to_json(), "goal_conditions": _records.goal_conditions(self),
                "belief": self.belief.snapshot(),
                "gtsam_agreement": _records.gtsam_agreement(self) if gtsam_check else None}

    def snapshot(self) -> dict:
        """The belief as one JSON record (a ``belief`` event's fields), with the factors that
        moved each object's belief (``moved_by``, :meth:`attribution`)."""
        return {**self.belief.snapshot(), **self.attribution().fields(self.belief)}

    def attribution(self) -> FactorAttribution:
        """Which factors move each object's belief (docs/design.md §4.8), built at the first
        call from the belief's factors and the model's program."""
        if self._attribution is None:
            self._attribution = FactorAttribution(self.belief, program_for(self.scenario, self.model))
        return self._attribution

    def progress(self) -> tuple[int, int]:
        """(task actions finished, task actions in all)."""
        return sum(self.graph.is_finished(n) for n in self.graph), len(self.graph)

    def branch(self) -> "Agent":
        """A copy of the agent to explore an outcome with (a policy's evaluation): its belief,
        task and counters are its own; its inputs, view geometry and planner are shared; it has
        no records yet to return."""
        import copy

        shared = (self.scenario, self.model, self.views, self.planner)
        child = copy.deepcopy(self, memo={id(x): x for x in shared})
        child.executor.events.clear()
        child._handed_out = 0
        return child

    # ------------------------------------------------------------------ reading
    def searching(self) -> list[str]:
        """Objects whose search is not finished, in the task's order."""
        return self.executor.pending_search_objects()

    def viewpoints(self) -> list[str]:
        """The viewpoints the agent can look from (empty before the view geometry is set)."""
        return [] if self.views is None else list(self.views.names)

    def view(self, viewpoint: str):
        """What a look from `viewpoint` covers: its sites and detection probabilities
        (:class:`~fg_tea.beliefs.detection.ViewModel`'s view); read only."""
        if self.views is None:
            raise ValueError(f"model {self.model.name!r} has no view geometry yet: "
                             f"call {self._geometry_call()}")
        return self.views.view(viewpoint)

    def search_problem(self, distances: DistanceModel, look: float):
        """The search for the objects still searched as one :class:`~fg_tea.planning.problem.SearchProblem`
        (what the planners and the limit decide over), from the belief now, with no site excluded
        and looks of cost `look` per image; a close-looks model scores sites by its miss
        likelihood."""
        from fg_tea.planning.problem import build_problem

        views = None if self.model.close_looks_only else self.views
        return build_problem(self.belief, self.searching(), distances, frozenset(), views, look)

    # ------------------------------------------------------------------ deciding
    @property
    def done(self) -> bool:
        """Every task action is complete or skipped."""
        return self.executor.done

    @property
    def stuck_reason(self) -> str | None:
        """Why no action is ready although the task is not done (None otherwise)."""
        return self.executor.stuck_reason

    def end_reason(self) -> str | None:
        """Why the episode ends when :meth:`next_action` returned None: ``complete``, a search
        given up (``not_found: ...``) or ``stuck: ...`` with the executor's reason; None while
        the task goes on."""
        if self.executor.done:
            return "complete"
        stuck = self.executor.stuck_reason
        if stuck is None:
            return None
        return stuck if stuck.startswith(NOT_FOUND) else f"stuck: {stuck}"

    def next_action(self, position: Sequence[float] | None = None,
                    distances: DistanceModel | None = None) -> TaskAction | None:
        """The next ready task action (skipping what the belief says is done), or None: the task
        is done, or stuck (:attr:`stuck_reason` says why, e.g. a search given up).

        A SEARCH action is first checked by the probability rule (R_o below its bound, or the
        look budget spent: :func:`fg_tea.agent.give_up.probability_rule`); under the cost give-up
        (docs/design.md §7.8) it is then weighed (:meth:`weigh_search`) from `position`
        (default: where the agent last looked from, else the scenario's start) with `distances`
        (None: on the floor plan); a search given up there makes this None.
        """
        action = self.executor.ready_action()
        if action is None:
            return None
        given = probability_rule(self.executor, self.model.planning) if action.verb == "SEARCH" else None
        if given is not None and self.executor.give_up(*given) is not None:
            return None  # stuck (a search given up with no substitute to stand in)
        action = self.executor.activate(action.id)
        if action.verb != "SEARCH" or self.model.planning.give_up != "cost" or self.views is None:
            return action
        if position is None:
            position = self._looked_from or self.scenario.start_position
        return None if self.weigh_search(position, distances) is not None else action

    def decide(self, action: TaskAction, position: Sequence[float],
               distances: DistanceModel | None = None) -> Decision:
        """Choose where to look next for a SEARCH action (docs/design.md §6).

        Args:
            action: the SEARCH action being served.
            position: the agent's floor position (x, y), metres.
            distances: travel distances from `position` (an environment's geodesic lookups);
                None computes them on the scenario's floor plan.

        Returns:
            The decision: the chosen viewpoint and every candidate with its terms.

        Raises:
            TypeError / ValueError: the planner's decision breaks the Planner contract
                (:func:`fg_tea.planning.base.accept_decision`: not a decision, a choice outside
                its candidates, a NaN, an unknown viewpoint or object).
            RuntimeError: the planner raised a ``BaseException`` of its own (not an interrupt).
        """
        if self.views is None:
            raise ValueError(f"model {self.model.name!r} needs the view geometry before deciding: "
                             f"call {self._geometry_call()}")
        objects = self.executor.pending_search_objects()
        self._reweigh()
        distances = distances_for(self.model, self.scenario, position,
                                  geodesic=distances or self._grid_distances(position))
        learned = self.model.learning is not None and self.model.learning.detection_active
        # A close-looks model scores sites with its miss likelihood; once it has learned
        # per-category reliabilities (eq. 51) the planner scores them through the views.
        views = None if self.model.close_looks_only and not learned else self.views
        extra = {"views": views} if views is not None else {}
        decision = call_planner(self.planner_spec, self.planner.choose, self.belief, objects,
                                self.executor.search_relevance(), distances, dict(self.inspected),
                                frozenset(self.executor.excluded_sites), **extra)
        decision = accept_decision(decision, self.planner_spec, self.views.names, objects)
        self.last_decision = decision
        return decision

    def weigh_search(self, position: Sequence[float], distances: DistanceModel | None = None) -> str | None:
        """Under ``[planning] give_up = "cost"``, give up a search whose best next look costs more
        per chance of finding its object than finishing the task is worth (docs/design.md §7.8).

        A search is weighed only once its remaining probability R_o is below
        ``give_up_probability`` (from the first look with ``weigh_early``). :meth:`next_action`
        calls it for a SEARCH action. Returns the episode's end reason (``not_found: ...``) when a
        search was given up (the executor is then stuck, with a ``give_up`` event saying why),
        else None. Under ``give_up = "probability"`` it does nothing.
        """
        planning = self.model.planning
        if planning.give_up != "cost":
            return None
        if self.views is None:
            raise ValueError(f"model {self.model.name!r} needs the view geometry before weighing a "
                             f"search: call {self._geometry_call()}")
        outlooks = [self.executor.search_outlook(obj) for obj in self.executor.pending_search_objects()]
        outlooks = [o for o in outlooks if o["remaining_probability"] is not None and
                    (planning.weigh_early or o["remaining_probability"] < planning.give_up_probability)]
        if self._sweep is not None and not outlooks:
            return None
        distances = distances_for(self.model, self.scenario, position,
                                  geodesic=distances or self._grid_distances(position))
        excluded = frozenset(self.executor.excluded_sites)
        if self._sweep is None:  # fixed at the first weighing, from where the search starts
            self._sweep = sweep_length([v for v in self.views.names if v not in excluded], distances)
        value = planning.task_value(self.graph.name) * self._sweep
        if outlooks:
            self._reweigh()
        for outlook in outlooks:
            obj = outlook["object"]
            weighed = weigh(self.belief, obj, self.views, distances, excluded,
                            outlook["remaining_probability"], planning.absent_probability, value)
            if weighed["give_up"]:
                why = (f"the best look ({weighed['viewpoint']}) costs {weighed['cost_per_find']:.3g} m "
                       f"per chance of finding it, more than the task's value of {value:.3g} m "
                       f"(chance it can still be found {weighed['findable']:.3g})")
                return self.executor.give_up(obj, {**outlook, "weighed": weighed}, why)
        return None

    def _grid_distances(self, position: Sequence[float]) -> DistanceModel:
        if self._navigator is None:
            self._navigator = Navigator(self.scenario, _Grid())
        return _GridDistances(self._navigator, position)

    # ------------------------------------------------------------------ observing
    def observe_look(self, viewpoint: str, result: InspectionResult | Mapping[str, str | None]
                     ) -> LookUpdate:
        """Absorb one look from `viewpoint` (docs/design.md eqs. 4-6, 30).

        Args:
            viewpoint: the viewpoint looked from.
            result: the environment's :class:`~fg_tea.world.interface.InspectionResult`, or a
                plain mapping object -> the in-view site it was seen at, or None for "looked and
                not seen"; objects left out are "no observation".

        Returns:
            The belief update: marginals before and after, and the objects now found. Each found
            object's SEARCH is confirmed, whichever search was being served (§6.1).
        """
        assert self.views is not None, "set_view_geometry first"
        if isinstance(result, InspectionResult):
            found = {o: (result.found_at.get(o) if seen else None)
                     for o, seen in result.detections.items()}
        else:
            found = dict(result)
        update = self.belief.observe_viewpoint(self.views.view(viewpoint), found)
        if any(v is None for v in found.values()):
            self.inspected[viewpoint] = self.inspected.get(viewpoint, 0) + 1
        self._looked_from = self.scenario.viewpoint(viewpoint).position
        for obj in update.detected:
            self.executor.confirm_search(obj, found[obj] or viewpoint)
        return update

    def observe_state(self, state: str, value: bool, action: TaskAction | None = None,
                      purpose: str = "task") -> dict:
        """Absorb a noisy reading of a hidden state (eqs. 23-24).

        Args:
            state: ``"object.state"``, e.g. ``"kettle.contains_water"``.
            value: what the sensor read.
            action: the INSPECT action the reading serves, if any (it then completes).
            purpose: why it was read (``"task"``, ``"verification"``, ``"recovery"``), for the log.
        """
        if action is not None:
            return self.executor.observe(action, value)
        return self.executor.observe_state(state, value, self.model.sensor("state"), purpose=purpose)

    def sensor_for(self, action: TaskAction | None = None):
        """The sensor whose sensitivity and specificity a reading for `action` has."""
        return action.sensor if action is not None else self.model.sensor("state")

    def reading_site(self, obj: str) -> str | None:
        """Where the agent would read `obj`'s states: the site it believes `obj` is at."""
        return self.executor.inspection_site(obj)

    # ------------------------------------------------------------------ acting
    def verification_states(self, action: TaskAction) -> list[str]:
        """States to read before `action`, because the belief is unsure of its preconditions."""
        return self.executor.verification_inspections(action)

    def violations(self, action: TaskAction) -> list[Violation]:
        """Belief preconditions and affordances `action` does not meet (empty: it may go ahead)."""
        return self.executor.check(action)

    def act(self, action: TaskAction) -> ActionRequest:
        """What to ask the world to do for a practical `action` (verb, object, sites)."""
        return self.executor.request(action)

    def outcome(self, action: TaskAction, result: ActionResult) -> dict:
        """Absorb a successful action's outcome: its transition is applied to the belief (eq. 27).

        Raises:
            fg_tea.tasks.records.PreconditionError: the outcome violates a precondition.
        """
        return self.executor.complete(action, result)

    def failed(self, action: TaskAction, reason: str, site: str | None = None) -> RecoveryDecision:
        """Absorb a failed action: its recovery (retry, reopen or give up, docs/design.md §10)."""
        return self.executor.fail(action, reason, site=site)
