"""The episode: the loop of docs/design.md §1 over fg_tea's layers, one event at a time.

    truth s* -> observation o -> belief q(s) -> decision pi -> changed world s*'      (eq. 1)

Stepping (docs/design.md §9, "Stepping"): the first :meth:`EpisodeRunner.step` (or
:meth:`EpisodeRunner.start`, or :meth:`EpisodeRunner.reset`) only resets the environment and
writes ``episode_start``, so the prior belief can be read before the first decision. Every later
step asks the agent for the next action and carries it out, writing the records the agent's
verbs return (:meth:`fg_tea.agent.agent.Agent.records`) and one ``belief`` snapshot; the step
that finds nothing left to do writes ``episode_end`` and ``metrics``. What one action's step
covers:

- SEARCH: the planner scores every (unresolved object, site) pair on the task frontier; the
  environment goes to the chosen site and looks; the belief engine absorbs every detection and
  miss; every object found has its search confirmed, whichever search was being served (docs/design.md §6.1);
- INSPECT: the environment reads the hidden state through a noisy sensor; the executor absorbs it;
- practical actions: unmet belief preconditions are first verified by inspection (bounded); the
  environment carries the action out; the executor applies its belief effects, or its recovery
  when the environment reports a failure.

The runner never reads truth: it passes the environment's observations to the agent and logs
both, and it reaches the belief, the executor and the views only through the agent's verbs
(``tests/test_agent_door.py``); ``start_event``, ``start_truth`` and ``end_event`` are its own
records, public so that a loop of one's own writes the same log (docs/how-to/own-loop.md). It
stops on completion, on an unrecoverable failure, or on the frame limit, and says which
(``terminated`` vs ``truncated``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from fg_tea.agent.agent import Agent
from fg_tea.beliefs.query_methods import inference_record
from fg_tea.common.errors import PlannerFault
from fg_tea.env.base import EnvAdapter, EnvConfig
from fg_tea.env.camera import Camera, default_camera, load_camera
from fg_tea.episode.distances import EnvDistances
from fg_tea.episode.config import RunConfig, logged_run
from fg_tea.episode.log import EventLog
from fg_tea.episode.metrics import score
from fg_tea.episode.provenance import episode_provenance, portable_ref, program_record
from fg_tea.model.spec import Model
from fg_tea.tasks.records import PreconditionError
from fg_tea.world.interface import ActionRequest, Pose
from fg_tea.world.scenario import Scenario

REASON_COMPLETE = "complete"
REASON_FRAME_LIMIT = "frame_limit"


def env_config_for(model: Model, camera: "str | Path | Camera | None" = None,
                   base: EnvConfig | None = None, **overrides) -> EnvConfig:
    """The embodiment config of an episode: `base` with `camera`'s settings, then `overrides`.

    Which file sets what (docs/design.md §1.3): the model says what the agent assumes, the camera
    file what the camera reports. `camera` is a :class:`~fg_tea.env.camera.Camera`, a bundled
    camera's name or a camera file; None takes the bundled camera of the detector `model` assumes
    (:func:`~fg_tea.env.camera.default_camera`), the world the model describes. The config's
    ``camera_source`` names the camera file, for the log's provenance.

    Raises:
        InputError: a camera that cannot be read, or an override that would have no effect with
            its detector (:meth:`Camera.env_config <fg_tea.env.camera.Camera.env_config>`).
    """
    chosen = load_camera(camera if camera is not None else default_camera(model.detector))
    return replace(chosen.env_config(base, **overrides), camera_source=chosen.source)


@dataclass
class EpisodeState:
    """What the runner has done so far (all derived from observations, none from truth)."""

    frame: int = 0
    steps: int = 0
    done: bool = False
    reason: str | None = None
    terminated: bool = False
    truncated: bool = False


class EpisodeRunner:
    """Runs one episode of a task in an environment with a model, step by step.

    Args:
        scenario: the house (the agent reads its sites and priors; the env reads its truth).
        model: the agent's generative model.
        env: the environment adapter (PyBullet house, or a fake for tests).
        config: episode parameters.
        log: where events go (in memory when None).
        world: the world distribution the scenario was sampled from (bundled name or path), if
            any; recorded with its sha256 in ``episode_start.inputs``.
        render: the rendering parameters of the video made from this log (a
            ``fg_tea.render.video.VideoOptions`` or a mapping), recorded in
            ``episode_start.parameters.render``; None when no video is made.

    Between steps, ``runner.agent`` (its ``belief``, ``last_decision``...) can be inspected
    freely. ``runner.agent.belief.sites`` and ``runner.agent.belief.objects`` give the order of
    every marginal's entries.
    """

    def __init__(self, scenario: Scenario, model: Model, env: EnvAdapter,
                 config: RunConfig = RunConfig(), log: EventLog | None = None, *,
                 world: str | Path | None = None, render: Any = None) -> None:
        self.scenario = scenario
        self.model = model
        self.env = env
        self.world = world
        self.render = render
        self._setup(config, log)

    def _setup(self, config: RunConfig, log: EventLog | None) -> None:
        """Fresh agent state for an episode with `config` (the environment is reset at start)."""
        self.config = config
        self.log = log if log is not None else EventLog()
        self._between: dict[tuple[str, str], float] = {}  # viewpoint distances (EnvDistances)
        self._matrices: dict[tuple[str, ...], np.ndarray] = {}
        self.agent = Agent(self.scenario, self.model, config.planner, config.task,
                           seed=config.seed, preparation_site=config.preparation_site,
                           solver=config.solver, max_reopenings=config.max_reopenings)
        self.state = EpisodeState()
        self._started = False
        # For the clairvoyant yardstick only (written in episode_end, never read by the agent):
        # the start floor point and the objects' true start sites, as the environment reports them.
        self._yardstick_start: tuple[tuple[float, float], dict] | None = None

    # ------------------------------------------------------------------ properties
    @property
    def done(self) -> bool:
        return self.state.done

    @property
    def reason(self) -> str | None:
        return self.state.reason

    @property
    def events(self) -> list[dict]:
        return self.log.events

    # ------------------------------------------------------------------ logging helpers
    def _write(self, event: dict) -> dict:
        return self.log.write({**event, "frame": self.state.frame})

    def _flush_agent(self, merge_last: bool = False) -> dict | None:
        """Write the agent's new records; with merge_last, return the last one instead."""
        pending = self.agent.records()
        last = pending.pop() if merge_last and pending else None
        for event in pending:
            self._write(event)
        return last

    def _advance(self, result) -> dict:
        self.state.frame += int(result.frames)
        return {"distance": float(result.distance), "frames": int(result.frames),
                "motion": [list(p) for p in result.motion]}

    # ------------------------------------------------------------------ episode
    def reset(self, seed: int | None = None, log: EventLog | None = None) -> dict:
        """Start the episode afresh, optionally with a new seed; return its ``episode_start``.

        Everything the agent holds is rebuilt (belief, task graph, executor, planner and its
        random generator, counters), the environment is reset with the seed, and the prior is
        logged; ``runner.agent.belief`` is then the prior, before any decision. The same seed gives
        the same events as a fresh runner.

        Args:
            seed: the episode seed (environment draws, random planner); None keeps the current one.
            log: where the new episode's events go; None starts a new in-memory log (a file log
                of the previous episode is never written again).
        """
        config = self.config if seed is None else replace(self.config, seed=int(seed))
        self._setup(config, log)
        return self.start()

    def start(self) -> dict:
        """Reset the environment and write the episode_start event (the prior); return it.

        Idempotent: once started, returns the episode_start already written.
        """
        if self._started:
            return self.log.events[0]
        pose = self.env.reset(self.config.seed)
        self._started = True
        self.agent.view_geometry_from(self.env)
        self._yardstick_start = start_truth(self.env, pose)
        event = self._write(start_event(self.scenario, self.model, self.env, self.config, self.agent,
                                        pose, world=self.world, render=self.render))
        return event

    def step(self) -> list[dict]:
        """Carry out one step of the loop; return the events it wrote.

        The first step only starts the episode (``[episode_start]``, the prior). Each later step
        carries out one task action: a SEARCH step is one look (``activate`` when the action
        starts, ``decision``, ``observation``, a ``confirm_search`` for every object found), an
        INSPECT step one ``state_reading``, a practical step its verification readings and its
        ``action`` (or ``action_failed`` and the recovery's events); skips and reopenings the
        executor decides on the way are written in order, and every action step ends with a
        ``belief`` snapshot. The step that finds the task finished, stuck or out of frames writes
        ``episode_end`` and ``metrics``; after that, steps return ``[]``.
        """
        first = len(self.log.events)
        if not self._started:
            return [self.start()]
        if self.state.done:
            return []
        if self.state.frame >= self.config.max_frames:
            self._end(REASON_FRAME_LIMIT, truncated=True)
            return self.log.events[first:]
        pose = self.env.agent_pose()  # where a search is weighed from (give-up, design §7.8)
        action = self.agent.next_action((pose.x, pose.y),
                                        EnvDistances(self.env, self._between, self._matrices))
        self._flush_agent()
        if action is None:
            self._end(self.agent.end_reason() or "stuck: ", terminated=True)
            return self.log.events[first:]
        self.state.steps += 1
        if action.verb == "SEARCH":
            self._search(action)
        elif action.verb == "INSPECT":
            self._inspect(action)
        else:
            self._practical(action)
        if self.config.snapshot_every_event:
            self._write({"event": "belief", **self.agent.snapshot()})
        return self.log.events[first:]

    def run(self, progress: Callable[["EpisodeRunner"], None] | None = None) -> dict:
        """Step until the episode ends; return its metrics (computed from the log)."""
        if not self._started:
            self.start()
        while not self.state.done:
            self.step()
            if progress is not None:
                progress(self)
        return self.metrics()

    def metrics(self) -> dict:
        return score(self.log.events)

    # ------------------------------------------------------------------ search
    def _search(self, action) -> None:
        agent = self.agent
        pose = self.env.agent_pose()
        distances = EnvDistances(self.env, self._between, self._matrices)
        try:
            decision = agent.decide(action, (pose.x, pose.y), distances)
        except (Exception, SystemExit) as exc:  # a planner of the user's own, often: end, saying why
            first = (str(exc).splitlines() or [""])[0]
            what = f"failed: {type(exc).__name__}" + (f": {first}" if first else "")
            self._end(f"planner_error: {what}", terminated=True)
            raise PlannerFault(self.config.planner, what) from exc
        viewpoint = decision.viewpoint
        record = agent.decision_record(action, decision)
        self._write(record)
        objects = record["objects"]
        result = self.env.inspect_viewpoint(viewpoint, objects)
        moved = self._advance(result)
        if not result.reachable:
            agent.failed(action, "unreachable", site=viewpoint)
            event = self._flush_agent(merge_last=True) or {}
            self._write({**event, "event": "action_failed", "action": action.id,
                         "site": viewpoint, "reason": "unreachable", **moved})
            return
        update = agent.observe_look(viewpoint, result)
        confirmed = agent.records()  # the searches this look confirmed, written after the look
        self._write({**agent.observation_record(viewpoint, objects, result, update), **moved})
        for event in confirmed:
            self._write(event)

    # ------------------------------------------------------------------ state inspections
    def _read_state(self, state: str, purpose: str, action=None) -> dict:
        obj = state.partition(".")[0]
        sensor = self.agent.sensor_for(action)
        site = self.agent.reading_site(obj)
        reading = self.env.observe_state(obj, state.partition(".")[2], site,
                                         sensor.sensitivity, sensor.specificity)
        moved = self._advance(reading)
        self.agent.observe_state(state, reading.value, action, purpose)
        event = self._flush_agent(merge_last=True) or {}
        return self._write({**event, "event": "state_reading", "purpose": purpose,
                            "executor_event": event.get("event"), "site": site, **moved})

    def _inspect(self, action) -> None:
        self._read_state(action.state, "task", action)

    # ------------------------------------------------------------------ practical actions
    def _practical(self, action) -> None:
        while states := self.agent.verification_states(action):
            for state in states:
                self._read_state(state, "verification")
        violations = self.agent.violations(action)
        if violations:
            kind = "precondition_unmet" if all(v.kind == "belief" for v in violations) else "affordance"
            self._fail(action, kind, detail=[v.to_json() for v in violations])
            return
        request: ActionRequest = self.agent.act(action)
        result = self.env.execute(request)
        moved = self._advance(result)
        env_fields = {"request": {"verb": request.verb, "object": request.object, "site": request.site,
                                  "destination": request.destination, "effect": request.effect},
                      "placements": {k: list(v) for k, v in (result.placements or {}).items()},
                      **moved}
        if not result.ok:
            self._fail(action, result.reason, env_fields=env_fields)
            return
        try:
            self.agent.outcome(action, result)
        except PreconditionError as exc:
            self._fail(action, "precondition_unmet", detail=[str(exc)], env_fields=env_fields)
            return
        event = self._flush_agent(merge_last=True) or {}
        self._write({**event, "event": "action", **env_fields})

    def _fail(self, action, reason: str, detail=None, env_fields: Mapping | None = None) -> None:
        decision = self.agent.failed(action, reason)
        event = self._flush_agent(merge_last=True) or {}
        self._write({**event, "event": "action_failed", "action": action.id, "reason": reason,
                     "detail": detail or [], **(env_fields or {"distance": 0.0, "frames": 0, "motion": []})})
        if decision.retry:
            for state in decision.inspections:
                self._read_state(state, "recovery")

    # ------------------------------------------------------------------ the end
    def _end(self, reason: str, terminated: bool = False, truncated: bool = False) -> None:
        self.state.done, self.state.reason = True, reason
        self.state.terminated, self.state.truncated = terminated, truncated
        self._write(end_event(self.env, self.agent, self.config, self.log.events, reason,
                              terminated, truncated, self._yardstick_start))
        # Metrics are a pure function of the events above; logged once more for convenience.
        self._write({"event": "metrics", **score(self.log.events)})


