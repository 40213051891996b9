"""The ranges a model file's numbers must lie in for the model to mean something.

:func:`~fg_tea.model.spec.parse_model` reads each key with its type and its plain range (a
probability in [0, 1], a weight >= 0). Some values inside those ranges still make the model
degenerate: a run divides by zero, or a look, a detection or the prior stops carrying any
information, or a probability so small it stands for zero where zero is refused. This module
refuses them once the model is built, each in one line naming the file that set the key, the key
and the fault (docs/guide/input-files.md lists every range).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from fg_tea.common.errors import InputError

if TYPE_CHECKING:
    from fg_tea.common.inputs import Reader

#: Smallest absent_probability accepted. Zero is refused (the cost rule would never give up a
#: search for an object that is not there); a rate below one in 10^12 houses is zero in all but
#: name: no run of episodes could tell the two apart, and the give-up threshold built from it,
#: p a / ((1 - p)(1 - a)), is then below any remaining probability a search reaches.
MIN_ABSENT_PROBABILITY = 1e-12
#: The keys of ``[transitions]`` that are settings, not transitions.
TRANSITIONS_SETTINGS = ("form", "success_override")


def _fail(r: "Reader", path: str, fault: str) -> InputError:
    return InputError(r.file_of(path), path, fault)


def check_model(model: Any, r: "Reader") -> None:
    """Refuse a model whose values are in their plain ranges but make it degenerate.

    Args:
        model: the model just built from the document (a :class:`~fg_tea.model.spec.Model`; not
            imported here, as spec.py calls this module).
        r: the reader of the whole (merged) document; faults name the file that set the key.

    Raises:
        InputError: the first fault, naming file, key path and what is wrong.
    """
    floor = model.prior_floor
    if not floor > 0.0:
        raise _fail(r, "$.beliefs.prior_floor", f"must be positive, got {floor:g}: the prior floor "
                    "keeps every site possible (eq. 2)")
    if not floor < 1.0:
        raise _fail(r, "$.beliefs.prior_floor", f"must be below 1, got {floor:g}: eq. 4 collapses "
                    "a detection onto the site seen with weight 1 against the floor elsewhere, so "
                    "a floor of 1 or more makes a detection say nothing")
    mu = model.miss_likelihood
    if not mu > 0.0:
        raise _fail(r, "$.detection.miss_likelihood", f"must be positive, got {mu:g}: a miss "
                    "likelihood of 0 makes a missed detection impossible; use a small positive value")
    if not mu < 1.0:
        raise _fail(r, "$.detection.miss_likelihood", f"must be below 1, got {mu:g}: a miss "
                    "likelihood of 1 says a look never sees an object that is there, so no look "
                    "could find or rule out anything (eqs. 5-6)")
    fp = model.false_positive_rate
    if not fp < 1.0 - mu:
        raise _fail(r, "$.detection.false_positive_rate",
                    f"must be below 1 - miss_likelihood = {1.0 - mu:g}, got {fp:g} (a detection at "
                    "a site must be likelier when the object is there than when it is elsewhere, "
                    "or seeing it is no evidence it is there; eq. 31)")
    transitions = r.data.get("transitions") if isinstance(r.data, dict) else None
    for name, value in (transitions.items() if isinstance(transitions, dict) else ()):
        if name not in TRANSITIONS_SETTINGS and not isinstance(value, dict):
            raise _fail(r, f"$.transitions.{name}", f"expected a table of effects (a transition "
                        f"[transitions.{name}]), got {type(value).__name__} {value!r:.40}; the "
                        f"settings of [transitions] are {', '.join(TRANSITIONS_SETTINGS)}")
    planning = model.planning
    if not planning.give_up_probability < 1.0:
        raise _fail(r, "$.planning.give_up_probability",
                    f"must be below 1, got {planning.give_up_probability:g} (the give-up rule "
                    "divides by 1 - p, and a search would be given up before its first look; "
                    "docs/design.md §7.8)")
    absent = planning.absent_probability
    if not MIN_ABSENT_PROBABILITY <= absent < 1.0:
        raise _fail(r, "$.planning.absent_probability",
                    f"must be at least {MIN_ABSENT_PROBABILITY:g} and below 1, got {absent:g} (the "
                    "chance an object cannot be found at all: 1 says no object is ever there, and "
                    f"below {MIN_ABSENT_PROBABILITY:g} it stands for 0, a search never given up; "
                    "docs/design.md §7.8)")
    for i, relation in enumerate(model.relations):
        if relation.kind == "co_location" and not all(c.strip() for c in relation.categories):
            raise _fail(r, f"$.relations[{i}].categories",
                        f"a category name must not be empty, got {list(relation.categories)!r} (a "
                        "relation naming no category adds no factor, silently)")
    fault = model.detector_kind.check_model(r.data)
    if fault is not None:
        raise _fail(r, *fault)

__all__ = ["MIN_ABSENT_PROBABILITY", "check_model"]
