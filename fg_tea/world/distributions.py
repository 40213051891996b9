"""World sampler: hidden truths drawn from a declared generative distribution (docs/design.md §11).

A world distribution is a JSON data file (``scenarios/worlds/*.json``) over one base scenario
(``"base_scenario"``), or over a fresh generated house per world (``"generate": {"rooms": N or
[min, max], "objects": [...]}``; the house of world seed s is ``fg-tea house --rooms R --seed s``
with R drawn uniformly from [min, max] by the world seed, see :mod:`fg_tea.world.housegen`). It
declares how the environment's hidden truth is drawn — never what the agent believes:

- objects are placed one by one, in ``placement.order``;
- each object's site is drawn from ``(1 - v) * prior + v * violation``, where ``prior`` is the
  scenario's affordance prior for its category (eq. 2, the agent's own prior), ``v`` is the
  ``prior_violation`` knob and ``violation`` is ``"inverse"`` (∝ 1 / prior) or ``"uniform"``;
- a ``co_location`` rule puts an object on its anchor's site with probability ``same_site``,
  else in the anchor's room with probability ``same_room`` (drawn within that room), else as above;
- a ``together`` rule draws its objects jointly when the first of them comes in the order: an
  arrangement with every two of them within ``within`` metres weighs ``weight`` times one without
  (:mod:`fg_tea.world.together`, exact);
- a site never receives more objects than its capacity (full sites are removed before drawing);
- an object the base scenario places ``beside`` or ``inside`` another is not drawn: it starts on
  its anchor's drawn site, in the same relation (:mod:`fg_tea.world.relative`);
- task-state truths: a state listed as ``"prior"`` in ``states`` is drawn from the scenario's
  state prior, a state listed as true/false is pinned, and every other state keeps the base
  scenario's hidden truth (so an empty kettle never starts with hot water by accident).

Same distribution, same seed: the same world.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

import numpy as np

from fg_tea.common.errors import InputError
from fg_tea.common.inputs import Reader, read_json, refuse_null
from fg_tea.world.scenario import Scenario, load_scenario, parse_scenario
from fg_tea.world.relative import anchor_site
from fg_tea.world.together import Together, check_positive, draw_together

#: Entropy tag of the random stream that draws a generated world's room count.
_ROOMS_STREAM = 0x726F6F6D73


@dataclass(frozen=True)
class CoLocation:
    """`object` shares `anchor`'s site w.p. same_site, else its room w.p. same_room."""

    object: str
    anchor: str
    same_site: float
    same_room: float


@dataclass(frozen=True)
class GeneratedHouses:
    """Each world draws its own house: `rooms` (inclusive range) and the objects it holds."""

    rooms: tuple[int, int]
    objects: tuple[str, ...]

    def draw(self, seed: int) -> tuple[int, int]:
        """(room count, house seed) of world `seed`; the house seed is the world seed."""
        lo, hi = self.rooms
        if lo == hi:
            return lo, int(seed)
        rng = np.random.default_rng([int(seed), _ROOMS_STREAM])
        return lo + int(rng.integers(hi - lo + 1)), int(seed)


@lru_cache(maxsize=32)
def _generated_house(rooms: int, seed: int, objects: tuple[str, ...], source: str) -> Scenario:
    from fg_tea.world.housegen import generate_house

    return parse_scenario(generate_house(rooms, seed, objects), f"{source} (house seed {seed})")


