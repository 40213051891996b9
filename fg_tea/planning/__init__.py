"""Planning: which object-site inspection is worth doing next? (docs/design.md §6, eqs. (8)-(17))

All planners share one interface (:class:`~fg_tea.planning.base.Planner`) and are built by name
from a model file, so every ablation (docs/design.md §11) is a switch in the TOML, not a code edit:

- ``information_weight = 0`` (w_e), ``relevance_weight = 0`` (lambda) and ``repeat_penalty = 0``
  (w_a) reach the EFE score through :class:`~fg_tea.model.spec.PlanningWeights`;
- ``miss_likelihood`` near 1 weakens negative evidence in the belief and in I(o, j), which the
  planners read from ``belief.model``;
- ``distance = "euclidean"`` selects the distances the caller builds (the planners take any
  :class:`~fg_tea.planning.base.DistanceModel`; :func:`distances_for` picks the right one).

Registry names: ``efe`` (eqs. 10-11 for factorised beliefs, exact mutual information for joint
ones), ``factorised_efe`` (eqs. 10-11 always), ``mi_efe`` (exact mutual information always),
``nearest``, ``greedy``, ``random``, ``optimal``, ``lookahead``, ``exact``, ``near_exact``,
and, when pomdp-py (the optional ``[peers]`` extra) is installed, the peers ``pouct:100``,
``pouct:1000``, ``pomcp:1000``. Families take settings after a colon: ``lookahead:depth=2,width=4``
(:class:`~fg_tea.planning.lookahead.LookaheadSettings`), ``exact:cap=N``,
``near_exact:cap=N,budget=E,restrict=R`` (:class:`~fg_tea.planning.near_exact.NearExactSettings`),
``pouct:N`` and ``pomcp:N`` (N
simulations per decision); :func:`check_planner_name` accepts any well-formed one.
Planners of your own plug in by name without editing the package: an entry point in the group
``fg_tea.planners``, or ``module:attribute`` (:mod:`fg_tea.planning.plugins`); they satisfy the
:class:`~fg_tea.planning.base.Planner` protocol.
"""

from __future__ import annotations

import importlib.util
from typing import Callable, Sequence

import numpy as np

from fg_tea.common.planner_names import planner_help
from fg_tea.model.spec import Model
from fg_tea.planning import plugins
from fg_tea.planning.base import (
    Candidate,
    Decision,
    DistanceModel,
    DistanceTable,
    Planner,
    euclidean_distances,
)
from fg_tea.planning.baselines import (
    GreedyProbabilityPlanner,
    NearestPlanner,
    RandomPlanner,
)
from fg_tea.planning.efe import EFEPlanner, FactorisedEFEPlanner
from fg_tea.planning.exact import ExactPlanner, ExactSettings
from fg_tea.planning.lookahead import LookaheadPlanner, LookaheadSettings
from fg_tea.planning.near_exact import NearExactPlanner, NearExactSettings
from fg_tea.planning.optimal import OptimalPlanner
from fg_tea.planning.plugins import PlannerSpecError
from fg_tea.world.scenario import Scenario


class MutualInformationEFEPlanner(EFEPlanner):
    """EFE with the exact mutual information of eqs. (38)/(42) whatever the belief's structure."""

    name = "mi_efe"

    def __init__(self, weights) -> None:
        super().__init__(weights, information="joint")


def _random(model: Model, rng: np.random.Generator | None) -> Planner:
    if rng is None:
        raise ValueError("planner 'random' needs a numpy.random.Generator (pass rng=...)")
    return RandomPlanner(rng)


