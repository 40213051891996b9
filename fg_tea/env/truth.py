"""Hidden truth: which tea states really hold, where each object really is, and how actions change them.

This module answers *what is actually the case* behind the agent's beliefs (docs/design.md §1
and §8.5). It holds the simulator-side counterpart of the Bernoulli task states of eq. (21)
(``kettle.contains_water`` ...), the object relations of docs/design.md §8.5 (site, held, contained in),
the deterministic truth effects of §8.5 (fill, boil, pour, steep, serve, and add_milk and
add_sugar for the milk-and-sugar task), and the noisy
binary sensor of eqs. (23, 24) from which the agent's state observations are drawn:

    P(o = 1 | z = 1) = alpha (sensitivity),    P(o = 0 | z = 0) = beta (specificity).

The verb semantics shared by every environment adapter (which action needs what, which failure
reason it reports, the seeded failure injection) are :class:`fg_tea.env.adapter.TruthBackedAdapter`'s.
Nothing here imports a simulator.

Truth is environment-only: agent-side code must never read a :class:`TeaTruth`.
"""

from __future__ import annotations

from typing import Any, Iterable

import numpy as np

from fg_tea.world.scenario import ObjectSpec

EFFECTS = ("fill", "boil", "pour", "steep", "serve", "add_milk", "add_sugar")


def effect_happens(success: "dict[str, float] | Any", effect: str, rng: np.random.Generator) -> bool:
    """Whether an action reported done has its truth `effect` (``EnvConfig.effect_success``):
    always for an effect not named, else with its probability (one draw from `rng`)."""
    p = success.get(effect)
    return p is None or float(rng.random()) < float(p)


def check_effect_success(success: "dict[str, float] | Any") -> None:
    """Raise ValueError unless `success` maps truth effects to probabilities in [0, 1]."""
    for name, p in success.items():
        if name not in EFFECTS or not 0.0 <= float(p) <= 1.0:
            raise ValueError(f"EnvConfig.effect_success: expected a truth effect ({', '.join(EFFECTS)}) "
                             f"-> probability in [0, 1], got {name!r}: {p!r}")


