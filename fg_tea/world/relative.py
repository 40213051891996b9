"""Placing an object relative to another: ``"placement": {"beside": "kettle"}`` or
``{"inside": "mug"}`` in a scenario's object (docs/design.md §8.1).

An object placed relative to an anchor starts on the anchor's site, so its ``true_site`` is the
anchor's (given, it must agree; left out, it is filled in). *Beside* stands it on the free slot
nearest the anchor's (:func:`start_layout`); *inside* puts it in the anchor, as ``INSERT`` would,
so it moves with the anchor and takes no slot of its own. Chains of *beside* are followed; an
anchor that is itself inside another object, a cycle or an object placed relative to itself is
refused in one line. This is environment truth, like ``true_site``: the agent's prior over where
the object starts is its category's, as for every object. A world distribution over a base
scenario keeps each relation: the object follows its anchor's drawn site
(:meth:`fg_tea.world.distributions.WorldDistribution.sample`).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, Sequence

from fg_tea.common.inputs import Reader

#: A :class:`fg_tea.world.scenario.ObjectSpec` (not imported: the scenario module imports this one).
ObjectSpec = Any

#: The relations a placement may state, in the order the file's key is looked for.
RELATIONS = ("beside", "inside")


def read_placement(o: Reader) -> tuple[str, str] | None:
    """``(relation, anchor)`` from an object's optional ``placement``, or None."""
    p = o.child("placement", required=False)
    if p is None:
        return None
    given = [(rel, p.opt(rel, str, None)) for rel in RELATIONS]
    given = [(rel, anchor) for rel, anchor in given if anchor is not None]
    if len(given) != 1:
        raise p.fail(f"expected exactly one of {', '.join(RELATIONS)} (an object's name), got "
                     f"{len(given) or 'none'}")
    return given[0]


def resolve(objects: Sequence[ObjectSpec], readers: Sequence[Reader],
            site_names: set[str]) -> list[ObjectSpec]:
    """Check every relative placement and give each such object its anchor's site.

    Raises:
        InputError: an anchor that is no object, the object itself, inside another object (for
            ``inside``: nothing nests twice), a cycle, a ``true_site`` that is no site or that
            disagrees with the placement.
    """
    specs = {s.name: s for s in objects}
    at = {s.name: r for s, r in zip(objects, readers)}
    for spec in objects:
        r = at[spec.name]
        if spec.relative_to is None:
            if spec.true_site not in site_names:
                raise r.fail(f"site {spec.true_site!r} is referenced but not defined in sites", "true_site")
            continue
        relation, anchor = spec.relative_to
        if anchor not in specs:
            raise r.fail(f"object {anchor!r} is referenced but not defined in objects", f"placement.{relation}")
        if anchor == spec.name:
            raise r.fail(f"object {anchor!r} cannot be placed relative to itself", f"placement.{relation}")
        outer = specs[anchor].relative_to
        if relation == "inside" and outer is not None and outer[0] == "inside":
            raise r.fail(f"{anchor!r} is itself inside {outer[1]!r}; an object goes inside an object "
                         "that stands on a site", f"placement.{relation}")
    resolved = []
    for spec in objects:
        site = anchor_site(spec.name, specs, at[spec.name])
        given = spec.true_site
        if spec.relative_to is not None and given and given != site:
            relation, anchor = spec.relative_to
            raise at[spec.name].fail(f"site {given!r} disagrees with placement {relation} {anchor!r}, "
                                     f"which is on {site!r} (leave true_site out)", "true_site")
        resolved.append(replace(spec, true_site=site))
    return resolved


def anchor_site(name: str, specs: dict, r: "Reader | None" = None) -> str:
    """The site `name` starts on: its own, or its anchor's (followed through every relation)."""
    seen = [name]
    spec = specs[name]
    while spec.relative_to is not None:
        spec = specs[spec.relative_to[1]]
        if spec.name in seen:
            cycle = " -> ".join(seen + [spec.name])
            if r is None:
                raise ValueError(f"placement cycle {cycle}")
            raise r.fail(f"placement cycle {cycle}", "placement")
        seen.append(spec.name)
    return spec.true_site




def start_layout(scenario: Any) -> tuple[dict[str, tuple[str, int]], dict[str, str]]:
    """Where each object of `scenario` (a :class:`~fg_tea.world.scenario.Scenario`) starts:
    ``({object: (site, slot)}, {object: container})``.

    Objects placed without a relation take their site's slots in scenario order (slot k is the
    k-th object of its site: the layout every scenario without relations has). Then each object
    *beside* another takes the free slot nearest its anchor's (slots alternate right and left of
    the site's point: :func:`slot_offset`), the nearer of the two sides first, ties to the lower
    slot; each object *inside* another is in it and takes no slot. Being beside comes first: the
    slot may lie past those the agent's pixel tables cover
    (:meth:`~fg_tea.env.adapter.TruthBackedAdapter.slot_count`), and its model of a look there is
    then a little off, as for any arrangement the model does not expect.
    """
    slots: dict[str, tuple[str, int]] = {}
    inside: dict[str, str] = {}
    taken: dict[str, set[int]] = {}
    for spec in scenario.objects:
        if spec.relative_to is None:
            used = taken.setdefault(spec.true_site, set())
            slots[spec.name] = (spec.true_site, len(used))
            used.add(len(used))
    beside: list[tuple[str, str]] = []  # (object, anchor)
    for spec in scenario.objects:
        if spec.relative_to is not None:
            relation, anchor = spec.relative_to
            if relation == "inside":
                inside[spec.name] = anchor
            else:
                beside.append((spec.name, anchor))
    while beside:  # anchors first: a chain of beside is laid out link by link
        ready = [(name, anchor) for name, anchor in beside if inside.get(anchor, anchor) in slots]
        if not ready:  # resolve() refuses cycles, so this is a fault of fg_tea's own
            raise ValueError("placement: " + ", ".join(n for n, _ in beside) + " cannot be laid out")
        for name, anchor in ready:  # beside an object that is inside another: beside its container
            site, slot = slots[inside.get(anchor, anchor)]
            used = taken.setdefault(site, set())
            chosen = nearest_free_slot(slot, used)
            slots[name] = (site, chosen)
            used.add(chosen)
            beside.remove((name, anchor))
    return slots, inside


def slot_offset(slot: int) -> int:
    """Slot k's position in spacings from the site's point: 0, +1, -1, +2, -2, ..."""
    return (slot + 1) // 2 * (1 if slot % 2 else -1)


def nearest_free_slot(anchor_slot: int, used: set[int]) -> int:
    """The free slot nearest `anchor_slot` in space (ties: the lower slot, so the right side)."""
    free = [k for k in range(max(used, default=-1) + anchor_slot + 3) if k not in used]
    here = slot_offset(anchor_slot)
    return min(free, key=lambda k: (abs(slot_offset(k) - here), k))
