"""Generative model: what the agent assumes — likelihoods, transitions, relations, policy weights.

A model is a TOML file in ``models/`` (one file per variant). It is separate from the scenario:
the scenario says what the house *is*; the model says what the agent *believes about how
observations and actions work*. A model may ``extends = "other"`` and override keys (ablations are
a few lines each). Parsed once into frozen dataclasses; faults are
:class:`~fg_tea.common.errors.InputError` naming the file, the key path and what is wrong.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

from fg_tea.common.errors import InputError
from fg_tea.common.inputs import Reader
from fg_tea.model.checks import check_model
from fg_tea.model.documents import load_document, origin_lookup
from fg_tea.model.learning import Learning, apply_to_sensors, apply_to_transitions, read_learning
from fg_tea.world.detectors import Detector, detector_kind, detector_names
from fg_tea.world.visibility import VisibilityCurve, read_curve

STRUCTURES = ("factorised", "joint")
#: Where the camera's settings live now, for the one line that refuses them in a model file.
CAMERA_KEY_MOVED = ("the camera is configured by a camera file (--camera; bundled: cameras/), "
                    "the model says only what the agent assumes (docs/design.md §1.3)")
#: Longest chain of ``extends`` (the bundled ablations use two levels).
RELATION_KINDS = ("capacity", "co_location", "exclusivity")
#: The roles a transition's state templates may name, filled in from a task action
#: (docs/design.md §7.3); ``{object}.contains_water`` becomes ``kettle.contains_water``.
ROLES = ("object", "destination")
ROLE_TEMPLATE = re.compile(r"\{([^{}]*)\}")


@dataclass(frozen=True)
class Effect:
    """Sets `state` to `value` with probability `success` if all `requires` hold (eq. 27)."""

    state: str
    value: bool
    success: float
    requires: tuple[str, ...] = ()


@dataclass(frozen=True)
class Condition:
    """A belief goal or precondition: q(state = true) >= at_least (eqs. 19, 20)."""

    state: str
    at_least: float


@dataclass(frozen=True)
class TransitionSpec:
    """An action's declared belief effects, goals and preconditions, with role templates."""

    name: str
    effects: tuple[Effect, ...]
    goals: tuple[Condition, ...] = ()
    preconditions: tuple[Condition, ...] = ()


@dataclass(frozen=True)
class Relation:
    """A relational factor between object locations (joint models only).

    kinds: ``capacity`` (penalty per object beyond a site's capacity), ``co_location`` (weights for
    two categories sharing a site or a room), ``exclusivity`` (weight for any two objects sharing a
    site).
    """

    kind: str
    penalty: float = 0.05
    categories: tuple[str, str] = ("", "")
    same_site: float = 1.0
    same_room: float = 1.0
    weight: float = 1.0


@dataclass(frozen=True)
class PlanningWeights:
    """Weights of the EFE-style score G(o, j), eqs. 12-16 (lower is better), and when to give up.

    Giving up a search (docs/design.md §7.8) looks at the *remaining probability* R_o: the
    probability, under the object's prior (eq. 2) and the detection model (eqs. 5-6), that o
    stands at a reachable site and would still be unseen after the looks so far. A present
    object gives a run of misses that unlikely with probability R_o, so a rule that gives up
    only when R_o < ``give_up_probability`` gives up on a findable object in at most that
    fraction of searches when the model is right. ``max_inspections_per_object`` caps the looks
    that missed o (0: automatic, K x (ceil(log p / log mu) + 1) for K sites).

    ``give_up = "cost"`` (the default) then weighs the cost: with a = ``absent_probability`` the
    chance o can still be found is F_o = R_o (1 - a) / (R_o (1 - a) + a) (eq. 58), and a search
    whose R_o is below ``give_up_probability`` stops only when the best next look's cost per
    chance of finding o exceeds the value of finishing the task, ``task_values[task]`` (or
    ``["default"]``) sweeps of the house. ``weigh_early = true`` weighs from the first look, so a
    cheap task may be given up sooner; the search also ends, whatever the cost, when F_o <
    ``give_up_probability``. ``give_up = "probability"`` gives up as soon as R_o is below the
    threshold, without weighing (the earlier default).
    """

    distance_weight: float = 0.20
    probability_weight: float = 3.00
    information_weight: float = 1.50
    repeat_penalty: float = 1.00
    relevance_weight: float = 0.75
    distance: str = "geodesic"
    give_up_probability: float = 1e-3
    max_inspections_per_object: int = 0
    give_up: str = "cost"
    absent_probability: float = 1e-3
    weigh_early: bool = False
    task_values: tuple[tuple[str, float], ...] = (("default", 3.0),)

    def task_value(self, task: str) -> float:
        """The value of finishing `task`, in sweeps of the house (``[planning.task_value]``)."""
        values = dict(self.task_values)
        return values.get(task, values.get("default", 3.0))


