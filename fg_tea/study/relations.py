"""Co-location weights derived from a world distribution's own placement rules (docs/design.md §12.1).

Which question it answers: what should a joint model's relational factors be for the worlds a
generator draws, with no episode and no result involved? For every (object, anchor) rule of the
distribution, :func:`derive` counts over drawn worlds how often the two true sites are the same
site, the same room or apart, and turns those frequencies into weights with eq. (55):
s = (pi_S / pi_A)(p_A / p_S) and r = (pi_R / pi_A)(p_A / p_R), pi being the world's frequencies
and p those of two independent objects under the agent's location priors, averaged over the
drawn houses. Two objects with one anchor are correlated through it already; a factor between
them derived from their raw co-occurrence would count that twice, so only the stated rules get
factors.

:func:`related_world` writes the worlds of the "number of related objects" axis
(``experiments/compare_at_scale.py --table related``): the five-object houses with the first
n objects of :data:`RELATED_ORDER` placed by the kettle, the rest from their priors.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from fg_tea.common.errors import InputError

#: Objects placed by the kettle, in the order the related-objects axis adds them: the two the
#: bundled milk-and-sugar worlds relate, then the milk and the mug.
RELATED_ORDER = ("teabag", "sugar", "milk", "mug")
ANCHOR = "kettle"
#: First world seed the related-objects table derives its models from: far from every discovery
#: (0..), confirmation (10000..) and proposed confirmation (30000..) set, so no evaluated house
#: informs the weights it is searched with.
DERIVE_FIRST_SEED = 1_000_000


def related_pairs(world) -> list[tuple[str, str]]:
    """(object, anchor) of every co-location rule of the distribution."""
    return [(rule.object, rule.anchor) for rule in world.co_location]


def derive(world, worlds: int, floor: float,
           first_seed: int = 0) -> dict[tuple[str, str], tuple[float, float, list]]:
    """(s, r, [n_S, n_R, n_A]) per related pair, from world seeds first_seed.. first_seed +
    `worlds` - 1 (eq. 55, pooled).

    Args:
        world: a loaded world distribution (:func:`fg_tea.world.distributions.load_world`).
        worlds: worlds drawn.
        floor: the agent's prior floor (``ModelSpec.prior_floor``), as in its location priors.
        first_seed: the first world seed drawn.

    Raises:
        InputError: (``worlds``) a pair that no drawn world put on one site, in one room or
            apart: its weight would be 0 or infinite.
    """
    from fg_tea.beliefs.factors import location_prior
    from fg_tea.beliefs.graph import prior_weights
    from fg_tea.model.learning import relation_base_rates

    pairs = related_pairs(world)
    counts = {p: np.zeros(3) for p in pairs}
    base = {p: np.zeros(3) for p in pairs}
    for seed in range(first_seed, first_seed + worlds):
        scenario = world.sample(seed)
        rooms = [s.room for s in scenario.sites]
        room_of = {s.name: s.room for s in scenario.sites}
        truth = {o.name: o.true_site for o in scenario.objects}
        prior = {o.name: location_prior(o.name, prior_weights(scenario, o.category), floor).table
                 for o in scenario.objects}
        for a, b in pairs:
            if a not in truth or b not in truth:
                continue
            cls = 0 if truth[a] == truth[b] else 1 if room_of[truth[a]] == room_of[truth[b]] else 2
            counts[(a, b)][cls] += 1
            base[(a, b)] += relation_base_rates(prior[a], prior[b], rooms)
    out = {}
    for pair in pairs:
        n, p = counts[pair], base[pair] / max(counts[pair].sum(), 1)
        if not np.all(n > 0):  # a frequency of 0 makes a weight 0 or infinite: not an estimate
            missing = [k for k, c in zip(("on one site", "in one room", "apart"), n) if c == 0]
            raise InputError(getattr(world, "name", "world"), "worlds",
                             f"{pair[0]} ~ {pair[1]}: none of the {worlds} worlds drawn had them "
                             f"{' or '.join(missing)}; draw more worlds to derive their weights")
        pi = n / n.sum()
        out[pair] = (float(pi[0] / pi[2] * p[2] / p[0]), float(pi[1] / pi[2] * p[2] / p[1]),
                     [int(x) for x in n])
    return out


def model_text(world_name: str, worlds: int, weights, capacity: float, command: str,
               name: str = "joint_derived", extends: str = "factorised") -> str:
    """A model file (TOML) extending `extends` with a joint belief, the capacity relation and one
    co-location relation per derived pair; `command` is recorded in its first line."""
    lines = [f"# Written by {command}.",
             f"# Co-location weights derived from {worlds} worlds of `{world_name}` by eq. (55):",
             "# the world's relation frequencies against those of independent objects under the",
             "# agent's priors (docs/design.md §12.1). Counts (same site, same room, apart) per pair",
             "# are in the comments; nothing here was tuned to an episode or a result.",
             f'extends = "{extends}"', f'name = "{name}"',
             f'description = "Joint belief with co-location weights derived from the {world_name} '
             'placement rules (eq. 55)"', "", "[beliefs]", 'structure = "joint"', "",
             "[[relations]]", 'kind = "capacity"', f"penalty = {capacity!r}", ""]
    for (a, b), (s, r, n) in weights.items():
        lines += [f"# {a} ~ {b}: counts {n}", "[[relations]]", 'kind = "co_location"',
                  f'categories = ["{a}", "{b}"]', f"same_site = {round(s, 6)!r}",
                  f"same_room = {round(r, 6)!r}", ""]
    return "\n".join(lines)


def related_world(base: dict[str, Any], count: int, name: str) -> dict[str, Any]:
    """The world-distribution JSON of `base` (a five-object generated world) with exactly the
    first `count` objects of :data:`RELATED_ORDER` placed by the kettle, each with the strength
    of `base`'s first rule (the bundled 0.5 on its site, 0.25 elsewhere in its room); the other
    objects are placed from their priors.

    Raises:
        ValueError: `count` outside 0..4, or `base` without a co-location rule to copy or
            without all five objects.
    """
    if not 0 <= count <= len(RELATED_ORDER):
        raise ValueError(f"related objects: {count} is outside 0..{len(RELATED_ORDER)}")
    world = copy.deepcopy(base)
    placement = world["placement"]
    objects = list(world["generate"]["objects"])
    if not placement.get("co_location") or not set(RELATED_ORDER + (ANCHOR,)) <= set(objects):
        raise ValueError(f"related objects: world {base.get('name')!r} needs the five objects "
                         "and a co-location rule")
    rule = placement["co_location"][0]
    related = list(RELATED_ORDER[:count])
    placement["co_location"] = [{"object": o, "anchor": ANCHOR, "same_site": rule["same_site"],
                                 "same_room": rule["same_room"]} for o in related]
    placement["order"] = [ANCHOR] + related + [o for o in placement["order"]
                                               if o != ANCHOR and o not in related]
    world["name"] = name
    world["description"] = (
        f"{base['name']} with {count} of its objects placed by the kettle "
        f"({', '.join(related) or 'none'}: on its site w.p. {rule['same_site']}, elsewhere in its "
        f"room w.p. {rule['same_room']}); the others from their priors. Written by "
        "experiments/compare_at_scale.py --table related.")
    return world
