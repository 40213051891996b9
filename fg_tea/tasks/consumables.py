"""A consumable that runs out: what the executor does when an action finds its object used up
(docs/design.md §7.6).

A scenario object may hold a count of uses (``"consumable"``, :mod:`fg_tea.world.consumables`): a
box of teabags is used by PICK, one teabag each time. The count is hidden truth; the agent never
reads it. It learns that the object is used up as it learns any failure: the action fails in the
environment with the reason ``used_up``. Then, in :meth:`fg_tea.tasks.recovery.TaskRecovery.fail`:

- no retry: the object stays used up, so trying again is the same failure;
- when the task declares substitutes for the object (``"substitutes": {"teabag_box":
  ["tea_tin"]}``, :mod:`fg_tea.tasks.substitutes`), the first not yet tried takes its place, as
  after a search given up, and a ``substitute`` event with ``cause`` ``"used_up"`` records the
  switch. Besides the unfinished actions that name the object, the finished ones that fetched it
  for the failed action (its ancestors naming the object, such as its search) are reopened for
  the substitute, and so is the failed action: the substitute is searched, fetched and used as the
  first object was. The action is pending again (the decision is a retry);
- otherwise the episode ends stuck, ``"<id> failed <n> times: used_up (<object> is used up and
  no substitute is left for it)"`` (or the action's alternative methods are tried first,
  :mod:`fg_tea.tasks.methods`).

A used-up object the agent already holds stays in its hand: reopening the substitute's PICK then
fails its free-hands check. The bundled example uses the teabag box with PICK, which fails
before the box is taken.
"""

from __future__ import annotations

from fg_tea.tasks.actions import TaskAction
from fg_tea.tasks.substitutes import switch
from fg_tea.world.consumables import USED_UP

__all__ = ["USED_UP", "run_out", "stuck_note"]


def run_out(executor, action: TaskAction) -> dict | None:
    """`action` failed because its object is used up: switch to the object's next substitute,
    reopening the failed action and its finished ancestors that name the object. Returns the
    ``substitute`` event, or None when no substitute is left (nothing changes)."""
    obj, graph = action.object, executor.graph
    fetched = [n for n in graph.ancestors(action.id)
               if graph.is_finished(n) and obj in (graph.action(n).object, graph.action(n).destination)]
    return switch(executor, obj, cause=USED_UP, reopen=(*fetched, action.id))


def stuck_note(action: TaskAction) -> str:
    """The end of the stuck reason when no substitute is left for the used-up object."""
    return f" ({action.object} is used up and no substitute is left for it)"