def _task_values(planning_r: Reader, default: tuple[tuple[str, float], ...]) -> tuple[tuple[str, float], ...]:
    """``[planning.task_value]``: task name -> value of finishing it, in sweeps of the house."""
    table = planning_r.child("task_value", required=False)
    values = dict(default)
    if table is not None:
        for name in table.names():
            values[name] = table.positive(name, values.get(name, 1.0))
    return tuple(sorted(values.items()))


@dataclass(frozen=True)
class RetryModel:
    """What the agent assumes about actions that fail for no cause it can act on, and how often
    it tries them (``docs/design.md`` §7.6, "Transient failures").

    A *transient* failure (``fg_tea.tasks.actions.TRANSIENT_REASONS``) is the environment saying
    that an action did not happen and nothing changed, without a cause the agent could act on
    (no object missing, no site unreachable). The model assumes (eq. 49) each try of a doable
    action fails independently with probability at most ``failure_rate``. A task whose practical
    actions are run at most M times in an episode (every non-search action, once plus once per
    allowed task-level reopening) gives each action up to

        k = ceil(log(tolerance / M) / log(failure_rate))

    tries in a row, so that by the union bound P(some doable action of the episode fails k times
    running) <= M x failure_rate^k <= ``tolerance``, at the declared rate or any lower one, in any
    house: the bound counts the task's actions, never the house's sites. A run of k failures is
    then strong evidence that the action cannot be done now, and the episode ends stuck with it.

    Defaults: ``failure_rate`` 0.5, i.e. a verb that fails more often than it succeeds is treated
    as broken rather than unlucky; ``tolerance`` 1e-3, the same one-in-a-thousand false give-up
    rate as the search give-up (``PlanningWeights.give_up_probability``). For make-tea (14
    practical actions, 2 reopenings, M = 42) this is k = 16 tries.
    """

    failure_rate: float = 0.5
    tolerance: float = 1e-3

    def tries(self, runs: int) -> int:
        """k, the tries of one action before a transient failure run ends the episode.

        Args:
            runs: M, how many action runs the episode may make (at least 1).
        """
        f, eps = self.failure_rate, self.tolerance
        if f <= 0.0:
            return 1
        return max(1, math.ceil(math.log(eps / max(1, runs)) / math.log(f)))


@dataclass(frozen=True)
class Sensor:
    """A noisy binary sensor: sensitivity P(o=1|z=1), specificity P(o=0|z=0)."""

    sensitivity: float
    specificity: float


