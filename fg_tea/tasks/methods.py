"""Alternative methods: another way to carry out an action whose retries are spent
(docs/design.md §7.6).

An action of a task file may list ``"alternatives"``: each a set of the action's own fields to
change (``verb``, ``object``, ``site``, ``destination``, ``transition``, ``state``, ``sensor``,
``requires_affordance``, ``recovery``, ``description``; never ``id`` or ``depends_on``), e.g. for
``boil_kettle`` (USE the kettle) ``{"verb": "WAIT", "description": "Heat the kettle on the hob"}``.
Each alternative is loaded as the action itself is (the same checks, the model's transition for
it). When the action fails and recovery has nothing left (its retries, or the transient tries of
§7.6, are spent), the executor does not end the episode: it puts the first alternative not yet
tried in the action's place (same id, same dependencies), pending, with a fresh retry count, and
an ``alternative_method`` event records the switch. When every alternative has failed too, the
episode ends stuck as before.
"""

from __future__ import annotations

from typing import Callable

from fg_tea.common.inputs import Reader
from fg_tea.tasks.actions import TaskAction

#: The action field that lists alternative methods.
KEY = "alternatives"
#: Fields an alternative may not change: it is the same node of the graph.
FIXED = ("id", "depends_on", KEY)


def read_alternatives(a: Reader, read_action: Callable[[Reader], tuple[TaskAction, list[str]]]) \
        -> tuple[TaskAction, ...]:
    """The alternatives of the action read by `a`, each built by `read_action` from the action's
    fields with the alternative's over them (faults name ``actions[i].alternatives[k]``)."""
    out = []
    for k, alt in enumerate(a.items(KEY, required=False)):
        if not isinstance(alt.data, dict) or not alt.data:
            raise alt.fail("expected an object with the action fields to change")
        for key in alt.names():  # every key is read here, and checked by read_action below
            if key in FIXED:
                raise alt.fail(f"an alternative cannot change {key!r}: it is the same action, done "
                               "another way", key)
        merged = {**{key: v for key, v in a.data.items() if key != KEY}, **alt.data}
        action, _ = read_action(Reader(merged, a.file, alt.path))
        out.append(action)
    return tuple(out)


def switch(executor, action: TaskAction) -> dict | None:
    """Put the next alternative of `action` in its place (pending, retries reset); return the
    ``alternative_method`` event to log, or None when none is left."""
    graph = executor.graph
    options = graph.alternatives.get(action.id, ())
    k = graph.methods_tried[action.id]
    if k >= len(options):
        return None
    graph.methods_tried[action.id] = k + 1
    new = options[k]
    graph.replace_action(action.id, new)
    graph.set_status(action.id, "pending")
    executor.attempts[action.id] = 0
    executor.transient_failures[action.id] = 0

    def how(a: TaskAction) -> dict:
        return {key: getattr(a, key) for key in ("verb", "object", "site", "destination", "transition")
                if getattr(a, key) is not None}

    return {"event": "alternative_method", "action": action.id, "method": k + 1, "before": how(action),
            "after": how(new), "description": new.description, "remaining": len(options) - k - 1,
            "graph": graph.to_json()}
