"""World sampler: hidden truths drawn from a declared generative distribution (blueprint 15.3-15.4).

A world distribution is a JSON data file (``scenarios/worlds/*.json``) over one base scenario. It
declares how the environment's hidden truth is drawn — never what the agent believes:

- objects are placed one by one, in ``placement.order``;
- each object's site is drawn from ``(1 - v) * prior + v * violation``, where ``prior`` is the
  scenario's affordance prior for its category (eq. 2, the agent's own prior), ``v`` is the
  ``prior_violation`` knob and ``violation`` is ``"inverse"`` (∝ 1 / prior) or ``"uniform"``;
- a ``co_location`` rule puts an object on its anchor's site with probability ``same_site``,
  else in the anchor's room with probability ``same_room`` (drawn within that room), else as above;
- a site never receives more objects than its capacity (full sites are removed before drawing);
- task-state truths: a state listed as ``"prior"`` in ``states`` is drawn from the scenario's
  state prior, a state listed as true/false is pinned, and every other state keeps the base
  scenario's hidden truth (so an empty kettle never starts with hot water by accident).

Same distribution, same seed: the same world.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

import numpy as np

from fg_tea.errors import InputError, Reader, read_json
from fg_tea.scenario import Scenario, load_scenario


@dataclass(frozen=True)
class CoLocation:
    """`object` shares `anchor`'s site w.p. same_site, else its room w.p. same_room."""

    object: str
    anchor: str
    same_site: float
    same_room: float


@dataclass(frozen=True)
class WorldDistribution:
    """A declared distribution over hidden truths of one base scenario."""

    name: str
    description: str
    base: Scenario
    order: tuple[str, ...]
    prior_violation: float
    violation: str
    co_location: tuple[CoLocation, ...]
    pinned_states: Mapping[str, bool]
    drawn_states: frozenset[str] = frozenset()
    source: str = ""

    def with_knobs(self, prior_violation: float | None = None, same_site: float | None = None,
                   same_room: float | None = None) -> "WorldDistribution":
        """The same distribution with some knobs changed (for sweeps)."""
        rules = tuple(replace(r, same_site=r.same_site if same_site is None else same_site,
                              same_room=r.same_room if same_room is None else same_room)
                      for r in self.co_location)
        return replace(self, co_location=rules,
                       prior_violation=self.prior_violation if prior_violation is None else prior_violation)

    def parameters(self) -> dict:
        return {"world": self.name, "prior_violation": self.prior_violation,
                "co_location": [{"object": r.object, "anchor": r.anchor, "same_site": r.same_site,
                                 "same_room": r.same_room} for r in self.co_location]}

    def sample(self, seed: int) -> Scenario:
        """Draw one world: the base scenario with new true sites and hidden state truths."""
        rng = np.random.default_rng(seed)
        scenario = self.base
        sites = scenario.sites
        k = len(sites)
        load = np.zeros(k, dtype=int)
        capacity = np.array([s.capacity if s.capacity is not None else 10 ** 9 for s in sites])
        placed: dict[str, int] = {}
        rules = {r.object: r for r in self.co_location}
        for name in self.order:
            spec = scenario.object(name)
            prior = np.array([max(s.affordances.get(spec.category, 0.0), 0.0) for s in sites]) + 1e-9
            prior /= prior.sum()
            alt = np.full(k, 1.0 / k) if self.violation == "uniform" else (1.0 / prior) / (1.0 / prior).sum()
            base = (1.0 - self.prior_violation) * prior + self.prior_violation * alt
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
        objects = []
        for spec in scenario.objects:
            truth = dict(spec.hidden_state_truth)
            for state, p in spec.state_priors.items():
                full = f"{spec.name}.{state}"
                if full in self.pinned_states:
                    truth[state] = self.pinned_states[full]
                elif full in self.drawn_states:
                    truth[state] = bool(rng.random() < p)
            objects.append(replace(spec, true_site=sites[placed[spec.name]].name if spec.name in placed
                                   else spec.true_site, hidden_state_truth=MappingProxyType(truth)))
        return replace(scenario, name=f"{self.name}#{seed}", objects=tuple(objects))


def parse_world(data: object, file: str | Path) -> WorldDistribution:
    r = Reader(data, file)
    if not isinstance(data, dict):
        raise r.fail("a world distribution must be a JSON object")
    base_name = r.req("base_scenario", str)
    if not base_name.strip() or len(base_name) > 255 or "\0" in base_name:
        raise r.fail(f"{base_name[:40]!r} does not name a scenario", "base_scenario")
    base_path = Path(file).parent / base_name
    base = load_scenario(base_path if base_path.suffix == ".json" and base_path.is_file() else base_name)
    placement = r.child("placement")
    order = placement.opt("order", list, list(base.object_names))
    for i, name in enumerate(order):
        if not isinstance(name, str):
            raise InputError(file, f"$.placement.order[{i}]", "expected an object name")
        if name not in base.object_names:
            raise InputError(file, f"$.placement.order[{i}]", f"object {name!r} is not in scenario {base.name!r}")
        if name in order[:i]:
            raise InputError(file, f"$.placement.order[{i}]", f"object {name!r} is listed twice")
    missing = [o for o in base.object_names if o not in order]
    order = list(order) + missing
    rules = []
    for c in placement.items("co_location", required=False):
        obj, anchor = c.req("object", str), c.req("anchor", str)
        for key, value in (("object", obj), ("anchor", anchor)):
            if value not in base.object_names:
                raise c.fail(f"object {value!r} is referenced but not defined in scenario {base.name!r}", key)
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
    pinned, drawn = {}, set()
    declared = {f"{o.name}.{s}" for o in base.objects for s in o.state_priors}
    states = r.child("states", required=False)
    if states is not None:
        for key in states.names():
            value = states.data[key]
            if key not in declared:
                raise states.fail(f"state {key!r} is referenced but no object of scenario "
                                  f"{base.name!r} declares it", key)
            if value == "prior":
                drawn.add(key)
            else:
                pinned[key] = states._check_type(value, bool, key)
    world = WorldDistribution(
        name=r.req("name", str), description=r.opt("description", str, ""), base=base,
        order=tuple(order), prior_violation=placement.probability("prior_violation", 0.0),
        violation=placement.choice("violation", ("inverse", "uniform"), "inverse"),
        co_location=tuple(rules), pinned_states=MappingProxyType(pinned),
        drawn_states=frozenset(drawn), source=str(file))
    r.finish()
    return world


def load_world(path: str | Path) -> WorldDistribution:
    """Load a world distribution (a path, or the name of a bundled one in scenarios/worlds)."""
    from fg_tea.resources import _resolve

    path = _resolve(path, "scenarios/worlds", ".json")
    return parse_world(read_json(path), path)