@dataclass(frozen=True)
class WorldDistribution:
    """A declared distribution over hidden truths of one base scenario, or of generated houses.

    ``base`` is None when ``generate`` is set (every world has its own house).
    """

    name: str
    description: str
    base: Scenario | None
    order: tuple[str, ...]
    prior_violation: float
    violation: str
    co_location: tuple[CoLocation, ...]
    pinned_states: Mapping[str, bool]
    drawn_states: frozenset[str] = frozenset()
    source: str = ""
    generate: GeneratedHouses | None = None
    together: tuple[Together, ...] = ()

    def with_knobs(self, prior_violation: float | None = None, same_site: float | None = None,
                   same_room: float | None = None) -> "WorldDistribution":
        """The same distribution with some knobs changed (for sweeps)."""
        rules = tuple(replace(r, same_site=r.same_site if same_site is None else same_site,
                              same_room=r.same_room if same_room is None else same_room)
                      for r in self.co_location)
        return replace(self, co_location=rules,
                       prior_violation=self.prior_violation if prior_violation is None else prior_violation)

    def parameters(self) -> dict:
        out = {"world": self.name, "prior_violation": self.prior_violation,
               "co_location": [{"object": r.object, "anchor": r.anchor, "same_site": r.same_site,
                                "same_room": r.same_room} for r in self.co_location]}
        if self.together:
            out["together"] = [{"objects": list(r.objects), "within": r.within, "weight": r.weight}
                               for r in self.together]
        if self.generate is not None:
            out["generate"] = {"rooms": list(self.generate.rooms), "objects": list(self.generate.objects)}
        return out

    def house(self, seed: int) -> Scenario:
        """The house of world `seed`: the base scenario, or the generated house of that seed."""
        if self.generate is None:
            assert self.base is not None, "a world has a base scenario or a generator"
            return self.base
        rooms, house_seed = self.generate.draw(seed)
        return _generated_house(rooms, house_seed, self.generate.objects, self.source or self.name)

    def house_columns(self, seed: int) -> dict:
        """Sweep-row columns naming the house of world `seed` (empty for a fixed base scenario)."""
        if self.generate is None:
            return {}
        rooms, house_seed = self.generate.draw(seed)
        house = self.house(seed)
        return {"house_seed": house_seed, "house_rooms": rooms, "house_sites": len(house.sites),
                "house_room_vantages": len(house.room_vantages)}

    def sample(self, seed: int) -> Scenario:
        """Draw one world: the (base or generated) house with new true sites and state truths."""
        rng = np.random.default_rng(seed)
        scenario = self.house(seed)
        sites = scenario.sites
        k = len(sites)
        load = np.zeros(k, dtype=int)
        capacity = np.array([s.capacity if s.capacity is not None else 10 ** 9 for s in sites])
        placed: dict[str, int] = {}
        rules = {r.object: r for r in self.co_location}
        groups = {o: g for g in self.together for o in g.objects}

        def placement_base(name: str) -> np.ndarray:
            spec = scenario.object(name)
            prior = np.array([max(s.affordances.get(spec.category, 0.0), 0.0) for s in sites]) + 1e-9
            prior /= prior.sum()
            alt = np.full(k, 1.0 / k) if self.violation == "uniform" else (1.0 / prior) / (1.0 / prior).sum()
            return (1.0 - self.prior_violation) * prior + self.prior_violation * alt

        following = {s.name for s in scenario.objects if s.relative_to is not None}
        for name in self.order:
            if name in placed or name in following:
                continue  # drawn with its together rule, or placed relative to its anchor
            group = groups.get(name)
            if group is not None:
                drawn = draw_together(group, [s.position for s in sites],
                                      [placement_base(o) for o in group.objects], capacity - load, rng)
                for o, j in zip(group.objects, drawn):
                    placed[o] = j
                    load[j] += 1
                continue
            base = placement_base(name)
            free = load < capacity
            weights = base * free
            rule = rules.get(name)
            u = rng.random()
            if rule is not None and rule.anchor in placed:
                anchor = placed[rule.anchor]
                room = np.array([s.room == sites[anchor].room for s in sites])
                if u < rule.same_site and free[anchor]:
                    weights = np.eye(k)[anchor]
                elif u < rule.same_site + rule.same_room and (weights * room).sum() > 0:
                    weights = weights * room
            if weights.sum() <= 0:
                raise ValueError(f"world {self.name!r}: no site has room left for {name!r}")
            j = int(rng.choice(k, p=weights / weights.sum()))
            placed[name] = j
            load[j] += 1
        sited = [replace(s, true_site=sites[placed[s.name]].name) if s.name in placed else s
                 for s in scenario.objects]
        specs = {s.name: s for s in sited}
        objects = []
        for spec in sited:  # an object placed beside or inside another follows its anchor's site
            spec = replace(spec, true_site=anchor_site(spec.name, specs))
            truth = dict(spec.hidden_state_truth)
            for state, p in spec.state_priors.items():
                full = f"{spec.name}.{state}"
                if full in self.pinned_states:
                    truth[state] = self.pinned_states[full]
                elif full in self.drawn_states:
                    truth[state] = bool(rng.random() < p)
            objects.append(replace(spec, hidden_state_truth=MappingProxyType(truth)))
        return replace(scenario, name=f"{self.name}#{seed}", objects=tuple(objects))


def _read_generate(r: Reader) -> GeneratedHouses:
    from fg_tea.world.housegen import (
        DEFAULT_OBJECTS,
        MAX_ROOMS,
        MIN_ROOMS,
        check_arguments,
    )

    g = r.child("generate")
    raw = g.req("rooms", (int, list))
    bounds = [raw, raw] if isinstance(raw, int) else raw
    if len(bounds) != 2 or not all(isinstance(b, int) and not isinstance(b, bool) for b in bounds):
        raise g.fail(f"expected a room count or [min, max], got {raw!r}", "rooms")
    if not MIN_ROOMS <= bounds[0] <= bounds[1] <= MAX_ROOMS:
        raise g.fail(f"expected room counts with {MIN_ROOMS} <= min <= max <= {MAX_ROOMS}, got {raw!r}", "rooms")
    objects = g.opt("objects", list, list(DEFAULT_OBJECTS))
    try:
        objects = check_arguments(bounds[0], 0, objects)
    except ValueError as exc:
        raise g.fail(str(exc).partition(": ")[2], "objects") from None
    return GeneratedHouses((bounds[0], bounds[1]), objects)


