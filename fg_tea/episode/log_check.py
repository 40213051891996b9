"""What a log's lines must mean, checked as :func:`fg_tea.episode.log.read_log` reads them.

The one log reader serves every command that reads logs (``explore``, ``learn``, ``render``, the
quality checks), so these checks live once, here. Syntax is not enough: a line is refused (one
:class:`~fg_tea.common.errors.InputError` naming the file, the line and the field) when

- it holds a NUL byte (padding a crash can leave), a duplicate key, a bare ``NaN``, or a string
  with a lone UTF-16 surrogate (``"\\ud800"``: not text, it cannot be printed or written);
- a number is infinite (``Infinity``, ``-Infinity`` or a literal beyond 1.8e308 such as ``1e400``)
  anywhere but as the value of a key of :data:`INFINITE_KEYS` (``distance``, ``cost_per_find``):
  fg_tea writes ``Infinity`` only there, for what cannot be reached or found, never in a seed, a
  pose, a probability or a metric;
- its ``seq`` is not an integer above the previous line's, or the first event is not
  ``episode_start``, or a later one is (one log holds one episode);
- ``event`` is not a kind the log format documents, or a field of that kind has another type
  than docs/design.md §9 gives it (:data:`FIELDS`; a field a log lacks is not checked: older
  logs lack some, and their readers say so).

Each check costs little: duplicate keys are seen by the parser's ``object_pairs_hook``, ``NaN``
by its ``parse_constant``; only a line whose text could hold an infinity or an escaped surrogate
(found by substring searches of the whole text, :func:`suspect_lines`) is walked whole; lists and
objects of plain values (motion, marginals, names) are checked by their element types at C speed.
"""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path
from typing import Any, Callable, Mapping

from fg_tea.common.errors import InputError

#: The keys whose number may be +infinite, the two places fg_tea writes ``Infinity``: the distance
#: to a site that cannot be reached (:meth:`fg_tea.world.navigation.Navigator.distance`) and the
#: metres per find of an object no look can find (``give_up.weighed.cost_per_find``,
#: :func:`fg_tea.agent.give_up.weigh`).
INFINITE_KEYS = frozenset({"distance", "cost_per_find"})
#: How far a probability may stray outside [0, 1] (floats are rounded to 9 decimals when written).
PROBABILITY_SLACK = 1e-6
#: The text of a log mapped so that one substring search finds each thing a line's parsed values
#: must be walked for: every digit becomes 0, ``E`` and ``D`` lower case, ``+`` is dropped (lines
#: stay lines). An infinite number then shows ``Infinity``, an exponent of 100 or more (``e000``)
#: or a run of 200 digits; an escaped surrogate ``\\ud`` (also some other escapes: the walk tells).
#: Plain substring searches cost a few ms per MB; regular expressions for the same, ten times more.
_MAPPING = str.maketrans({**{d: "0" for d in "123456789"}, "E": "e", "D": "d", "+": None})
_INFINITE_TEXT = ("Infinity", "e000", "0" * 200)
_SURROGATE_TEXT = "\\ud"
_NUMBER_TYPES = frozenset({int, float})


class Fault(ValueError):
    """A line's fault, with the path to the field (filled in as the checks unwind)."""

    def __init__(self, fault: str, where: list | None = None) -> None:
        super().__init__(fault)
        self.fault = fault
        self.where: list = where or []


class _Bad(Exception):
    """A value that is not what its field holds; `where` grows as the checks unwind."""

    def __init__(self, expected: str, value: Any) -> None:
        super().__init__(expected)
        self.expected, self.value = expected, value
        self.where: list = []


# ------------------------------------------------------------------------------------ parsing
def _pairs(pairs: list[tuple[str, Any]]) -> dict:
    """A JSON object; a key written twice is refused (the parser would keep only the last)."""
    obj = dict(pairs)
    if len(obj) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise Fault(f"duplicate key {key!r}: each key is written once")
            seen.add(key)
    return obj


