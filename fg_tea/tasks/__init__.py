"""The task layer: what must happen, in which order, and what can be skipped (docs/design.md §7).

Declarative actions (:mod:`~fg_tea.tasks.actions`), the validated task DAG with statuses and task
relevance [14, 15, 18] (:mod:`~fg_tea.tasks.graph`), task files as data
(:mod:`~fg_tea.tasks.load`) and the executor that skips satisfied goals [19], checks affordances
and belief preconditions [20], applies belief effects [25-27] and recovers from failures
(:mod:`~fg_tea.tasks.executor`). Nothing here imports a simulator.
"""

from fg_tea.tasks.actions import RecoveryPolicy, TaskAction
from fg_tea.tasks.executor import TaskExecutor
from fg_tea.tasks.records import (
    AffordanceError,
    ObjectState,
    PreconditionError,
    RecoveryDecision,
    TaskError,
    Violation,
)
from fg_tea.tasks.graph import STATUSES, TaskGraph
from fg_tea.tasks.load import load_task, parse_task

__all__ = ["AffordanceError", "ObjectState", "PreconditionError", "RecoveryDecision",
           "RecoveryPolicy", "STATUSES", "TaskAction", "TaskError", "TaskExecutor", "TaskGraph",
           "Violation", "load_task", "parse_task"]