def start_event(scenario: Scenario, model: Model, env: EnvAdapter, config: RunConfig, agent: Agent,
                pose: Pose, *, world: str | Path | None = None, render: Any = None) -> dict:
    """The ``episode_start`` record (before its ``seq`` and ``frame``) of an episode whose
    environment was just reset to `pose` and whose agent has its view geometry: the inputs and
    their provenance, every parameter, the house as the agent may know it, the task and the prior.
    `world` and `render` as for :class:`EpisodeRunner`; the agent's factor attribution adds the
    factors that moved the prior to its ``belief`` (``moved_by``) and its plan to ``inference``."""
    looks_from = set(agent.viewpoints())
    # JSON records of the log (mixed value types); the yardstick reads them back.
    viewpoints: list[dict[str, Any]] = [
        {"name": v.name, "kind": v.kind, "position": list(v.position),
         "sites": list(v.sites), "room": v.room}
        for v in scenario.viewpoints if v.name in looks_from]
    from fg_tea.common.resources import _resolve, resolve_task

    world_file = None if world is None else _resolve(world, "scenarios/worlds", ".json")
    provenance = episode_provenance(scenario.source, model.source,
                                    resolve_task(config.task), world_file, render,
                                    camera=getattr(env.config, "camera_source", None))
    mine = agent.start_record()
    return {
        "event": "episode_start",
        "scenario": scenario.name,
        "scenario_file": (provenance["inputs"]["scenario"] or {}).get("file"),
        "model": model.name, "model_file": portable_ref(model.source) if model.source else None,
        "structure": model.structure,
        # The exact method of each query (docs/design.md §4.8), chosen when the belief was built.
        "inference": inference_record(agent.belief, agent.attribution()),
        # A model program (docs/design.md §4.8): its file, hash and factors; absent for TOML models.
        **({"program": program_record(scenario, model)} if model.program is not None else {}),
        "task": mine["task"], "planner": config.planner, "seed": config.seed,
        "versions": provenance["versions"], "git": provenance["git"],
        "inputs": provenance["inputs"],
        "parameters": {"run": logged_run(config), "env": _env_params(env.config),
                       "render": provenance["render"],
                       "planning": asdict(model.planning),
                       "detection": {"miss_likelihood": model.miss_likelihood,
                                     "false_positive_rate": model.false_positive_rate,
                                     "positive_update": model.positive_update,
                                     "prior_floor": model.prior_floor,
                                     "detector": model.detector,
                                     "visibility": (model.detection_curve.to_json()
                                                    if model.detection_curve else None),
                                     "room_glances": model.room_glances},
                       "transition_form": model.transition_form,
                       "recovery": {**asdict(model.retries),
                                    "tries": mine["tries"], "action_runs": mine["action_runs"]},
                       # Experience (docs/design.md §12), only for a model that has some, so
                       # a model learned from no logs writes its base model's events.
                       **({"learning": model.learning.to_json()}
                          if model.learning is not None and model.learning.active else {})},
        "sites": [{"name": s.name, "room": s.room, "vantage": list(s.vantage),
                   "position": list(s.position)} for s in scenario.sites],
        "viewpoints": viewpoints,
        "objects": list(scenario.object_names),
        "categories": {o.name: o.category for o in scenario.objects},
        "searched": mine["searched"], "graph": mine["graph"], "tasks": mine["tasks"],
        "pose": pose.as_list(),
        "world": {"placements": {k: list(v) for k, v in env.placements().items()}},
        "belief": {**mine["belief"], **agent.attribution().fields(agent.belief)},
    }