_REGISTRY: dict[str, Callable[[Model, np.random.Generator | None], Planner]] = {
    "efe": lambda model, rng: EFEPlanner(model.planning),
    "factorised_efe": lambda model, rng: FactorisedEFEPlanner(model.planning),
    # The exact mutual information of eqs. (38)/(42) whatever the belief's structure, so that
    # belief structure and information gain can be compared as separate factors.
    "mi_efe": lambda model, rng: MutualInformationEFEPlanner(model.planning),
    "nearest": lambda model, rng: NearestPlanner(),
    "greedy": lambda model, rng: GreedyProbabilityPlanner(),
    "random": _random,
    "optimal": lambda model, rng: OptimalPlanner(),
    "lookahead": lambda model, rng: LookaheadPlanner(model.planning),
    "exact": lambda model, rng: ExactPlanner(),
    "near_exact": lambda model, rng: NearExactPlanner(model.planning),
}
if importlib.util.find_spec("pomdp_py") is not None:  # the optional [peers] extra
    _REGISTRY.update({
        "pouct:100": lambda model, rng: _peer("pouct", "100", model, rng),
        "pouct:1000": lambda model, rng: _peer("pouct", "1000", model, rng),
        "pomcp:1000": lambda model, rng: _peer("pomcp", "1000", model, rng),
    })


def _peer(kind: str, spec: str, model: Model, rng: np.random.Generator | None) -> Planner:
    from fg_tea.planning.peers import make_peer  # pomdp-py is optional: import on use
    return make_peer(kind, spec, model, rng)


#: Planner families whose names take settings after a colon: name -> factory(spec, model, rng).
_FAMILIES: dict[str, Callable[[str, Model, np.random.Generator | None], Planner]] = {
    "lookahead": lambda spec, model, rng: LookaheadPlanner(model.planning,
                                                           LookaheadSettings.parse(spec)),
    "exact": lambda spec, model, rng: ExactPlanner(ExactSettings.parse(spec)),
    "near_exact": lambda spec, model, rng: NearExactPlanner(model.planning,
                                                            NearExactSettings.parse(spec)),
    "pouct": lambda spec, model, rng: _peer("pouct", spec, model, rng),
    "pomcp": lambda spec, model, rng: _peer("pomcp", spec, model, rng),
}


#: Most simulations per decision a POUCT/POMCP spec may ask for (about three hours a decision at
#: the measured ~1 ms a simulation; pomdp-py overflows far above it).
MAX_SIMULATIONS = 10_000_000


def peers_installed() -> bool:
    """Whether pomdp-py, the optional ``[peers]`` extra of POUCT and POMCP, is installed."""
    return importlib.util.find_spec("pomdp_py") is not None


def _check_family_spec(family: str, spec: str) -> None:
    if family == "lookahead":
        LookaheadSettings.parse(spec)
        return
    if family == "exact":
        ExactSettings.parse(spec)
        return
    if family == "near_exact":
        NearExactSettings.parse(spec)
        return
    if not (spec.isdigit() and 1 <= int(spec) <= MAX_SIMULATIONS):
        raise ValueError(f"planner {family}:{spec}: the setting is the number of simulations "
                         f"per decision, an integer from 1 to {MAX_SIMULATIONS:,}")
    if not peers_installed():
        from fg_tea.common.install import install_command

        raise ValueError(f"planner {family}:{spec} needs pomdp-py, the optional peers extra: "
                         f"{install_command('peers')}")


def is_family_spec(name: str) -> bool:
    """Whether `name` is ``family:settings`` of a built-in family (``lookahead``, ``pouct``, ...),
    as opposed to a plug-in's ``module:attribute``."""
    family, sep, _ = name.partition(":")
    return bool(sep) and family in _FAMILIES


def check_planner_name(name: str) -> None:
    """Raise ValueError unless `name` is a registered planner or a well-formed family spec."""
    family, sep, spec = name.partition(":")
    if sep and family in _FAMILIES:  # registered shorthands (pouct:100) too: the extra is checked
        _check_family_spec(family, spec)
        return
    if name in _REGISTRY:
        return
    import difflib

    close = difflib.get_close_matches(name, list(_REGISTRY), n=1, cutoff=0.6)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    raise ValueError(f"unknown planner {name!r}{hint} (known: {', '.join(_REGISTRY)}; families "
                     f"{', '.join(f + ':...' for f in _FAMILIES)})")


def planner_names() -> tuple[str, ...]:
    """The registered planner names, in registry order."""
    return tuple(_REGISTRY)