def _constant(name: str) -> float:
    """``NaN`` is never written (:func:`fg_tea.episode.log.encode` refuses it); ``Infinity`` is
    read here and its place checked after the line is parsed."""
    if name == "NaN":
        raise Fault("a bare NaN: not a value fg_tea writes")
    return float(name)


def parse_line(line: str) -> Any:
    """One line's JSON value. Raises :class:`Fault` for a duplicate key or a ``NaN``, and
    ``ValueError`` for a line that is not JSON (a partial last line may be one)."""
    return json.loads(line, object_pairs_hook=_pairs, parse_constant=_constant)


def _hits(text: str, needle: str) -> list[int]:
    found, at = [], text.find(needle)
    while at >= 0:
        found.append(at)
        at = text.find(needle, at + 1)
    return found


def _lines_of(text: str, positions: list[int]) -> set[int]:
    """The line numbers (from 1) of character positions in `text`."""
    lines, line, last = set(), 1, 0
    for at in sorted(positions):
        line += text.count("\n", last, at)
        last = at
        lines.add(line)
    return lines


def suspect_lines(text: str) -> tuple[set[int], set[int]]:
    """The lines of `text` whose parsed values must be walked: those that could hold an infinite
    number, and those that could hold a lone surrogate (usually none of either, but for the
    hashes of ``episode_start``, whose hex digits can read like an exponent)."""
    mapped = text.translate(_MAPPING)
    infinite = [at for needle in _INFINITE_TEXT for at in _hits(mapped, needle)]
    return _lines_of(mapped, infinite), _lines_of(mapped, _hits(mapped, _SURROGATE_TEXT))


def check_walked(value: Any, infinite: bool, surrogate: bool) -> None:
    """Walk a parsed line whose text :func:`suspect_lines` named."""
    if infinite:
        _check_finite(value, [])
    if surrogate:
        _check_text(value, [])


_INFINITE = ("an infinite number (Infinity, or a literal beyond 1.8e308): fg_tea writes Infinity only "
             "for a distance or a cost_per_find that nothing reaches")


def _check_finite(value: Any, where: list) -> None:
    if isinstance(value, dict):
        for key, v in value.items():
            if type(v) is float and math.isinf(v):
                if key in INFINITE_KEYS and v > 0:
                    continue  # an unreachable site's distance, an unfindable object's cost
                raise Fault(_INFINITE, [*where, key])
            _check_finite(v, [*where, key])
    elif isinstance(value, list):
        for i, v in enumerate(value):
            if type(v) is float and math.isinf(v):
                raise Fault(_INFINITE, [*where, i])
            _check_finite(v, [*where, i])


def _check_text(value: Any, where: list) -> None:
    def lone(s: str) -> bool:
        try:
            s.encode("utf-8")
        except UnicodeEncodeError:
            return True
        return False

    if isinstance(value, str) and lone(value):
        raise Fault(f"a lone surrogate in {value.encode('utf-8', 'backslashreplace').decode()[:60]!r}: "
                     "not text", where)
    if isinstance(value, dict):
        for key, v in value.items():
            if lone(key):
                raise Fault("a key with a lone surrogate: not text", where)
            _check_text(v, [*where, key])
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _check_text(v, [*where, i])


def field_path(kind: str, where: list) -> str:
    """``kind.key[i].key``: where a fault stands in an event."""
    text = kind
    for part in where:
        text += f"[{part}]" if isinstance(part, int) else f".{part}"
    return text


def refuse(path: str | Path, n: int, exc: Fault, kind: str | None) -> InputError:
    """The one-line error of a line's fault."""
    where = f"line {n}" + (f": {field_path(kind or 'event', exc.where)}" if exc.where else "")
    return InputError(path, where, exc.fault)


# ------------------------------------------------------------------------------------ field types
Check = Callable[[Any], None]