class TeaTruth:
    """The true hidden task states and object relations of one episode.

    Args:
        objects: the scenario's object specs. Each ``hidden_state_truth`` entry becomes the state
            ``"<object>.<state>"``; a state no spec mentions reads False until an effect sets it.
            A ``consumable`` object starts with its count of uses (:meth:`take_use`).
    """

    def __init__(self, objects: Iterable[ObjectSpec]) -> None:
        specs = tuple(objects)
        self.states: dict[str, bool] = {}
        for spec in specs:
            for key, value in spec.hidden_state_truth.items():
                self.states[f"{spec.name}.{key}"] = bool(value)
        self.site_of: dict[str, str | None] = {spec.name: spec.true_site for spec in specs}
        self.held: str | None = None
        self.contained_in: dict[str, str] = {}
        #: consumable object -> uses left (fg_tea.world.consumables); the verb that takes one
        self.uses_left: dict[str, int] = {s.name: s.consumable.uses for s in specs if s.consumable}
        self._used_by: dict[str, str] = {s.name: s.consumable.verb for s in specs if s.consumable}

    # --- consumables ---------------------------------------------------------------------

    def take_use(self, obj: str, verb: str) -> bool:
        """Take one use of `obj` for an action with `verb` that is about to succeed.

        False when `obj` is a consumable used by `verb` with no use left (nothing changes: the
        action fails with ``used_up``); otherwise True, with one use fewer if it is such a
        consumable. Other verbs and other objects use nothing.
        """
        if self._used_by.get(obj) != verb:
            return True
        if self.uses_left[obj] <= 0:
            return False
        self.uses_left[obj] -= 1
        return True

    # --- hidden states -------------------------------------------------------------------

    def get(self, obj: str, state: str) -> bool:
        """True value of ``obj.state``; states never set read False (objects can gain states)."""
        return self.states.get(f"{obj}.{state}", False)

    def set(self, obj: str, state: str, value: bool) -> None:
        """Set ``obj.state``, creating the state if the object did not have it yet."""
        self.states[f"{obj}.{state}"] = bool(value)

    def apply_effect(self, effect: str, obj: str, destination: str | None = None,
                     rng: np.random.Generator | None = None) -> None:
        """Apply a deterministic truth effect (docs/design.md §8.5).

        Args:
            effect: one of ``fill`` (obj gains water), ``boil`` (obj's water becomes hot if it has
                water), ``pour`` (obj's water, hot or not, moves into `destination`; obj is left
                empty and cold), ``steep`` (obj = teabag, destination = mug: the mug's tea brews
                iff the mug holds hot water; the teabag is steeped iff the mug holds water),
                ``serve`` (obj is served), ``add_milk`` (obj = milk: `destination` has milk) and
                ``add_sugar`` (obj = sugar: `destination` has sugar). Adding milk or sugar
                changes no other state: the tea stays brewed and the source is not used up.
            obj: the acted-on object.
            destination: the receiving object for ``pour``, ``steep``, ``add_milk`` and
                ``add_sugar``. For ``steep`` it may be omitted when the teabag is contained in
                the mug (or obj is the mug holding it).
            rng: accepted for adapters whose effects are stochastic; the effects here are
                deterministic, and action failure is injected by the adapter, so it is not drawn.

        Raises:
            ValueError: unknown effect, or a ``pour``, ``add_milk`` or ``add_sugar`` without a
                destination (caller errors).
        """
        del rng  # deterministic effects; see Args
        if effect == "fill":
            self.set(obj, "contains_water", True)
        elif effect == "boil":
            self.set(obj, "water_hot", self.get(obj, "contains_water"))
        elif effect == "pour":
            if destination is None:
                raise ValueError("the pour effect needs a destination object")
            if self.get(obj, "contains_water"):
                self.set(destination, "contains_water", True)
                self.set(destination, "water_hot", self.get(obj, "water_hot"))
            self.set(obj, "contains_water", False)
            self.set(obj, "water_hot", False)
        elif effect == "steep":
            bag, cup = self._steep_pair(obj, destination)
            self.set(cup, "tea_brewed", self.get(cup, "contains_water") and self.get(cup, "water_hot"))
            if bag is not None:
                self.set(bag, "steeped", self.get(cup, "contains_water"))
        elif effect == "serve":
            self.set(obj, "served", True)
        elif effect in ("add_milk", "add_sugar"):
            if destination is None:
                raise ValueError(f"the {effect} effect needs a destination object")
            self.set(destination, "has_milk" if effect == "add_milk" else "has_sugar", True)
        else:
            raise ValueError(f"unknown truth effect {effect!r} (known: {', '.join(EFFECTS)})")

    def _steep_pair(self, obj: str, destination: str | None) -> tuple[str | None, str]:
        if destination is not None:
            return obj, destination
        if obj in self.contained_in:
            return obj, self.contained_in[obj]
        inside = sorted(o for o, c in self.contained_in.items() if c == obj)
        return (inside[0] if inside else None), obj

    def read_state(self, name: str, sensitivity: float, specificity: float,
                   rng: np.random.Generator) -> bool:
        """Draw a noisy binary reading of hidden state `name` [23, 24].

        Args:
            name: ``"<object>.<state>"``.
            sensitivity: alpha = P(reading True | state True), in [0, 1].
            specificity: beta = P(reading False | state False), in [0, 1].
            rng: the episode's generator; exactly one uniform draw per reading.

        Returns:
            The reading.
        """
        if not (0.0 <= sensitivity <= 1.0 and 0.0 <= specificity <= 1.0):
            raise ValueError(f"sensitivity and specificity must lie in [0, 1], got "
                             f"{sensitivity}, {specificity}")
        u = float(rng.random())
        if self.states.get(name, False):
            return u < sensitivity
        return u >= specificity

    # --- relations (docs/design.md §8.5) -----------------------------------------------------

    def contents_of(self, container: str) -> list[str]:
        """Objects directly contained in `container`, sorted by name."""
        return sorted(o for o, c in self.contained_in.items() if c == container)

    def pick(self, obj: str) -> None:
        """`obj` is now held; it leaves its site and any container; its contents travel with it."""
        self.held = obj
        self.contained_in.pop(obj, None)
        self._move_with_contents(obj, None)

    def place(self, obj: str, site: str) -> None:
        """The held `obj` now stands on `site`."""
        if self.held == obj:
            self.held = None
        self._move_with_contents(obj, site)

    def insert(self, obj: str, container: str) -> None:
        """The held `obj` is now inside `container` and shares its site."""
        if self.held == obj:
            self.held = None
        self.contained_in[obj] = container
        self._move_with_contents(obj, self.site_of.get(container))

    def _move_with_contents(self, obj: str, site: str | None) -> None:
        self.site_of[obj] = site
        for inner in self.contents_of(obj):
            self._move_with_contents(inner, site)


