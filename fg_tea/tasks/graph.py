"""The household task graph: a DAG of declarative actions with statuses (docs/design.md §7.1).

Nodes are :class:`~fg_tea.tasks.actions.TaskAction` values held in a networkx ``DiGraph`` whose
edges run from a dependency to the action that needs it. Insertion order is kept, so that ties
between equally ready actions break deterministically.

Each node has a status: ``pending``, ``active``, ``complete``, ``skipped`` (completed with a
structured skip result because its belief goals held, eq. 19) or ``failed``. A pending action is
ready when every dependency is finished:

    ready(a_i) <=> for all a_k in dep(a_i): status(a_k) in {complete, skipped}         [18]

(the original eq. 18 says "complete", docs/design.md §10 item 8; a skipped action is a completed
one whose result was "already true"). Task relevance of each object's search node biases the search planner:

    r~_o = 1 + N_unfinished_descendants(o)                                               [14]
    r_o  = r~_o / max_o' r~_o'                                                           [15]

where "unfinished" means not complete and not skipped, and the maximum runs over objects whose
search node is unfinished. The graph is validated when it is created: a dependency on an
undefined action and a dependency cycle are :class:`~fg_tea.common.errors.InputError` naming the
offending actions.
"""

from __future__ import annotations

from collections import Counter
from typing import Mapping, Sequence

import networkx as nx

from fg_tea.common.errors import InputError
from fg_tea.tasks.actions import TaskAction
from fg_tea.tasks.substitutes import Substitutes

STATUSES = ("pending", "active", "complete", "skipped", "failed")
FINISHED = ("complete", "skipped")