@dataclass(frozen=True)
class Model:
    """The agent's generative model (:func:`load_model`): what it assumes about the house, its
    detector, its sensors and its actions (docs/design.md §3-§5).

    Attributes:
        name, description: from the file; the run folder is named from `name`.
        structure: ``"factorised"`` (independent location beliefs) or ``"joint"``.
        prior_floor, miss_likelihood, false_positive_rate, positive_update: the location belief's
            prior floor and detection terms (eqs. 2-6, 31).
        sensors: the noisy state sensors by name (eqs. 23-24); ``sensor(name)``.
        transitions: each action's belief transition (eq. 27); ``transition(name)``.
        relations: co-location relations between objects (the joint model's factors).
        planning: the planner's weights (w_d, w_p, w_e, w_a, lambda; eq. 12-16).
        detector, detection_curve: the detector the agent assumes (eqs. 29-30).
        source: the file read (or the bundled name).
    """

    name: str
    description: str
    structure: str
    prior_floor: float
    miss_likelihood: float
    false_positive_rate: float
    positive_update: str
    min_visible_pixels: int
    sensors: Mapping[str, Sensor]
    transition_form: str
    transitions: Mapping[str, TransitionSpec]
    relations: tuple[Relation, ...] = ()
    planning: PlanningWeights = field(default_factory=PlanningWeights)
    source: str = ""
    retries: RetryModel = field(default_factory=RetryModel)
    #: The detector the agent assumes (docs/design.md §3.4): ``"threshold"`` (eq. 29) or
    #: ``"visibility"`` (eq. 30, with `detection_curve`). The camera's own detector is set by the
    #: camera file (:mod:`fg_tea.env.camera`), never here.
    detector: str = "threshold"
    detection_curve: VisibilityCurve | None = None
    room_glances: bool = False
    #: docs/design.md §3.4, "Facing and company": average the detection probability over the
    #: turn tolerance of a look, and condition it on the other objects sharing the site.
    facing_tolerance: bool = False
    occlusion: bool = False
    #: Experience learned from logs (docs/design.md §12); None or without counts: no change.
    learning: Learning | None = None
    #: The declared sensors before eq. 52 was applied (None when no learning changed them).
    declared_sensors: Mapping[str, Sensor] | None = None
    #: The declared transitions before eq. 63 was applied (None when no learning changed them).
    declared_transitions: Mapping[str, TransitionSpec] | None = None
    #: A model program's source (:class:`fg_tea.model.program_file.ProgramSource`): the graph's starting factors.
    program: Any = None

    @property
    def close_looks_only(self) -> bool:
        """The pre-viewpoint behaviour: threshold detector, one close look per site."""
        return self.detector_kind.pixel_free and not self.room_glances

    @property
    def detector_kind(self) -> Detector:
        """The registered kind of :attr:`detector` (:mod:`fg_tea.world.detectors`)."""
        return detector_kind(self.detector, self.source or f"<model {self.name}>", "$.perception.detector")

    def sensor(self, name: str = "state") -> Sensor:
        return self.sensors[name]

    def transition(self, name: str) -> TransitionSpec:
        try:
            return self.transitions[name]
        except KeyError:
            raise KeyError(f"model {self.name!r} declares no transition {name!r} "
                           f"(known: {', '.join(sorted(self.transitions))})") from None

    def with_overrides(self, **changes: Any) -> "Model":
        return replace(self, **changes)


POSITIVE_UPDATES = ("collapse", "likelihood")
#: The earlier name of ``"collapse"``, still read from older model files.
_OLD_POSITIVE_UPDATE = "blue" "print"


def _positive_update(detection: Reader) -> str:
    if detection.has("positive_update") and \
            detection.opt("positive_update", str, "collapse") == _OLD_POSITIVE_UPDATE:
        return "collapse"
    return detection.choice("positive_update", POSITIVE_UPDATES, "collapse")


def state_template_fault(template: str) -> str | None:
    """What is wrong with a transition's state template, or None.

    A template is ``object.state`` where ``object`` may be a role (``{object}``,
    ``{destination}``); the task loader fills the roles in and refuses anything else, so a model
    that a run would refuse is refused when it is read.
    """
    if not template.strip():
        return "a state name must not be empty"
    unknown = [role for role in ROLE_TEMPLATE.findall(template) if role not in ROLES]
    if unknown:
        return (f"unknown role {{{unknown[0]}}} in {template!r} (known: "
                f"{', '.join('{' + r + '}' for r in ROLES)})")
    filled = ROLE_TEMPLATE.sub("x", template)
    if "{" in filled or "}" in filled:
        return f"unbalanced brace in {template!r}"
    obj, dot, state = filled.partition(".")
    if not dot or not obj.strip() or not state.strip():
        return f"{template!r} is not a state name of the form object.state ({{object}}.state)"
    return None