def make_planner(name: str, model: Model, rng: np.random.Generator | None = None) -> Planner:
    """Build a planner by name, configured from the model file.

    Args:
        name: one of :func:`planner_names`, a family spec such as ``lookahead:depth=3`` or
            ``pouct:500``, the name of an entry point in the group ``fg_tea.planners``, or
            ``module:attribute`` (see :mod:`fg_tea.planning.plugins`).
        model: the agent's model; its ``planning`` weights configure the EFE planners.
        rng: the Generator for ``random`` (required there), handed to plug-in factories that
            ask for ``rng``; ignored elsewhere.

    Raises:
        ValueError: ``random`` without a Generator.
        fg_tea.planning.plugins.PlannerSpecError: (a ``ValueError``) an unknown name, or a
            plug-in that cannot be imported or does not satisfy the :class:`Planner` protocol.
    """
    factory = _REGISTRY.get(name)
    if factory is not None:
        return factory(model, rng)
    if is_family_spec(name):
        check_planner_name(name)
        family, _, spec = name.partition(":")
        return _FAMILIES[family](spec, model, rng)
    return plugins.build(name, model, rng, planner_names())


def check_planner(name: str) -> None:
    """Check, without building it, that `name` names a planner (for the CLI and sweep checks).

    Built-in names and well-formed family specs pass at once; a plug-in's module is imported and
    its ``choose`` signature checked (:func:`fg_tea.planning.plugins.check_plugin`).

    Raises:
        PlannerSpecError: unknown name, a malformed family spec, or a plug-in that fails its check.
    """
    if name in planner_names() and not is_family_spec(name):
        return
    if is_family_spec(name):  # lookahead:depth=2, pouct:500: a built-in family, not module:attribute
        try:
            check_planner_name(name)
        except ValueError as exc:
            raise PlannerSpecError(name, str(exc)) from None
        return
    plugins.check_plugin(name, planner_names())


def register_planner(name: str, planner) -> None:
    """Make `planner` available by `name` in this process (``fg.Agent(..., planner=name)``).

    Args:
        name: a new name: not a built-in planner's, and without ``:``.
        planner: a factory (class or callable taking any of ``model`` and ``rng``) or an object
            with a ``choose`` method, as for an entry point (:mod:`fg_tea.planning.plugins`).

    A registration lives in this process only: sweeps that run episodes in worker processes
    (``compare --executor process`` or ``ray``) do not see it; name the planner there by an entry
    point or ``module:attribute`` instead.

    Raises:
        PlannerSpecError: the name is taken or malformed, or the object is not a planner.
    """
    if not isinstance(name, str) or not name.strip() or ":" in name or name in planner_names():
        raise PlannerSpecError(str(name), f"cannot register a planner as {name!r}: use a new "
                               "name without ':' (built-in names are taken)")
    plugins.register(name, planner)


def distances_for(model: Model, scenario: Scenario, agent_xy: Sequence[float],
                  geodesic: DistanceModel | None = None) -> DistanceModel:
    """The distance model the model file asks for (``planning.distance``).

    Args:
        model: the agent's model.
        scenario: the house (vantage points for Euclidean distances).
        agent_xy: the agent's floor position (x, y), metres.
        geodesic: the environment's geodesic distances, required when the model asks for them.

    Raises:
        ValueError: the model asks for geodesic distances and none were supplied.
    """
    if model.planning.distance == "euclidean":
        return euclidean_distances(scenario, agent_xy)
    if geodesic is None:
        raise ValueError(f"model {model.name!r} plans with geodesic distances; pass the "
                         "environment's distance model (or use the euclidean ablation)")
    return geodesic


__all__ = ["Candidate", "Decision", "DistanceModel", "DistanceTable", "Planner", "EFEPlanner",
           "FactorisedEFEPlanner", "MutualInformationEFEPlanner",
           "NearestPlanner", "GreedyProbabilityPlanner", "RandomPlanner",
           "OptimalPlanner", "LookaheadPlanner", "LookaheadSettings", "ExactPlanner", "ExactSettings",
           "NearExactPlanner", "NearExactSettings",
           "euclidean_distances", "distances_for", "make_planner", "planner_names", "planner_help",
           "check_planner_name", "is_family_spec", "check_planner", "register_planner"]