def start_truth(env: EnvAdapter, pose: Pose) -> tuple[tuple[float, float], dict]:
    """For the clairvoyant yardstick only (written in ``episode_end``, never read by the agent):
    the start floor point and the objects' true start sites, as the environment reports them."""
    return (pose.x, pose.y), dict(env.truth_report().get("sites") or {})


def end_event(env: EnvAdapter, agent: Agent, config: RunConfig, events: list[dict], reason: str,
              terminated: bool, truncated: bool, truth: tuple[tuple[float, float], dict] | None) -> dict:
    """The ``episode_end`` record (before its ``seq`` and ``frame``) of an episode whose log so far
    is `events`, ending for `reason`. `truth` is :func:`start_truth`'s (None: no yardstick). The
    ``metrics`` record follows it: ``score(log.events)`` once it is written."""
    end = {"event": "episode_end", "reason": reason, "terminated": terminated,
           "truncated": truncated,
           # the agent's graph, goal conditions, belief and gtsam agreement (off: None,
           # RunConfig.gtsam_check)
           **agent.end_record(config.gtsam_check),
           # The world as it truly ended, for evaluation only: written after the agent's
           # last decision, never read by the agent side.
           "world_truth": env.truth_report(),
           # The clairvoyant yardstick (fg_tea.episode.yardstick), for evaluation only.
           "yardstick": _yardstick(env, events, truth)}
    return end


