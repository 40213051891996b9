"""Consumables: an object with a count of uses, such as a box holding a few teabags
(docs/design.md §7.6, §8.5).

A scenario object may declare ``"consumable": {"uses": 2, "verb": "PICK"}``: when the episode
starts it holds ``uses`` (an integer >= 0) uses, and each successful action with verb ``verb`` on
it (the object as the action's ``object``) takes one. Taking a teabag from the box is picking it
up, so the teabag box of the bundled ``tea_box_apartment`` is used by PICK. When no use is left,
that action fails in the environment with the reason :data:`USED_UP` and changes nothing.

The count is hidden truth, like ``true_site``: only the environment reads it
(:class:`fg_tea.env.truth.TeaTruth`). The agent learns that an object is used up from the failure
of the action that needed it, and the task decides what to do then (its ``substitutes``,
:mod:`fg_tea.tasks.consumables`).
"""

from __future__ import annotations

from dataclasses import dataclass

from fg_tea.common.inputs import Reader

#: The object field that declares a consumable.
KEY = "consumable"
#: The failure reason (``ActionResult.reason``) of an action on a consumable with no use left.
USED_UP = "used_up"
#: Verbs that can use up an object: the practical verbs but NAVIGATE (walking uses nothing).
CONSUMING_VERBS = ("PICK", "PLACE", "INSERT", "FILL", "POUR", "USE", "WAIT")


@dataclass(frozen=True)
class Consumable:
    """How many uses an object holds at the start (`uses`) and which verb takes one (`verb`)."""

    uses: int
    verb: str

    def to_json(self) -> dict:
        return {"uses": self.uses, "verb": self.verb}


def read_consumable(o: Reader) -> Consumable | None:
    """The ``consumable`` field of the scenario object read by `o`, or None when it has none.

    Raises:
        InputError: naming the file, ``objects[i].consumable.<field>`` and the fault (a count that
            is not an integer or is negative, an unknown verb, an unknown field).
    """
    c = o.child(KEY, required=False)
    if c is None:
        return None
    uses = c.req("uses", int)
    if uses < 0:
        raise c.fail(f"a count of uses must be a non-negative integer, got {uses}", "uses")
    return Consumable(uses, c.choice("verb", CONSUMING_VERBS))