def _state(r: Reader, key: str | int, template: str) -> str:
    fault = state_template_fault(template)
    if fault is not None:
        raise r.fail(fault, key)
    return template


def _read_conditions(r: Reader, key: str) -> tuple[Condition, ...]:
    out = []
    for c in r.items(key, required=False):
        out.append(Condition(_state(c, "state", c.req("state", str)), c.probability("at_least")))
    return tuple(out)


def _read_transition(name: str, r: Reader, override: float | None) -> TransitionSpec:
    effects = []
    targets: set[str] = set()
    for e in r.items("effects"):
        requires = e.opt("requires", list, [])
        sub = Reader(requires, e.file, f"{e.path}.requires")
        for i, req in enumerate(requires):
            if not isinstance(req, str):
                raise InputError(e.file, f"{e.path}.requires[{i}]", "expected a state name")
            _state(sub, i, req)
            if req in requires[:i]:  # a repeated variable the belief engine cannot build
                raise sub.fail(f"state {req!r} is required twice", i)
        state = _state(e, "state", e.req("state", str))
        if state in targets:  # all effects read the state before the action (eq. 27)
            raise e.fail(f"the transition sets state {state!r} twice", "state")
        targets.add(state)
        if override is None:
            success = e.probability("success")
        else:  # still checked, though the override replaces it
            e.probability("success", override)
            success = override
        effects.append(Effect(state, e.req("value", bool), success, tuple(requires)))
    if not effects:
        raise r.fail("a transition needs at least one effect", "effects")
    return TransitionSpec(name, tuple(effects), _read_conditions(r, "goals"),
                          _read_conditions(r, "preconditions"))


def _read_relation(r: Reader) -> Relation:
    kind = r.choice("kind", RELATION_KINDS)
    if kind == "capacity":
        return Relation(kind, penalty=r.probability("penalty"))
    if kind == "exclusivity":
        return Relation(kind, weight=r.positive("weight", allow_zero=False))
    cats = r.req("categories", list)
    if len(cats) != 2 or not all(isinstance(c, str) for c in cats) or cats[0] == cats[1]:
        raise r.fail("expected two different category names", "categories")
    return Relation(kind, categories=(cats[0], cats[1]), same_site=r.positive("same_site"),
                    same_room=r.positive("same_room", 1.0))