def _describe(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the string {value[:40]!r}"
    return "a list" if isinstance(value, list) else "an object"


def _plain(expected: str, types: frozenset, bounds: tuple[float, float] | None = None) -> Check:
    """A value of one of `types` (within `bounds`, for a number); the check carries both, so a
    list or an object of such values is checked at C speed (:func:`_surely`)."""
    def check(v: Any) -> None:
        if type(v) not in types or (bounds is not None and v is not None and not bounds[0] <= v <= bounds[1]):
            raise _Bad(expected, v)
    check.types, check.bounds, check.expected = types, bounds, expected  # type: ignore[attr-defined]
    return check


def _surely(item: Check, values: Any) -> bool:
    """True when every one of `values` (a list or a dict's values) passes the plain check `item`,
    found without a Python call per value; False means: check them one by one."""
    types = getattr(item, "types", None)
    if types is None or not types.issuperset(map(type, values)):
        return False
    bounds = item.bounds  # type: ignore[attr-defined]
    return bounds is None or not values or (
        type(None) not in types and bounds[0] <= min(values) and max(values) <= bounds[1])


STR = _plain("a string", frozenset({str}))
INT = _plain("an integer", frozenset({int}))
COUNT = _plain("a non-negative integer", frozenset({int}), (0, math.inf))
NUM = _plain("a number", _NUMBER_TYPES)
BOOL = _plain("true or false", frozenset({bool}))
OBJ = _plain("an object", frozenset({dict}))
LIST = _plain("a list", frozenset({list}))
PROB = _plain("a probability in [0, 1]", _NUMBER_TYPES, (-PROBABILITY_SLACK, 1 + PROBABILITY_SLACK))


def maybe(check: Check) -> Check:
    """`check`, or null."""
    types = getattr(check, "types", None)
    if types is not None:
        return _plain(f"{check.expected} or null", types | {type(None)}, check.bounds)  # type: ignore[attr-defined]

    def nullable(v: Any) -> None:
        if v is not None:
            check(v)
    return nullable


def list_of(item: Check, least: int = 0, expected: str | None = None) -> Check:
    """A list of at least `least` values, each passing `item`."""
    what = expected or f"a list{f' of at least {least}' if least else ''}"

    def check(v: Any) -> None:
        if type(v) is not list or len(v) < least:
            raise _Bad(what, v)
        if _surely(item, v):
            return
        for i, x in enumerate(v):
            try:
                item(x)
            except _Bad as bad:
                bad.where.append(i)
                raise
    return check


def numbers(least: int = 0, probabilities: bool = False) -> Check:
    """A list of at least `least` numbers (probabilities in [0, 1] with `probabilities`)."""
    what = "probabilities in [0, 1]" if probabilities else "numbers"
    return list_of(PROB if probabilities else NUM, least,
                   f"a list of {f'at least {least} ' if least else ''}{what}")


def map_of(value: Check) -> Check:
    """An object whose every value passes `value`."""
    def check(v: Any) -> None:
        if type(v) is not dict:
            raise _Bad("an object", v)
        if _surely(value, v.values()):
            return
        for key, x in v.items():
            try:
                value(x)
            except _Bad as bad:
                bad.where.append(key)
                raise
    return check


#: The fields to check, each with the types that settle it without a call (a plain, unbounded one).
_Plan = list[tuple[str, Check, Any]]


def _plan(fields: Mapping[str, Check]) -> _Plan:
    return [(key, item, None if getattr(item, "bounds", None) is not None else getattr(item, "types", None))
            for key, item in fields.items()]


def _check_fields(v: Mapping[str, Any], plan: _Plan) -> None:
    for key, item, types in plan:
        if key in v:
            x = v[key]
            if types is not None and type(x) in types:
                continue
            try:
                item(x)
            except _Bad as bad:
                bad.where.append(key)
                raise


def record(fields: Mapping[str, Check], required: tuple[str, ...] = ()) -> Check:
    """An object whose listed keys, where present, pass their checks (`required` must be present)."""
    plan = _plan(fields)

    def check(v: Any) -> None:
        if type(v) is not dict:
            raise _Bad("an object", v)
        for key in required:
            if key not in v:
                raise _Bad(f"an object with {key!r}", v)
        _check_fields(v, plan)
    return check


def rows(least: int) -> Check:
    """A list of lists of at least `least` numbers each (a motion: one pose per frame), checked
    at C speed; the slow walk only finds where a fault stands."""
    slow = list_of(numbers(least))

    def check(v: Any) -> None:
        if type(v) is not list or (v and (
                set(map(type, v)) != {list} or min(map(len, v)) < least
                or not _NUMBER_TYPES.issuperset(map(type, itertools.chain.from_iterable(v))))):
            slow(v)
    return check


POINT = numbers(2)  # [x, y, ...] in metres
POSE = numbers(3)   # [x, y, yaw]
STRS = list_of(STR)
MARGINALS = map_of(numbers(probabilities=True))  # object -> probability per site
MOTION = rows(3)
TRAVEL = {"distance": NUM, "frames": COUNT, "motion": MOTION}
GRAPH = {"graph": OBJ}
_CANDIDATE = record({"object": STR, "viewpoint": STR, "viewpoint_kind": STR, "site": STR, "distance": NUM,
                     "probability": PROB, "information_gain": NUM, "repeat": INT, "relevance": NUM,
                     "base": NUM, "total": NUM, "information_gain_bound": STR})
_GOAL = record({"state": STR, "belief": PROB, "threshold": PROB})
_FAILED = {"action": STR, "reason": STR, "detail": LIST, "attempt": INT, "retry": BOOL,
           "inspections": STRS, "exclude_site": maybe(STR), "reopened_search": maybe(STR),
           "reopened": STRS, "alternative_site": maybe(STR), "stuck_reason": maybe(STR),
           "site": maybe(STR), "request": OBJ, "placements": OBJ, **GRAPH}

#: Per event kind, the type of every field docs/design.md §9 documents (checked where present).
FIELDS: dict[str, dict[str, Check]] = {
    "episode_start": {
        "scenario": STR, "scenario_file": maybe(STR), "model": STR, "model_file": maybe(STR),
        "structure": STR, "task": maybe(STR), "planner": STR, "seed": INT, "versions": map_of(maybe(STR)),
        "git": maybe(OBJ), "inputs": OBJ, "parameters": OBJ,
        "sites": list_of(record({"name": STR, "room": maybe(STR), "vantage": maybe(POINT), "position": POINT},
                                required=("name", "position")), least=1),
        "viewpoints": list_of(record({"name": STR, "kind": STR, "position": POINT, "sites": STRS,
                                      "room": maybe(STR)}, required=("name", "position"))),
        "objects": STRS, "categories": map_of(STR), "searched": STRS, "graph": OBJ,
        "tasks": list_of(list_of(STR)), "pose": POSE, "world": OBJ,
        "belief": record({"locations": MARGINALS, "states": map_of(PROB)}),
    },
    "activate": {"action": STR},
    "skip": {"action": STR, "goals": list_of(_GOAL), "relation": STR, **GRAPH},
    "decision": {"serving": maybe(STR), "objects": STRS, "relevance": map_of(NUM), "inspected": map_of(INT),
                 "excluded": STRS, "planner": STR, "object": maybe(STR), "viewpoint": maybe(STR),
                 "viewpoint_kind": maybe(STR), "site": maybe(STR), "total": maybe(NUM), "info": OBJ,
                 "candidates": list_of(_CANDIDATE)},
    "observation": {"viewpoint": STR, "viewpoint_kind": STR, "site": STR, "sites_in_view": STRS,
                    "objects": STRS, "detections": map_of(BOOL), "found_at": map_of(STR),
                    "pixel_counts": map_of(NUM), "site_pixel_counts": map_of(map_of(NUM)),
                    "detection_probability": map_of(map_of(PROB)), "resolved": STRS,
                    "before": MARGINALS, "after": MARGINALS, "entropy_before": map_of(NUM),
                    "entropy_after": map_of(NUM), **TRAVEL},
    "confirm_search": {"object": STR, "site": STR, "completed": STRS, "object_before": OBJ,
                       "object_after": OBJ, **GRAPH},
    "state_reading": {"purpose": STR, "executor_event": STR, "state": STR, "value": BOOL,
                      "sensitivity": PROB, "specificity": PROB, "before": PROB, "after": PROB,
                      "site": maybe(STR), "action": STR, "graph_before": OBJ, "graph_after": OBJ, **TRAVEL},
    "action": {"action": STR, "verb": STR, "parameters": OBJ, "outcome": OBJ, "request": OBJ,
               "placements": OBJ, "graph_before": OBJ, "graph_after": OBJ, "objects_before": OBJ,
               "objects_after": OBJ, "belief_before": map_of(PROB), "belief_after": map_of(PROB),
               "transition": maybe(OBJ), **TRAVEL},
    "action_failed": {**_FAILED, **TRAVEL},
    "fail": _FAILED,
    "reopen": {"action": STR, "previous_status": STR, "round": INT, "max_reopenings": INT,
               "trigger": OBJ, "reason": STR, "state": STR, "belief": PROB, "threshold": PROB,
               "needed_by": STR, "upstream": STRS},
    "alternative_site": {"action": STR, "full_site": STR, "site": STR, "retargeted": STRS,
                         "full_sites": STRS},
    "give_up": {"object": STR, "remaining_probability": maybe(PROB), "looks": INT, "threshold": NUM,
                "budget": maybe(INT), "why": STR},
    "substitute": {"object": STR, "substitute": STR, "cause": STR, "retargeted": STRS, "reopened": STRS,
                   "remaining": STRS, **GRAPH},
    "alternative_method": {"action": STR, "method": INT, "before": OBJ, "after": OBJ, "description": STR,
                           "remaining": INT, **GRAPH},
    "stuck": {"reason": STR, **GRAPH},
    "belief": {"locations": MARGINALS, "states": map_of(PROB), "entropy": map_of(NUM)},
    "episode_end": {"reason": STR, "terminated": BOOL, "truncated": BOOL, "goal_conditions": OBJ,
                    "belief": OBJ, "gtsam_agreement": maybe(NUM), "world_truth": OBJ,
                    "yardstick": maybe(OBJ), **GRAPH},
    "metrics": {"success": BOOL, "reason": STR, "actions_total": INT, "actions_complete": INT,
                "actions_skipped": INT, "goal_conditions": OBJ, "goals_true": maybe(BOOL),
                "total_distance": NUM, "search_distance": NUM, "inspections": INT,
                "inspections_until_resolved": map_of(maybe(INT)),
                "entropy_reduction_per_inspection": maybe(NUM), "repeated_sites": INT,
                "skipped_actions": LIST, "state_readings": INT, "failures": INT, "frames": INT,
                "clairvoyant_search_travel": maybe(NUM), "spl": maybe(NUM)},
}


_PLANS = {kind: _plan(fields) for kind, fields in FIELDS.items()}


def check_event(event: Any, previous: Mapping | None) -> str:
    """Check one parsed line against the log format and the line before it (None: it is the
    first); return its kind. Raises ``Fault`` naming the field."""
    if type(event) is not dict or type(event.get("event")) is not str:
        raise Fault("not an event (a JSON object with 'event')")
    kind = event["event"]
    if previous is None and kind != "episode_start":
        raise Fault(f"not an fg_tea episode log: it starts with episode_start, not {kind[:40]!r}", ["event"])
    fields = FIELDS.get(kind)
    if fields is None:
        raise Fault(f"{kind[:40]!r} is not an event kind of the log format (docs/log-format.md)", ["event"])
    if previous is not None and kind == "episode_start":
        raise Fault("a second episode_start: one log holds one episode", ["event"])
    seq = event.get("seq")
    if type(seq) is not int or seq < 0:
        raise Fault(f"expected a non-negative integer, got {_describe(seq)}", ["seq"])
    if previous is not None:
        if seq <= previous["seq"]:
            raise Fault(f"{seq} after {previous['seq']}: seq rises strictly from episode_start", ["seq"])
    if "frame" in event and (type(event["frame"]) is not int or event["frame"] < 0):
        raise Fault(f"expected a non-negative integer, got {_describe(event['frame'])}", ["frame"])
    try:
        _check_fields(event, _PLANS[kind])
    except _Bad as bad:
        raise Fault(f"expected {bad.expected}, got {_describe(bad.value)}", list(reversed(bad.where))) from None
    return kind