def _yardstick(env: EnvAdapter, events: list[dict],
               truth: tuple[tuple[float, float], dict] | None) -> dict | None:
    """The clairvoyant route for this episode's searched objects, or None if unknown."""
    if truth is None:
        return None
    from fg_tea.episode.yardstick import clairvoyant_report

    start_xy, true_sites = truth
    start = next((e for e in events if e.get("event") == "episode_start"), {})
    objects = list(start.get("searched") or [])
    if not true_sites or any(o not in true_sites for o in objects):
        return None
    viewpoints = start.get("viewpoints") or []
    positions = {v["name"]: v["position"] for v in viewpoints}
    walk = env.walking_distance
    try:
        report = clairvoyant_report(viewpoints, true_sites, objects,
                                    lambda v: walk(v, start_xy),
                                    lambda a, b: walk(b, positions[a]), start_xy)
    except NotImplementedError:
        return None
    travel = report["clairvoyant_search_travel"]
    if travel is not None:
        report["clairvoyant_search_travel"] = round(travel, 6)
    return report


def _env_params(config: EnvConfig) -> dict:
    from dataclasses import fields

    out = {f.name: getattr(config, f.name) for f in fields(config) if f.name != "camera_source"}
    out["failure_rates"] = dict(config.failure_rates)
    if out.pop("effect_success"):  # logged only when set, so other logs stay byte for byte
        out["effect_success"] = dict(config.effect_success)
    out["camera_curve"] = config.camera_curve.to_json() if config.camera_curve else None
    return out