def parse_model(data: dict, file: str | Path = "<model>",
                origins: "Mapping[str, str] | None" = None) -> Model:
    """Validate a parsed model document (after `extends` merging) and build a :class:`Model`.

    Args:
        data: the merged document.
        file: the model file (the child of an ``extends`` chain).
        origins: key path (``$.beliefs.structure``) -> the file of the chain that set it, so a
            fault is reported against the file that holds the key.
    """
    r = Reader(data, file, origins=origin_lookup(origins) if origins else None)
    beliefs = r.child("beliefs")
    detection = r.child("detection")
    perception = r.child("perception", required=False) or Reader({}, file, "$.perception")
    sensors = {}
    sensors_r = r.child("sensors")
    for name in sensors_r.names():
        s = sensors_r.child(name)
        sensors[name] = Sensor(s.probability("sensitivity"), s.probability("specificity"))
        if sensors[name].sensitivity + sensors[name].specificity <= 1.0:
            raise s.fail("sensitivity + specificity must exceed 1, or a reading carries no "
                         "information (or the wrong sign)")
    trans_r = r.child("transitions")
    override = trans_r.opt("success_override", float, None)
    if override is not None and not 0.0 <= override <= 1.0:
        raise trans_r.fail(f"probability {override} is outside [0, 1]", "success_override")
    transitions = {}
    for name in trans_r.names():
        if isinstance(trans_r.data[name], dict):
            transitions[name] = _read_transition(name, trans_r.child(name), override)
    planning_r = r.child("planning", required=False) or Reader({}, file, "$.planning")
    d = PlanningWeights()
    planning = PlanningWeights(
        distance_weight=planning_r.positive("distance_weight", d.distance_weight, allow_zero=True),
        probability_weight=planning_r.positive("probability_weight", d.probability_weight, allow_zero=True),
        information_weight=planning_r.positive("information_weight", d.information_weight, allow_zero=True),
        repeat_penalty=planning_r.positive("repeat_penalty", d.repeat_penalty, allow_zero=True),
        relevance_weight=planning_r.positive("relevance_weight", d.relevance_weight, allow_zero=True),
        distance=planning_r.choice("distance", ("geodesic", "euclidean"), d.distance),
        give_up_probability=planning_r.probability("give_up_probability", d.give_up_probability),
        max_inspections_per_object=planning_r.opt("max_inspections_per_object", int,
                                                  d.max_inspections_per_object),
        give_up=planning_r.choice("give_up", ("probability", "cost"), d.give_up),
        absent_probability=planning_r.probability("absent_probability", d.absent_probability),
        task_values=_task_values(planning_r, d.task_values),
        weigh_early=planning_r.opt("weigh_early", bool, d.weigh_early),
    )
    if planning.give_up == "probability":  # settings the probability rule never reads, if set
        for name in ("weigh_early", "absent_probability", "task_value"):  # here (not by a parent)
            here = origins is None or any(f == str(file) and (k == f"$.planning.{name}" or k.startswith(
                f"$.planning.{name}.")) for k, f in origins.items())
            if planning_r.has(name) and here and (name != "weigh_early" or planning.weigh_early):
                raise planning_r.fail('has no effect with give_up = "probability" (only the cost '
                                      'rule weighs; docs/design.md §7.8)', name)
    if planning.max_inspections_per_object < 0:
        raise planning_r.fail("must be 0 (automatic) or more, got "
                              f"{planning.max_inspections_per_object}", "max_inspections_per_object")
    retries_r = r.child("recovery", required=False) or Reader({}, file, "$.recovery")
    dr = RetryModel()
    retries = RetryModel(failure_rate=retries_r.probability("failure_rate", dr.failure_rate),
                         tolerance=retries_r.probability("tolerance", dr.tolerance))
    if not retries.failure_rate < 1.0:
        raise retries_r.fail("a failure rate of 1 means no action ever succeeds; retries could "
                             "not be bounded", "failure_rate")
    if not 0.0 < retries.tolerance < 1.0:
        raise retries_r.fail(f"must lie strictly between 0 and 1, got {retries.tolerance}",
                             "tolerance")
    structure = beliefs.choice("structure", STRUCTURES)
    relations = tuple(_read_relation(x) for x in r.items("relations", required=False))
    if structure == "factorised" and relations:
        raise r.fail("relational factors need structure = \"joint\"", "relations")
    miss = detection.probability("miss_likelihood")  # its ranges: fg_tea.model.checks
    detector = perception.choice("detector", detector_names(), "threshold")
    kind = detector_kind(detector)
    # The model says what the agent assumes; the camera file says what the camera does
    # (docs/design.md §1.3). Keys that used to set the camera from here are refused by name.
    if perception.has("site_association"):
        raise perception.fail(f"moved to the camera file: {CAMERA_KEY_MOVED}", "site_association")
    if detection.has("visibility"):
        raise detection.fail("moved: the agent's assumed curve is [perception.visibility]; "
                             f"{CAMERA_KEY_MOVED}", "visibility")
    # written in this very file (a parent's curve, inherited, is the parent's business)
    curve_here = origins is not None and any(
        k.startswith("$.perception.visibility.") and f == str(file) for k, f in origins.items())
    kind.check_perception(perception, curve_here)
    facing_tolerance = perception.opt("facing_tolerance", bool, False)
    occlusion = perception.opt("occlusion", bool, False)
    for key, on in (("facing_tolerance", facing_tolerance), ("occlusion", occlusion)):
        if on and not kind.company:  # named on the detector: a file that extends a
            # company model and switches the detector is the one at fault
            raise perception.fail(f"\"{detector}\" cannot be combined with {key} = true, which "
                                  "needs the visibility detector (docs/design.md §3.4); set "
                                  f"{key} = false too", "detector")
    assumed_r = perception.child("visibility", required=False)
    detection_curve = (read_curve(assumed_r) if assumed_r is not None
                       else VisibilityCurve() if kind.curve else None)
    viewpoints = r.child("viewpoints", required=False) or Reader({}, file, "$.viewpoints")
    learning = None
    declared_sensors = None
    declared_transitions = None
    learning_r = r.child("learning", required=False)
    if learning_r is not None:
        learning = read_learning(learning_r)
        if learning.detection_active and (facing_tolerance or occlusion):
            raise learning_r.fail("learned detection probabilities (eq. 51) cannot be combined "
                                  "with [perception] facing_tolerance or occlusion yet", "detection")
        learned = apply_to_sensors(learning, sensors, learning_r)
        if learned != sensors:
            declared_sensors = MappingProxyType(dict(sensors))
            sensors = learned
        if learning.counts.transitions:
            declared_transitions = MappingProxyType(dict(transitions))
            transitions = dict(apply_to_transitions(learning, transitions, learning_r))
    floor = beliefs.probability("prior_floor")
    name = r.req("name", str)
    if not name.strip():
        raise r.fail("a model name must not be empty", "name")
    model = Model(
        name=name,
        description=r.opt("description", str, ""),
        structure=structure,
        prior_floor=floor,
        miss_likelihood=miss,
        false_positive_rate=detection.probability("false_positive_rate", 1e-4),
        positive_update=_positive_update(detection),
        min_visible_pixels=perception.opt("min_visible_pixels", int, 25),
        sensors=MappingProxyType(sensors),
        transition_form=trans_r.choice("form", ("full", "direct"), "full"),
        transitions=MappingProxyType(transitions),
        relations=relations,
        planning=planning,
        source=str(file),
        detector=detector,
        detection_curve=detection_curve,
        room_glances=viewpoints.opt("room_glances", bool, False),
        facing_tolerance=facing_tolerance,
        occlusion=occlusion,
        retries=retries,
        learning=learning,
        declared_sensors=declared_sensors,
        declared_transitions=declared_transitions,
    )
    r.finish()
    check_model(model, r)
    return model


