"""Tasks are data files: load and validate a household task into a :class:`TaskGraph`.

A task file (``scenarios/tasks/NAME.json``) lists declarative actions and their dependencies
(docs/design.md §7.1). Belief effects, goals and preconditions are not written in the task: they
come from the generative model's named transitions (``models/*.toml``: fill, boil, pour, steep,
serve), whose role templates ``{object}`` and ``{destination}`` are filled in from the action.
So the same task runs under every model variant, and the numbers (success probabilities
rho [25-27], goal thresholds [19], precondition thresholds [20]) live in one place.

Format::

    {
      "name": "make_tea",
      "description": "Make a cup of tea at the preparation site",
      "declares_states": {"cupboard": {"open": 0.5}},          # optional, see below
      "actions": [
        {"id": "search_kettle", "verb": "SEARCH", "object": "kettle",
         "recovery": {"max_retries": 3, "exclude_site": true}},
        {"id": "inspect_kettle_water", "verb": "INSPECT", "object": "kettle",
         "state": "contains_water", "sensor": "state", "depends_on": ["search_kettle"]},
        {"id": "fill_kettle", "verb": "FILL", "object": "kettle", "transition": "fill",
         "depends_on": ["inspect_kettle_water"],
         "recovery": {"max_retries": 2, "reinspect": ["{object}.contains_water"]}},
        {"id": "carry_mug", "verb": "NAVIGATE", "object": "mug", "site": "$preparation_site",
         "depends_on": ["pick_mug"]},
        {"id": "pour_hot_water", "verb": "POUR", "object": "kettle", "destination": "mug",
         "transition": "pour", "depends_on": ["carry_kettle", "insert_teabag"]},
        {"id": "boil_kettle", "verb": "USE", "object": "kettle", "transition": "boil",
         "requires_affordance": "heatable", "depends_on": ["fill_kettle"]}
      ]
    }

Action fields:

- ``id`` (required, unique), ``verb`` (required, one of SEARCH INSPECT PICK NAVIGATE PLACE INSERT
  FILL POUR USE WAIT), ``object`` (required, a scenario object), ``description``.
- ``site``: a scenario site, or ``"$preparation_site"`` (the ``preparation_site`` argument of
  :func:`load_task`, else the scenario's). Required for NAVIGATE and PLACE; not allowed for
  SEARCH and INSPECT. Other verbs act where the object is believed to be.
- ``destination``: another scenario object. Required for INSERT and POUR.
- ``transition``: a transition of the model; its templates are filled with object/destination.
- ``state`` (INSPECT only, required): ``"contains_water"`` (a state of the object),
  ``"{object}.contains_water"`` or ``"kettle.contains_water"``; ``sensor`` (INSPECT only) names
  a model sensor, default ``"state"`` (eqs. 23-24).
- ``requires_affordance`` (USE and WAIT only): the affordance the object must have. The other
  verbs have fixed affordance checks (PICK graspable, INSERT container destination, FILL
  fillable, POUR pourable held source and container destination).
- ``goals``, ``preconditions``: extra conditions ``[{"state": "{object}.x", "at_least": 0.9}]``
  appended to the transition's.
- ``depends_on``: ids of actions that must be complete or skipped first (eq. 18).
- ``recovery``: ``{"max_retries": int >= 0, "reinspect": [state templates],
  "exclude_site": bool}`` (docs/design.md §7.6); default: no retry.

Objects can gain states (docs/design.md §2). Every state an action reads or writes must be
declared, either in the scenario object's ``state_priors`` or in the task's ``declares_states``
section (object -> state -> prior q(z = true)); the graph carries the latter and the executor
adds them to the belief with ``BeliefEngine.ensure_state`` when it starts. Declaring at load
time, rather than creating states silently when first used, keeps a misspelt state a load error.

Every fault is an :class:`~fg_tea.common.errors.InputError` naming the task file, the JSON path and
what is wrong; dangling dependencies and cycles name the actions involved.
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

from fg_tea.common.errors import InputError
from fg_tea.common.inputs import Reader, _suggest, read_json, refuse_null
from fg_tea.common.resources import resolve_task
from fg_tea.model.spec import Condition, Effect, Model
from fg_tea.tasks.actions import RecoveryPolicy, TaskAction
from fg_tea.tasks.graph import TaskGraph
from fg_tea.world.interface import VERBS
from fg_tea.world.scenario import Scenario

PREPARATION_SITE = "$preparation_site"

ACTION_FIELDS = ("id", "verb", "object", "site", "destination", "transition", "state", "sensor",
                 "requires_affordance", "goals", "preconditions", "depends_on", "recovery",
                 "description", "alternatives")
RECOVERY_FIELDS = ("max_retries", "reinspect", "exclude_site")

_SITE_REQUIRED = ("NAVIGATE", "PLACE")
_SITE_FORBIDDEN = ("SEARCH", "INSPECT")
_DESTINATION_REQUIRED = ("INSERT", "POUR")
_AFFORDANCE_VERBS = ("USE", "WAIT")
#: The fixed affordance checks of the other verbs (docs/design.md §7.5; TaskExecutor.check).
VERB_AFFORDANCES = {"PICK": ("graspable",), "INSERT": ("container",), "FILL": ("fillable",),
                    "POUR": ("pourable", "container")}
_TEMPLATE = re.compile(r"\{([^{}]*)\}")


class _Context:
    """What the loader checks names against: the scenario, the model and declared states."""

    def __init__(self, model: Model, scenario: Scenario, preparation_site: str | None,
                 declared: dict[str, float]) -> None:
        self.model = model
        self.scenario = scenario
        self.preparation_site = preparation_site
        self.from_argument = preparation_site is not None
        self.declared = declared

    def known_state(self, name: str) -> bool:
        obj, _, state = name.partition(".")
        try:
            spec = self.scenario.object(obj)
        except KeyError:
            return False
        return state in spec.state_priors or name in self.declared


def _fill(template: str, obj: str, destination: str | None, r: Reader, key: str | int,
          where: str) -> str:
    """Fill ``{object}``/``{destination}`` in a state template, or fail naming the field."""
    def sub(match: re.Match) -> str:
        role = match.group(1)
        if role == "object":
            return obj
        if role == "destination":
            if destination is None:
                raise r.fail(f"{where} refers to {{destination}} ({template!r}) but the action "
                             "has no destination", key)
            return destination
        raise r.fail(f"{where} uses unknown role {{{role}}} in {template!r} (known: {{object}}, "
                     "{destination})", key)

    return _TEMPLATE.sub(sub, template)


def _check_state(ctx: _Context, name: str, r: Reader, key: str | int, where: str) -> str:
    obj, dot, state = name.partition(".")
    if not dot or not obj or not state:
        raise r.fail(f"{where}: {name!r} is not a state name of the form object.state", key)
    if obj not in ctx.scenario.object_names:
        raise r.fail(f"{where}: state {name!r} belongs to {obj!r}, which is not an object of "
                     f"scenario {ctx.scenario.name!r}", key)
    if not ctx.known_state(name):
        raise r.fail(f"{where}: state {name!r} is declared neither in the state_priors of object "
                     f"{obj!r} in scenario {ctx.scenario.name!r} nor in the task's "
                     "declares_states", key)
    return name


def _conditions(r: Reader, key: str, obj: str, dest: str | None, ctx: _Context) -> tuple[Condition, ...]:
    out = []
    for c in r.items(key, required=False):
        if not isinstance(c.data, dict):
            raise c.fail("expected an object with state and at_least")
        name = _fill(c.req("state", str), obj, dest, c, "state", key)
        out.append(Condition(_check_state(ctx, name, c, "state", key), c.probability("at_least")))
    return tuple(out)


def _read_site(r: Reader, ctx: _Context) -> str:
    site = r.req("site", str)
    if site == PREPARATION_SITE:
        site = ctx.preparation_site
        if site not in ctx.scenario.site_names:
            raise r.fail(f"{PREPARATION_SITE} is {site!r} (from the preparation_site argument), "
                         f"which is not a site of scenario {ctx.scenario.name!r}", "site")
        return site
    if site.startswith("$"):
        raise r.fail(f"unknown variable {site!r} (known: {PREPARATION_SITE})", "site")
    if site not in ctx.scenario.site_names:
        raise r.fail(f"site {site!r} is not a site of scenario {ctx.scenario.name!r}", "site")
    return site


def _read_recovery(r: Reader, obj: str, dest: str | None, ctx: _Context) -> RecoveryPolicy:
    rec = r.child("recovery", required=False)
    if rec is None:
        return RecoveryPolicy()
    for key in rec.data:
        if key not in RECOVERY_FIELDS:
            raise rec.fail(f"unknown field{_suggest(key, RECOVERY_FIELDS) or ''} (known: "
                           f"{', '.join(RECOVERY_FIELDS)})", key)
    retries = rec.opt("max_retries", int, 0)
    if retries < 0:
        raise rec.fail(f"must be non-negative, got {retries}", "max_retries")
    states = []
    for i, template in enumerate(rec.opt("reinspect", list, [])):
        if not isinstance(template, str):
            raise InputError(rec.file, f"{rec.path}.reinspect[{i}]", "expected a state name")
        sub = Reader(rec.data["reinspect"], rec.file, f"{rec.path}.reinspect")
        states.append(_check_state(ctx, _fill(template, obj, dest, sub, i, "reinspect"), sub, i,
                                   "reinspect"))
    return RecoveryPolicy(retries, tuple(states), rec.opt("exclude_site", bool, False))


def _read_action(r: Reader, ctx: _Context) -> tuple[TaskAction, list[str]]:
    if not isinstance(r.data, dict):
        raise r.fail("an action must be a JSON object")
    for key in r.data:
        if key not in ACTION_FIELDS:
            raise r.fail(f"unknown field{_suggest(key, ACTION_FIELDS)} (known: "
                         f"{', '.join(ACTION_FIELDS)})", key)
    action_id = r.req("id", str)
    if not action_id:
        raise r.fail("an action id must not be empty", "id")
    verb = r.req("verb", str)
    if verb not in VERBS:
        raise r.fail(f"unknown verb {verb!r} (known: {', '.join(VERBS)})", "verb")
    obj = r.req("object", str)
    if obj not in ctx.scenario.object_names:
        raise r.fail(f"object {obj!r} is not an object of scenario {ctx.scenario.name!r} "
                     f"(known: {', '.join(ctx.scenario.object_names)})", "object")

    site = None
    if r.has("site"):
        if verb in _SITE_FORBIDDEN:
            raise r.fail(f"{verb} takes no site: the planner or the object's belief decides", "site")
        site = _read_site(r, ctx)
    elif verb in _SITE_REQUIRED:
        raise r.fail(f"{verb} needs a target site", "site")

    dest = r.opt("destination", str, None)
    if dest is not None:
        if dest not in ctx.scenario.object_names:
            raise r.fail(f"destination {dest!r} is not an object of scenario "
                         f"{ctx.scenario.name!r}", "destination")
        if dest == obj:
            raise r.fail("an object cannot be its own destination", "destination")
    elif verb in _DESTINATION_REQUIRED:
        raise r.fail(f"{verb} needs a destination object", "destination")

    state, sensor = None, None
    if verb == "INSPECT":
        raw = r.req("state", str)
        name = _fill(raw, obj, dest, r, "state", "state") if "{" in raw else \
            (raw if "." in raw else f"{obj}.{raw}")
        state = _check_state(ctx, name, r, "state", "state")
        sensor_name = r.opt("sensor", str, "state")
        if sensor_name not in ctx.model.sensors:
            raise r.fail(f"model {ctx.model.name!r} has no sensor {sensor_name!r} (known: "
                         f"{', '.join(sorted(ctx.model.sensors))})", "sensor")
        sensor = ctx.model.sensors[sensor_name]
    else:
        for key in ("state", "sensor"):
            if r.has(key):
                raise r.fail(f"only INSPECT actions take {key!r}", key)

    effects: tuple[Effect, ...] = ()
    goals: tuple[Condition, ...] = ()
    pre: tuple[Condition, ...] = ()
    transition = r.opt("transition", str, None)
    if transition is not None:
        if verb in ("SEARCH", "INSPECT"):
            raise r.fail(f"{verb} actions observe; they take no transition", "transition")
        if transition not in ctx.model.transitions:
            raise r.fail(f"model {ctx.model.name!r} declares no transition {transition!r} "
                         f"(known: {', '.join(sorted(ctx.model.transitions))})", "transition")
        spec = ctx.model.transitions[transition]
        where = f"transition {transition!r}"

        def concrete(template: str) -> str:
            return _check_state(ctx, _fill(template, obj, dest, r, "transition", where), r,
                                "transition", where)

        effects = tuple(Effect(concrete(e.state), e.value, e.success,
                               tuple(concrete(q) for q in e.requires)) for e in spec.effects)
        # Filled in, two templates can name one state ({object}.x and kettle.x): the belief
        # engine cannot build a factor over a repeated variable (docs/design.md eq. 27).
        targets = [e.state for e in effects]
        for e in effects:
            twice = [q for i, q in enumerate(e.requires) if q in e.requires[:i]]
            if twice or targets.count(e.state) > 1:
                what = "requires" if twice else "sets"
                raise r.fail(f"{where} {what} state {(twice or [e.state])[0]!r} twice for this "
                             "action", "transition")
        goals = tuple(Condition(concrete(c.state), c.at_least) for c in spec.goals)
        pre = tuple(Condition(concrete(c.state), c.at_least) for c in spec.preconditions)
    goals += _conditions(r, "goals", obj, dest, ctx)
    pre += _conditions(r, "preconditions", obj, dest, ctx)

    affordance = r.opt("requires_affordance", str, None)
    if affordance is not None and verb not in _AFFORDANCE_VERBS:
        raise r.fail(f"requires_affordance is for {' and '.join(_AFFORDANCE_VERBS)}; {verb} has "
                     "fixed affordance checks", "requires_affordance")
    if affordance is not None:  # the executor refuses the action on every try: the run is stuck
        have = ctx.scenario.object(obj).affordances
        if affordance not in have:
            holders = [o.name for o in ctx.scenario.objects if affordance in o.affordances]
            others = (f"only {', '.join(map(repr, holders))} of scenario {ctx.scenario.name!r} "
                      "has it") if holders else f"no object of scenario {ctx.scenario.name!r} has it"
            raise r.fail(f"action {action_id!r} ({verb}) needs object {obj!r} to be {affordance!r}, "
                         f"but it affords {', '.join(sorted(have)) or 'nothing'}; {others}",
                         "requires_affordance")

    deps = r.opt("depends_on", list, [])
    for k, dep in enumerate(deps):
        if not isinstance(dep, str):
            raise InputError(r.file, f"{r.path}.depends_on[{k}]", "expected an action id")
    if len(set(deps)) != len(deps):
        raise r.fail("a dependency is listed twice", "depends_on")

    action = TaskAction(
        id=action_id, verb=verb, object=obj, site=site, destination=dest, transition=transition,
        state=state, sensor=sensor, effects=effects, goals=goals, preconditions=pre,
        requires_affordance=affordance, recovery=_read_recovery(r, obj, dest, ctx),
        description=r.opt("description", str, ""))
    return action, list(deps)


def _read_declared(r: Reader, scenario: Scenario) -> dict[str, float]:
    sec = r.child("declares_states", required=False)
    if sec is None:
        return {}
    out = {}
    for obj in sec.names():
        if obj not in scenario.object_names:
            raise sec.fail(f"object {obj!r} is not an object of scenario {scenario.name!r}", obj)
        per = sec.child(obj)
        for state in per.data:
            if "." in state or not state:
                raise per.fail("give the state without its object (\"open\", not "
                               "\"cupboard.open\")", state)
            if state in scenario.object(obj).state_priors:
                raise per.fail(f"state {obj}.{state} is already declared by the scenario; "
                               "its prior comes from there", state)
            out[f"{obj}.{state}"] = per.probability(state)
    return out


@functools.lru_cache(maxsize=1)
def known_affordances() -> frozenset[str]:
    """The affordances some task verb checks (docs/design.md §7.5): the fixed ones of
    :data:`VERB_AFFORDANCES` and every ``requires_affordance`` of the bundled tasks."""
    from fg_tea.common.resources import bundled

    known = {a for names in VERB_AFFORDANCES.values() for a in names}
    for path in bundled("scenarios/tasks", ".json"):
        try:
            data = read_json(path)
        except InputError:
            continue
        for action in data.get("actions", []) if isinstance(data, dict) else []:
            if isinstance(action, dict) and isinstance(action.get("requires_affordance"), str):
                known.add(action["requires_affordance"])
    return frozenset(known)


def _check_object_affordances(r: Reader, actions: list[TaskAction], scenario: Scenario) -> None:
    """Refuse an affordance of an object the task acts on that no task verb checks: neither a
    fixed one, nor a bundled task's or this task's ``requires_affordance`` (docs/design.md §7.5).
    Such an affordance is a misspelling (``graspabel``) that leaves the object without the one
    meant, so an action is refused on every try and the run ends stuck."""
    known = set(known_affordances())
    known |= {a.requires_affordance for a in actions if a.requires_affordance is not None}
    for k, action in enumerate(actions):
        for role in ("object", "destination"):
            name = getattr(action, role)
            if name is None:
                continue
            unknown = sorted(scenario.object(name).affordances - known)
            if unknown:
                raise InputError(r.file, f"{r.path}.actions[{k}].{role}",
                                 f"action {action.id!r}: object {name!r} of scenario "
                                 f"{scenario.name!r} affords {unknown[0]!r}, which no task verb "
                                 f"checks{_suggest(unknown[0], known)} (known: "
                                 f"{', '.join(sorted(known))}; a USE or WAIT action's "
                                 "requires_affordance adds one)")


def parse_task(data: object, model: Model, scenario: Scenario, preparation_site: str | None = None,
               file: str | Path = "<task>") -> TaskGraph:
    """Validate a parsed task document against a model and scenario; build its graph.

    Args:
        data: the parsed JSON document.
        model: supplies transitions (effects, goals, preconditions) and sensors.
        scenario: supplies object, site and state names.
        preparation_site: replaces ``$preparation_site``; default the scenario's.
        file: the file it came from, for error messages.

    Returns:
        The validated :class:`TaskGraph`, every action pending.

    Raises:
        InputError: naming the file, the JSON path and the fault.
    """
    r = Reader(data, file)
    if not isinstance(data, dict):
        raise r.fail("a task must be a JSON object")
    refuse_null(data, file, "task")
    top = ("name", "description", "declares_states", "actions", "substitutes")
    for key in data:
        if key not in top:
            raise r.fail(f"unknown field{_suggest(key, top)} (known: {', '.join(top)})", key)
    declared = _read_declared(r, scenario)
    from fg_tea.beliefs.engine import MAX_STATES

    total = sum(len(o.state_priors) for o in scenario.objects) + len(declared)
    if total > MAX_STATES:
        raise r.fail(f"the scenario's and the task's task states number {total}; an exact belief "
                     f"holds at most {MAX_STATES}", "declares_states")
    ctx = _Context(model, scenario, preparation_site or scenario.preparation_site, declared)
    from fg_tea.tasks.methods import read_alternatives

    actions, deps, alternatives = [], {}, {}
    for a in r.items("actions"):
        action, depends_on = _read_action(a, ctx)
        if action.id in deps:
            raise a.fail(f"duplicate action id {action.id!r}", "id")
        actions.append(action)
        deps[action.id] = depends_on
        if methods := read_alternatives(a, lambda alt: _read_action(alt, ctx)):
            alternatives[action.id] = methods
    if not actions:
        raise r.fail("a task needs at least one action", "actions")
    _check_object_affordances(r, actions, scenario)
    graph = TaskGraph(actions, deps, name=r.req("name", str), description=r.opt("description", str, ""),
                      source=str(file), declared_states=declared)
    graph.alternatives = alternatives
    from fg_tea.tasks.substitutes import read_substitutes

    acted_on = {n for a in actions for n in (a.object, a.destination) if n is not None}
    checked = known_affordances() | {a.requires_affordance for a in actions if a.requires_affordance}
    graph.substitutes = read_substitutes(r, data, acted_on, scenario, frozenset(checked),
                                         lambda doc: parse_task(doc, model, scenario, preparation_site, file))
    r.finish()
    return graph


def load_task(path_or_name: str | Path, model: Model, scenario: Scenario,
              preparation_site: str | None = None) -> TaskGraph:
    """Load and validate a task file (a path, or the name of a bundled task such as ``make_tea``).

    Args:
        path_or_name: ``scenarios/tasks/make_tea.json`` or ``make_tea``.
        model: the agent's generative model (transitions, sensors).
        scenario: the house (objects, sites, declared states).
        preparation_site: replaces ``$preparation_site``; default ``scenario.preparation_site``.

    Raises:
        InputError: naming the file, the JSON path and the fault.
    """
    path = resolve_task(path_or_name)
    return parse_task(read_json(path), model, scenario, preparation_site, path)