class TaskGraph:
    """A validated DAG of task actions and their statuses.

    Args:
        actions: the actions, in insertion order (the tie-break order of :meth:`ready`).
        depends_on: action id -> ids of the actions it depends on (missing = none).
        name: task name (``make_tea``).
        description: what the task achieves.
        source: the file it came from, for error messages.
        declared_states: concrete state name -> prior q(z = true) for states the task adds to
            objects beyond the scenario's ``state_priors`` (the executor declares them in the
            belief with ``ensure_state``).

    Raises:
        InputError: duplicate id, a dependency on an undefined action (named), or a cycle
            (printed as ``cycle: a -> b -> a``, each action depending on the next, starting at the
            earliest action). JSON paths follow the task-file layout: ``$.actions[i].depends_on[k]``.
    """

    def __init__(self, actions: Sequence[TaskAction], depends_on: Mapping[str, Sequence[str]],
                 name: str = "task", description: str = "", source: str = "<task>",
                 declared_states: Mapping[str, float] | None = None) -> None:
        self.name = name
        self.description = description
        self.source = str(source)
        self.declared_states = dict(declared_states or {})
        #: the objects that may stand in for one given up, and their actions (set by the loader)
        self.substitutes: Substitutes | None = None
        #: action id -> its alternative methods, and how many of them were put in its place
        self.alternatives: dict[str, tuple[TaskAction, ...]] = {}
        self.methods_tried: Counter[str] = Counter()
        self._g = nx.DiGraph()
        self._order: list[str] = []
        for i, action in enumerate(actions):
            if action.id in self._g:
                raise InputError(self.source, f"$.actions[{i}].id",
                                 f"duplicate action id {action.id!r}")
            self._g.add_node(action.id, action=action, status="pending")
            self._order.append(action.id)
        unknown = set(depends_on) - set(self._order)
        if unknown:
            raise InputError(self.source, "$.actions",
                             f"dependencies given for undefined action(s) {sorted(unknown)}")
        for i, node in enumerate(self._order):
            for k, dep in enumerate(depends_on.get(node, ())):
                if dep not in self._g:
                    raise InputError(self.source, f"$.actions[{i}].depends_on[{k}]",
                                     f"action {node!r} depends on {dep!r}, which is not defined")
                self._g.add_edge(dep, node)
        self._check_acyclic()
        self._index = {n: i for i, n in enumerate(self._order)}

    def _check_acyclic(self) -> None:
        if nx.is_directed_acyclic_graph(self._g):
            return
        rank = {n: i for i, n in enumerate(self._order)}
        for start in self._order:  # the cycle through the earliest action, walked deterministically
            try:
                edges = nx.find_cycle(self._g, source=start)
            except nx.NetworkXNoCycle:
                continue
            # Edges run dependency -> dependant; print in "depends on" order, earliest action first.
            names = list(reversed([u for u, _ in edges]))
            top = names.index(min(names, key=rank.__getitem__))
            names = names[top:] + names[:top]
            text = " -> ".join(names + [names[0]])
            raise InputError(self.source, f"$.actions[{rank[names[0]]}].depends_on",
                             f"cycle: {text} (each action depends on the next)")

    # ------------------------------------------------------------------ structure
    def __len__(self) -> int:
        return len(self._order)

    def __contains__(self, node: str) -> bool:
        return node in self._g

    def __iter__(self):
        return iter(self._order)

    @property
    def ids(self) -> tuple[str, ...]:
        """Action ids in insertion order."""
        return tuple(self._order)

    @property
    def nx_graph(self) -> nx.DiGraph:
        """The underlying networkx graph (edges dependency -> dependant); do not mutate."""
        return self._g

    def action(self, node: str) -> TaskAction:
        """The action with id `node`."""
        try:
            return self._g.nodes[node]["action"]
        except KeyError:
            raise KeyError(f"task {self.name!r} has no action {node!r}") from None

    def actions(self) -> list[TaskAction]:
        """All actions in insertion order."""
        return [self._g.nodes[n]["action"] for n in self._order]

    def dependencies(self, node: str) -> tuple[str, ...]:
        """Ids `node` depends on, in insertion order."""
        return tuple(sorted(self._g.predecessors(node), key=self._index.__getitem__))

    def descendants(self, node: str) -> tuple[str, ...]:
        """Every action that transitively depends on `node`, in insertion order."""
        return tuple(sorted(nx.descendants(self._g, node), key=self._index.__getitem__))

    def ancestors(self, node: str) -> tuple[str, ...]:
        """Every action `node` transitively depends on, in insertion order."""
        return tuple(sorted(nx.ancestors(self._g, node), key=self._index.__getitem__))

    def replace_action(self, node: str, action: TaskAction) -> None:
        """Replace the action of `node` (same id) by `action`, e.g. with another target site."""
        if action.id != node:
            raise ValueError(f"replacement for {node!r} has id {action.id!r}")
        self.action(node)
        self._g.nodes[node]["action"] = action

    def search_nodes(self, obj: str | None = None) -> list[str]:
        """Ids of SEARCH actions (of `obj` only, if given), in insertion order."""
        return [n for n in self._order if self.action(n).verb == "SEARCH"
                and (obj is None or self.action(n).object == obj)]

    # ------------------------------------------------------------------ statuses
    def status(self, node: str) -> str:
        """The status of `node`."""
        self.action(node)
        return self._g.nodes[node]["status"]

    def set_status(self, node: str, status: str) -> None:
        """Set the status of `node` (one of :data:`STATUSES`)."""
        if status not in STATUSES:
            raise ValueError(f"unknown status {status!r} (known: {', '.join(STATUSES)})")
        self.action(node)
        self._g.nodes[node]["status"] = status

    def is_finished(self, node: str) -> bool:
        """True when `node` is complete or skipped."""
        return self.status(node) in FINISHED

    def dependencies_met(self, node: str) -> bool:
        """True when every dependency of `node` is complete or skipped (eq. 18)."""
        return all(self.is_finished(d) for d in self._g.predecessors(node))

    def ready(self) -> list[str]:
        """Pending actions whose dependencies are all complete or skipped, in insertion order."""
        return [n for n in self._order
                if self.status(n) == "pending" and self.dependencies_met(n)]

    def frontier(self) -> list[str]:
        """Ready actions plus active ones (being worked on), in insertion order."""
        return [n for n in self._order
                if self.status(n) in ("pending", "active") and self.dependencies_met(n)]

    @property
    def done(self) -> bool:
        """True when every action is complete or skipped."""
        return all(self.is_finished(n) for n in self._order)

    def status_counts(self) -> dict[str, int]:
        """Number of actions per status (every status listed, zeros included)."""
        counts = Counter(self.status(n) for n in self._order)
        return {s: counts.get(s, 0) for s in STATUSES}

    def to_json(self) -> dict[str, str]:
        """Action id -> status, in insertion order (for logs)."""
        return {n: self.status(n) for n in self._order}

    # ------------------------------------------------------------------ relevance
    def relevance(self) -> dict[str, float]:
        """Task relevance r_o of each object with an unfinished search node (eqs. 14, 15).

        r~_o = 1 + |unfinished descendants of o's unfinished search nodes| (their union, when
        an object has several); r_o = r~_o / max r~. Objects whose search is finished are absent.
        """
        sets: dict[str, set[str]] = {}
        for node in self.search_nodes():
            if self.is_finished(node):
                continue
            obj = self.action(node).object
            sets.setdefault(obj, set()).update(
                d for d in nx.descendants(self._g, node) if not self.is_finished(d))
        raw = {obj: 1 + len(s) for obj, s in sets.items()}
        if not raw:
            return {}
        top = max(raw.values())
        return {obj: r / top for obj, r in raw.items()}