def load_model(path: str | Path) -> Model:
    """Load and validate a model TOML file (a path, or the name of a bundled model), or a model program."""
    from fg_tea.common.resources import is_program_ref, resolve_model
    from fg_tea.model.program_file import load_program_model

    if is_program_ref(path):  # a .py file, module:attribute or entry point (docs/design.md §4.8)
        return load_program_model(path, load_model)
    path = Path(resolve_model(path))
    origins: dict[str, str] = {}
    try:
        seen: tuple[Path, ...] = (path.resolve(),)
    except (OSError, RuntimeError):  # a symlink loop
        seen = ()
    return parse_model(load_document(path, seen, origins), path, origins)


def apply_learning(model: "Model", learning: Learning) -> "Model":
    """`model` with `learning` as its experience (sensors updated by eq. 52, transitions by eq. 63),
    for code that learns in memory (the lifelong sweep) rather than through files."""
    from fg_tea.common.inputs import Reader

    where = Reader({}, model.source, "$.learning")
    sensors = apply_to_sensors(learning, _declared_sensors(model), where)
    declared = model.declared_transitions if model.declared_transitions is not None else model.transitions
    if not learning.counts.transitions:
        return replace(model, learning=learning, sensors=MappingProxyType(sensors))
    return replace(model, learning=learning, sensors=MappingProxyType(sensors), declared_transitions=declared,
                   transitions=apply_to_transitions(learning, declared, where))


def _declared_sensors(model: "Model") -> Mapping[str, "Sensor"]:
    """The sensors before any learning was applied (kept on the model for in-memory learning)."""
    return model.declared_sensors if model.declared_sensors is not None else model.sensors
