"""The tea-making house as a Gymnasium environment (docs/design.md §9.1).

:class:`TeaEnv` is the world side of the loop of docs/design.md §1 behind Gymnasium's contract
(``reset(seed) -> (obs, info)``, ``step(action) -> (obs, reward, terminated, truncated, info)``):
it owns the house and its hidden truth and never holds a belief. Any agent can act through it;
:class:`GymAdapter` lets fg_tea's own :class:`~fg_tea.agent.agent.Agent` do so through
:class:`~fg_tea.episode.runner.EpisodeRunner`, which then writes the same log as ``fg-tea run``.

Needs the optional ``gym`` extra (``pip install "fg-tea[gym]"``): the core does not use Gymnasium.
``import fg_tea`` registers the id ``"fg_tea/TeaMaking-v0"`` (fg_tea/episode/gym_id.py; Gymnasium 1.x
loads no plug-ins), so either import order works::

    import fg_tea, gymnasium
    env = gymnasium.make("fg_tea/TeaMaking-v0", scenario="default_apartment")

(``"fg_tea.episode.gym_env:fg_tea/TeaMaking-v0"``, naming the module, works too.)
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from fg_tea.episode.gym_id import ENV_ID, register
from fg_tea.common.errors import InputError
from fg_tea.common.inputs import MAX_COORDINATE
from fg_tea.env.base import EnvAdapter
from fg_tea.env.truth import EFFECTS
from fg_tea.episode.run import make_env
from fg_tea.model.spec import Model, load_model
from fg_tea.world.interface import (
    VERBS,
    ActionRequest,
    ActionResult,
    InspectionResult,
    Pose,
    StateReading,
)
from fg_tea.world.scenario import Scenario, load_scenario

try:
    import gymnasium
    from gymnasium import spaces
except ImportError:  # pragma: no cover - exercised by the missing-extra test in a subprocess
    from fg_tea.common.install import install_command

    raise InputError("<import>", "gymnasium", "the Gymnasium environment needs the gym extra: "
                     f"{install_command('gym')}") from None

#: Action kinds: look from a viewpoint, read a hidden state, carry out a practical request.
KINDS = ("look", "read", "act")
#: Frames an episode can reach: the frame limit plus the longest single movement.
MAX_FRAMES = 10 ** 9
#: Reward for the tea served, against -1 per metre walked.
SERVED_REWARD = 10.0
#: What "the tea is served" means in the world's truth: brewed tea, served (a served empty mug
#: is not tea, and earns nothing).
GOAL_STATES = ("mug.tea_brewed", "mug.served")


class TeaEnv(gymnasium.Env):
    """Make a cup of tea in a simulated house.

    ## Description
    The house of a fg_tea scenario (the PyBullet house, or the fake house with the same geometry
    and truth) with its hidden truth: where the mug, kettle and teabag are, whether the kettle
    holds water, and so on. The environment never reveals truth in observations; an agent finds
    things by looking and reading noisy sensors (docs/design.md §8).

    ## Action Space
    ``Dict``: ``kind`` (``Discrete(3)``: 0 look, 1 read, 2 act) chooses which fields apply.
    *look*: ``viewpoint`` (``Discrete(V)``, the scenario's viewpoints in order) and ``objects``
    (``MultiDiscrete([O + 1] * O)``: the objects the look considers, in the order the detector
    takes them, each an index or O for none; repeats count once). *read*: ``state``
    (``Discrete(S)``, the scenario's ``object.state`` names in order) and ``sensor``
    (``Box([0, 0], [1, 1])``, the sensitivity and specificity the reading is drawn with, eqs.
    23-24). *act*: ``verb``
    (``Discrete(10)``, :data:`fg_tea.world.interface.VERBS`), ``object`` (``Discrete(O)``),
    ``site`` and ``destination`` (``Discrete(K + 1)`` and ``Discrete(O + 1)``, the last value
    meaning none) and ``effect`` (``Discrete(E + 1)``, the truth effects, the last meaning none).
    The tables are :attr:`viewpoints`, :attr:`states`, :attr:`objects`, :attr:`sites`.

    ## Observation Space
    ``Dict``: ``pose`` (``Box(3)``: x, y in metres, yaw in degrees), ``frame`` (``Box(1)``),
    ``seen`` and ``considered`` (``MultiBinary(O)``: objects seen, and looked for, by the last
    look), ``reading`` (``Discrete(3)``: no reading, false, true), ``ok`` (``Discrete(2)``: the
    last step did what was asked). ``info["result"]`` holds the full record of the step: an
    :class:`~fg_tea.world.interface.InspectionResult`, ``StateReading`` or ``ActionResult``.

    ## Rewards
    Minus the metres walked in the step; :data:`SERVED_REWARD` when the tea is served: every
    state of ``goal_states`` (default :data:`GOAL_STATES`: brewed, and served) holds in truth.

    ## Starting State
    The scenario's start pose and the world as the scenario's truth (and the seed) set it.

    ## Episode End
    Terminated when the world's truth says the tea is served (``goal_states``); truncated at
    ``max_frames`` frames (30 frames a second of simulated time).

    ## Arguments
    ``scenario``, ``model`` (a loaded object, a path or a bundled name), ``env`` (``"fake"`` or
    ``"pybullet"``), ``camera`` (a camera file or bundled name; None: the bundled camera of the
    detector the model assumes, docs/design.md §1.3), ``max_frames``, ``goal_states``.

    ## Version History
    * v0: initial version.
    """

    metadata = {"render_modes": []}

    def __init__(self, scenario: Scenario | str = "default_apartment",
                 model: Model | str = "factorised", env: str = "fake",
                 max_frames: int = 50_000, goal_states: Sequence[str] = GOAL_STATES,
                 camera: str | None = None) -> None:
        self.scenario = load_scenario(scenario) if isinstance(scenario, str) else scenario
        self.model = load_model(model) if isinstance(model, str) else model
        self.adapter: EnvAdapter = make_env(self.scenario, self.model, env, camera=camera)
        self.max_frames = int(max_frames)
        self.goal_states = tuple(goal_states)
        self.viewpoints = tuple(v.name for v in self.scenario.viewpoints)
        self.objects = tuple(self.scenario.object_names)
        self.sites = tuple(self.scenario.site_names)
        self.states = tuple(sorted({f"{o.name}.{s}" for o in self.scenario.objects
                                    for s in o.hidden_state_truth}))
        n_obj = len(self.objects)
        self.action_space = spaces.Dict({
            "kind": spaces.Discrete(len(KINDS)),
            "viewpoint": spaces.Discrete(len(self.viewpoints)),
            "objects": spaces.MultiDiscrete([n_obj + 1] * n_obj),
            "state": spaces.Discrete(max(1, len(self.states))),
            "sensor": spaces.Box(0.0, 1.0, (2,), dtype=np.float64),
            "verb": spaces.Discrete(len(VERBS)),
            "object": spaces.Discrete(n_obj),
            "site": spaces.Discrete(len(self.sites) + 1),
            "destination": spaces.Discrete(n_obj + 1),
            "effect": spaces.Discrete(len(EFFECTS) + 1),
        })
        self.observation_space = spaces.Dict({
            "pose": spaces.Box(np.array([-MAX_COORDINATE, -MAX_COORDINATE, -180.0]),
                               np.array([MAX_COORDINATE, MAX_COORDINATE, 180.0]), dtype=np.float64),
            "frame": spaces.Box(0.0, float(MAX_FRAMES), (1,), dtype=np.float64),
            "seen": spaces.MultiBinary(n_obj),
            "considered": spaces.MultiBinary(n_obj),
            "reading": spaces.Discrete(3),
            "ok": spaces.Discrete(2),
        })
        self._frame = 0
        self._started = False

    # ------------------------------------------------------------------ the contract
    def reset(self, *, seed: int | None = None, options: Mapping[str, Any] | None = None):
        super().reset(seed=seed)
        episode_seed = int(seed) if seed is not None else int(self.np_random.integers(2 ** 31))
        pose = self.adapter.reset(episode_seed)
        self._frame, self._started = 0, True
        return self._observation(pose), {"seed": episode_seed}

    def step(self, action: Mapping[str, Any]):
        if not self._started:
            raise RuntimeError("call reset() before step()")
        kind = KINDS[int(action["kind"])]
        try:
            result = self._carry_out(kind, action)
        except ValueError as exc:  # a request the world cannot even attempt: a no-op step
            result = ActionResult(False, f"invalid: {exc}")
        self._frame += int(getattr(result, "frames", 0))
        truth = self.adapter.truth_report().get("states", {})
        served = all(bool(truth.get(s, False)) for s in self.goal_states)
        reward = -float(getattr(result, "distance", 0.0)) + (SERVED_REWARD if served else 0.0)
        truncated = self._frame >= self.max_frames and not served
        return (self._observation(self.adapter.agent_pose(), result), reward, served, truncated,
                {"result": result})

    def close(self) -> None:
        self.adapter.close()

    # ------------------------------------------------------------------ encoding
    def look(self, viewpoint: str, objects: Sequence[str]) -> dict:
        """The action that looks from `viewpoint` for `objects`."""
        order = [self.objects.index(o) for o in objects]
        order += [len(self.objects)] * (len(self.objects) - len(order))
        return {**self._blank(), "kind": 0, "viewpoint": self.viewpoints.index(viewpoint),
                "objects": np.array(order, dtype=np.int64)}

    def read(self, state: str, sensitivity: float, specificity: float) -> dict:
        """The action that reads `state` (``object.state``) with this sensor."""
        return {**self._blank(), "kind": 1, "state": self.states.index(state),
                "sensor": np.array([sensitivity, specificity], dtype=np.float64)}

    def act(self, request: ActionRequest) -> dict:
        """The action that carries out `request`."""
        def index(table: Sequence[str], name: str | None) -> int:
            return len(table) if name is None else table.index(name)

        return {**self._blank(), "kind": 2, "verb": VERBS.index(request.verb),
                "object": self.objects.index(request.object), "site": index(self.sites, request.site),
                "destination": index(self.objects, request.destination),
                "effect": index(EFFECTS, request.effect)}

    def _blank(self) -> dict:
        return {"kind": 0, "viewpoint": 0,
                "objects": np.full(len(self.objects), len(self.objects), dtype=np.int64),
                "state": 0, "sensor": np.array([0.95, 0.95]), "verb": 0, "object": 0,
                "site": len(self.sites), "destination": len(self.objects), "effect": len(EFFECTS)}

    def _carry_out(self, kind: str, action: Mapping[str, Any]):
        if kind == "look":
            chosen = [int(i) for i in np.asarray(action["objects"]) if int(i) < len(self.objects)]
            objects = [self.objects[i] for i in dict.fromkeys(chosen)]
            return self.adapter.inspect_viewpoint(self.viewpoints[int(action["viewpoint"])], objects)
        if kind == "read":
            if not self.states:
                raise ValueError("the scenario has no hidden states to read")
            obj, _, state = self.states[int(action["state"])].partition(".")
            sensitivity, specificity = (float(x) for x in np.asarray(action["sensor"]))
            return self.adapter.observe_state(obj, state, self._site_of(action), sensitivity,
                                              specificity)
        site = int(action["site"])
        destination, effect = int(action["destination"]), int(action["effect"])
        return self.adapter.execute(ActionRequest(
            VERBS[int(action["verb"])], self.objects[int(action["object"])],
            self.sites[site] if site < len(self.sites) else None,
            self.objects[destination] if destination < len(self.objects) else None,
            EFFECTS[effect] if effect < len(EFFECTS) else None))

    def _site_of(self, action: Mapping[str, Any]) -> str | None:
        """Where a reading is taken: the action's ``site`` (the last value: none named)."""
        site = int(action["site"])
        return self.sites[site] if site < len(self.sites) else None

    def _observation(self, pose: Pose, result: Any = None) -> dict:
        seen = np.zeros(len(self.objects), dtype=np.int8)
        considered = np.zeros(len(self.objects), dtype=np.int8)
        reading, ok = 0, 1
        if isinstance(result, InspectionResult):
            for i, o in enumerate(self.objects):
                if o in result.detections:
                    considered[i], seen[i] = 1, int(bool(result.detections[o]))
            ok = int(result.reachable)
        elif isinstance(result, StateReading):
            reading = 2 if result.value else 1
        elif isinstance(result, ActionResult):
            ok = int(result.ok)
        return {"pose": np.array([pose.x, pose.y, pose.yaw_deg], dtype=np.float64),
                "frame": np.array([float(self._frame)]), "seen": seen, "considered": considered,
                "reading": reading, "ok": ok}


class GymAdapter(EnvAdapter):
    """fg_tea's environment contract served by a :class:`TeaEnv`: every look, reading and action
    is one ``env.step``; what the runner reads besides (geometry, distances, the expected pixels
    of the visibility model, and the truth written into ``episode_end`` for evaluation) is read
    from the wrapped world directly. With it, :class:`~fg_tea.episode.runner.EpisodeRunner` runs
    the fg_tea agent through Gymnasium and writes the same log as with the plain adapter."""

    def __init__(self, env: TeaEnv) -> None:
        self.env = env
        self.config = env.adapter.config

    def reset(self, seed: int) -> Pose:
        self.env.reset(seed=seed)
        return self.env.adapter.agent_pose()

    def agent_pose(self) -> Pose:
        return self.env.adapter.agent_pose()

    def distance_to_site(self, site: str) -> float:
        return self.env.adapter.distance_to_site(site)

    def distance_between_sites(self, a: str, b: str) -> float:
        return self.env.adapter.distance_between_sites(a, b)

    def walking_distance(self, target: str, xy: Sequence[float]) -> float:
        return self.env.adapter.walking_distance(target, xy)

    def expected_pixel_counts(self, categories: Sequence[str]):
        return self.env.adapter.expected_pixel_counts(categories)

    def company_pixel_counts(self, categories: Sequence[str]):
        return self.env.adapter.company_pixel_counts(categories)

    def inspect_viewpoint(self, viewpoint: str, objects: Sequence[str]) -> InspectionResult:
        return self.env.step(self.env.look(viewpoint, objects))[4]["result"]

    def observe_state(self, obj: str, state: str, site: str | None,
                      sensitivity: float, specificity: float) -> StateReading:
        action = self.env.read(f"{obj}.{state}", sensitivity, specificity)
        action["site"] = len(self.env.sites) if site is None else self.env.sites.index(site)
        return self.env.step(action)[4]["result"]

    def execute(self, request: ActionRequest) -> ActionResult:
        return self.env.step(self.env.act(request))[4]["result"]

    def truth_report(self) -> dict:
        return self.env.adapter.truth_report()

    def placements(self):
        return self.env.adapter.placements()

    def close(self) -> None:
        self.env.close()


register(gymnasium)
