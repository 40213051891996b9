"""Substitutes: another object that serves the same role, searched when the first is given up
(docs/design.md §7.6).

A task file may declare, at its top level, ``"substitutes": {"teabag": ["tea_tin"]}``: when the
search for the teabag is given up (§7.8), the executor does not end the episode but switches to
the first substitute not yet tried. Every unfinished action that names the teabag as its object or
destination is replaced by the same action built for the substitute (the task document with the
name changed, loaded as the task itself is: effects, goals and preconditions are the model's for
the substitute), its declared states enter the belief, and a ``substitute`` event records the
switch in the log. Finished actions keep what they did. When every substitute is given up too,
the episode ends as before (``not_found``). The same switch serves an object found used up (a
consumable with no use left, :mod:`fg_tea.tasks.consumables`); then the finished actions that
fetched it are done again for the substitute.

A substitute must be an object of the scenario that the task does not already act on, different
from the original, listed once, and afford everything the original affords that a task verb
checks (so it can serve the same role); each fault is one line naming the field.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Collection

from fg_tea.tasks.actions import TaskAction

#: The top-level key of a task file that declares substitutes.
KEY = "substitutes"


@dataclass
class Substitutes:
    """The substitutes a task declares, and the actions each switch puts in place.

    Attributes:
        candidates: object -> its substitutes, in the order they are tried.
        actions: (object, substitute) -> {action id: the action built for the substitute}, for
            every action that names the object.
        declared: (object, substitute) -> the task's declared states for the substitute.
        switched: (object, substitute) pairs switched to so far, in order.
    """

    candidates: dict[str, tuple[str, ...]] = field(default_factory=dict)
    actions: dict[tuple[str, str], dict[str, TaskAction]] = field(default_factory=dict)
    declared: dict[tuple[str, str], dict[str, float]] = field(default_factory=dict)
    switched: list[tuple[str, str]] = field(default_factory=list)

    def original(self, obj: str) -> str:
        """The object `obj` stands in for (itself if it is no substitute)."""
        for first, second in reversed(self.switched):
            if second == obj:
                return self.original(first)
        return obj

    def next_for(self, obj: str) -> str | None:
        """The first substitute of `obj`'s original not yet tried, or None."""
        root = self.original(obj)
        tried = {root} | {s for o, s in self.switched if self.original(o) == root}
        return next((s for s in self.candidates.get(root, ()) if s not in tried), None)


def renamed(document: dict, old: str, new: str) -> dict:
    """The task document with object `old` called `new` in every action: an ``object`` or
    ``destination`` equal to it, and a concrete state name of it (``old.state``)."""
    def swap(value: Any) -> Any:
        if isinstance(value, str):
            if value == old:
                return new
            return new + value[len(old):] if value.startswith(old + ".") else value
        if isinstance(value, list):
            return [swap(v) for v in value]
        if isinstance(value, dict):
            return {k: (v if k in ("id", "description", "depends_on") else swap(v)) for k, v in value.items()}
        return value

    out = {k: v for k, v in document.items() if k != KEY}
    out["actions"] = [swap(a) for a in document.get("actions", [])]
    if isinstance(document.get("declares_states"), dict):
        out["declares_states"] = swap(document["declares_states"])
    return out


def read_substitutes(r, data: dict, acted_on: set[str], scenario, checked: frozenset[str],
                     build: Callable[[dict], Any]) -> Substitutes:
    """Read ``substitutes`` (a :class:`fg_tea.common.inputs.Reader` `r` over the task document
    `data`) and build each switch's actions with `build` (the task's own loader on the renamed
    document; its faults name the substitute's object).

    Args:
        acted_on: objects the task's actions name (object or destination).
        scenario: the house whose objects substitutes are.
        checked: the affordances some task verb checks.
    """
    out = Substitutes()
    for obj, names in r.mapping(KEY, list).items():  # object -> a list (one schema for every entry)
        where = f"{KEY}.{obj}"
        if obj not in acted_on:
            raise r.fail(f"object {obj!r} is not an object this task acts on", where)
        if not names:
            raise r.fail("expected a list of at least one object name", where)
        for k, sub in enumerate(names):
            at = f"{where}[{k}]"
            if not isinstance(sub, str):
                raise r.fail("expected an object name", at)
            if sub not in scenario.object_names:
                raise r.fail(f"object {sub!r} is referenced but not defined in scenario {scenario.name!r} "
                             f"(known: {', '.join(scenario.object_names)})", at)
            why = ("the object itself" if sub == obj else "listed twice" if sub in names[:k]
                   else "already acted on by this task" if sub in acted_on else None)
            if why is not None:
                raise r.fail(f"object {sub!r} is {why}; a substitute is another object", at)
            missing = sorted((scenario.object(obj).affordances & checked) - scenario.object(sub).affordances)
            if missing:
                raise r.fail(f"object {sub!r} does not afford {', '.join(missing)}, which {obj!r} "
                             "affords and the task checks, so it cannot serve the same role", at)
            graph = build(renamed(data, obj, sub))
            out.actions[(obj, sub)] = {a.id: a for a in graph.actions()
                                       if sub in (a.object, a.destination)}
            out.declared[(obj, sub)] = dict(graph.declared_states)
        out.candidates[obj] = tuple(names)
    return out


def switch(executor, obj: str, cause: str = "given_up", reopen: Collection[str] = ()) -> dict | None:
    """Switch the task to the next substitute of `obj`, if any: after its search was given up
    (`cause` ``"given_up"``), or after it was found used up (``"used_up"``,
    :mod:`fg_tea.tasks.consumables`).

    Replaces every unfinished action that names `obj` with the substitute's, and the actions of
    `reopen` that name it too, whatever their status, which become pending with their attempts
    cleared (the chain that fetched a used-up object is done again for the substitute); declares
    the substitute's states in the belief, and appends a ``substitute`` event (returned). None
    when `obj` has no substitute left (the executor then ends the episode as before).
    """
    subs: Substitutes | None = getattr(executor.graph, "substitutes", None)
    if subs is None:
        return None
    new = subs.next_for(obj)
    if new is None:
        return None
    root = subs.original(obj)
    graph = executor.graph
    retargeted, reopened = [], []
    for node, action in subs.actions[(root, new)].items():
        current = graph.action(node)
        if (node in reopen or not graph.is_finished(node)) and obj in (current.object, current.destination):
            graph.replace_action(node, action)
            retargeted.append(node)
            if node in reopen:
                graph.set_status(node, "pending")
                executor.attempts.pop(node, None)
                executor.transient_failures.pop(node, None)
                reopened.append(node)
    for state, prior in subs.declared[(root, new)].items():
        executor.belief.ensure_state(state, prior)
    subs.switched.append((obj, new))
    event = {"event": "substitute", "object": obj, "substitute": new, "cause": cause,
             "retargeted": retargeted, "reopened": reopened,
             "remaining": [s for s in subs.candidates[root] if s != new and s not in
                           {b for _, b in subs.switched}],
             "graph": graph.to_json()}
    executor.events.append(event)
    return event