def parse_world(data: object, file: str | Path) -> WorldDistribution:
    r = Reader(data, file)
    if not isinstance(data, dict):
        raise r.fail("a world distribution must be a JSON object")
    refuse_null(data, file, "world distribution")
    generate = None
    if r.has("generate"):
        if r.has("base_scenario"):
            raise r.fail("give either base_scenario or generate, not both", "generate")
        generate = _read_generate(r)
        from fg_tea.world.housegen import OBJECT_TEMPLATES

        base = None
        what = "the generated houses"
        object_names = generate.objects
        declared = {f"{o}.{s}" for o in object_names for s in OBJECT_TEMPLATES[o]["state_priors"]}
    else:
        base_name = r.req("base_scenario", str)
        if not base_name.strip() or len(base_name) > 255 or "\0" in base_name:
            raise r.fail(f"{base_name[:40]!r} does not name a scenario", "base_scenario")
        base_path = Path(file).parent / base_name
        base = load_scenario(base_path if base_path.suffix == ".json" and base_path.is_file() else base_name)
        what = f"scenario {base.name!r}"
        object_names = base.object_names
        declared = {f"{o.name}.{s}" for o in base.objects for s in o.state_priors}
    placement = r.child("placement")
    order = placement.opt("order", list, list(object_names))
    for i, name in enumerate(order):
        if not isinstance(name, str):
            raise InputError(file, f"$.placement.order[{i}]", "expected an object name")
        if name not in object_names:
            raise InputError(file, f"$.placement.order[{i}]", f"object {name!r} is not in {what}")
        if name in order[:i]:
            raise InputError(file, f"$.placement.order[{i}]", f"object {name!r} is listed twice")
    missing = [o for o in object_names if o not in order]
    order = list(order) + missing
    rules: list[CoLocation] = []
    following = {} if base is None else {o.name: o.relative_to for o in base.objects if o.relative_to}
    for c in placement.items("co_location", required=False):
        obj, anchor = c.req("object", str), c.req("anchor", str)
        for key, value in (("object", obj), ("anchor", anchor)):
            if value not in object_names:
                raise c.fail(f"object {value!r} is referenced but not defined in {what}", key)
            if value in following:
                raise c.fail(_follows(value, following[value], what), key)
        if anchor == obj:
            raise c.fail(f"object {obj!r} cannot be its own anchor", "anchor")
        if any(rule.object == obj for rule in rules):
            raise c.fail(f"object {obj!r} already has a co_location rule (one rule per object)", "object")
        if order.index(anchor) > order.index(obj):
            raise c.fail(f"anchor {anchor!r} must be placed before {obj!r} in placement.order", "anchor")
        same_site, same_room = c.probability("same_site"), c.probability("same_room", 0.0)
        if same_site + same_room > 1:
            raise c.fail("same_site + same_room must not exceed 1", "same_room")
        rules.append(CoLocation(obj, anchor, same_site, same_room))
    together: list[Together] = []
    for c in placement.items("together", required=False):
        members = c.req("objects", list)
        if len(members) < 2 or not all(isinstance(m, str) for m in members):
            raise c.fail("expected a list of at least two object names", "objects")
        for m in members:
            if m not in object_names:
                raise c.fail(f"object {m!r} is referenced but not defined in {what}", "objects")
            if m in following:
                raise c.fail(_follows(m, following[m], what), "objects")
            if members.count(m) > 1 or any(m in g.objects for g in together):
                raise c.fail(f"object {m!r} is listed twice (an object is in at most one rule)", "objects")
            if any(rule.object == m for rule in rules):
                raise c.fail(f"object {m!r} already has a co_location rule; a together rule places it", "objects")
        numbers = {}
        for key in ("within", "weight"):
            numbers[key] = float(c.req(key, float))
            fault = check_positive(numbers[key])
            if fault:
                raise c.fail(fault, key)
        together.append(Together(tuple(members), numbers["within"], numbers["weight"]))
    pinned, drawn = {}, set()
    states = r.child("states", required=False)
    if states is not None:
        for key in states.names():
            value = states.data[key]
            if key not in declared:
                raise states.fail(f"state {key!r} is referenced but no object of {what} declares it", key)
            if value == "prior":
                drawn.add(key)
            else:
                pinned[key] = states._check_type(value, bool, key)
    world = WorldDistribution(
        name=r.req("name", str), description=r.opt("description", str, ""), base=base,
        order=tuple(order), prior_violation=placement.probability("prior_violation", 0.0),
        violation=placement.choice("violation", ("inverse", "uniform"), "inverse"),
        co_location=tuple(rules), pinned_states=MappingProxyType(pinned),
        drawn_states=frozenset(drawn), source=str(file), generate=generate, together=tuple(together))
    r.finish()
    return world


def _follows(name: str, relation: tuple[str, str], what: str) -> str:
    """Why a placement rule may not name an object placed relative to another."""
    return (f"object {name!r} is placed {relation[0]} {relation[1]!r} in {what}, so it starts where its "
            "anchor is drawn and no placement rule draws it")


def load_world(path: str | Path) -> WorldDistribution:
    """Load a world distribution (a path, or the name of a bundled one in scenarios/worlds)."""
    from fg_tea.common.resources import resolve_world

    path = resolve_world(path)
    return parse_world(read_json(path), path)
