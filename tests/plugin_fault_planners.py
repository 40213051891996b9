"""Plug-in planners that misbehave, for tests/test_plugin_faults.py (``plugin_fault_planners:X``).

Importable by the tests through ``sys.path`` (in-process) or ``PYTHONPATH`` (worker processes).
Each one breaks the Planner contract (fg_tea.planning.base.Planner) in one way.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from fg_tea.planning import Candidate, Decision


def _candidates(belief, objects, relevance, distances, inspected, excluded):
    obj = objects[0]
    q = belief.location_map(obj)
    sites = [s for s in belief.sites if s not in excluded]
    return obj, tuple(Candidate(obj, s, distances.from_agent(s), q[s], 0.0, int(inspected.get(s, 0)),
                                float(relevance[obj]), -q[s], -q[s]) for s in sites)


class _Base:
    def check(self, belief, objects):
        return None

    def choose(self, belief, objects, relevance, distances, inspected, excluded_sites=frozenset(),
               views=None):
        obj, cands = _candidates(belief, objects, relevance, distances, inspected, excluded_sites)
        return self.decide(obj, cands)


class Outside(_Base):
    """Chooses the first site but leaves it out of its candidates."""

    def decide(self, obj, cands):
        return Decision(obj, cands[0].viewpoint, cands[0].total, cands[1:], "outside")


class Empty(_Base):
    """A decision with no candidates at all."""

    def decide(self, obj, cands):
        return Decision(obj, cands[0].viewpoint, cands[0].total, (), "empty")


class NaNTotal(_Base):
    """A decision whose total is NaN."""

    def decide(self, obj, cands):
        return Decision(obj, cands[0].viewpoint, math.nan, cands, "nan_total")


class NaNCandidate(_Base):
    """A decision with a candidate whose distance is NaN."""

    def decide(self, obj, cands):
        first = cands[0]
        bad = Candidate(first.object, first.viewpoint, math.nan, first.probability, 0.0, 0,
                        first.relevance, first.base, first.total)
        return Decision(obj, first.viewpoint, first.total, (bad,) + cands[1:], "nan_candidate")


class NotADecision(_Base):
    """Returns a dict, not a Decision."""

    def decide(self, obj, cands):
        return {"object": obj, "viewpoint": cands[0].viewpoint}


class Raises:
    """Raises an error of its own in choose."""

    def choose(self, belief, objects, relevance, distances, inspected, excluded_sites=frozenset(),
               views=None):
        raise RuntimeError("my planner broke")


class Stop(BaseException):
    """Neither an Exception nor SystemExit."""


class RaisesBase:
    """Raises a BaseException subclass in choose."""

    def choose(self, belief, objects, relevance, distances, inspected, excluded_sites=frozenset(),
               views=None):
        raise Stop("stopped")


def factory_raises_base():
    """A factory that raises a BaseException subclass."""
    raise Stop("no planner today")


def factory_exits(model):
    """A factory that calls sys.exit (as ``builtins:exit`` does)."""
    import sys

    sys.exit(0)


# ----------------------------------------------------------------------- for executor tests
class FakeJob(NamedTuple):
    key: str


class Unpicklable(Exception):
    """An exception that pickles but cannot be rebuilt (its __init__ needs two arguments)."""

    def __init__(self, a, b):
        super().__init__(f"{a} and {b}")


def raise_unpicklable(job):
    """A sweep job that fails with an exception the process pool cannot carry back."""
    raise Unpicklable("left", "right")


class CheckRaises(Outside):
    """Its check() (before the first decision) raises an error of its own."""

    def check(self, belief, objects):
        raise RuntimeError("cannot check")


class CheckExits(Outside):
    """Its check() calls exit."""

    def check(self, belief, objects):
        raise SystemExit(3)
