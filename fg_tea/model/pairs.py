"""Pairwise relations between two objects' locations (docs/design.md §3.7, eqs. 34-35, 55).

:class:`PairRelation` is the structured form of a co-location or exclusivity factor: a weight
when the two objects share a site, another when they share a room on two sites, 1 otherwise.
Programs (:mod:`fg_tea.model.program_bundled`) and the belief graph (:mod:`fg_tea.beliefs.graph`)
both hold relations in this form; :func:`learned_pairs` applies eq. (55)'s learned weights.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from fg_tea.model.learning import learned_relation_weights
from fg_tea.model.spec import Model


@dataclass(frozen=True)
class PairRelation:
    """psi(L_a, L_b): `same_site` when a and b share a site, `same_room` when they share a room
    on two different sites, 1 otherwise (exclusivity and co-location factors)."""

    a: str
    b: str
    same_site: float
    same_room: float
    label: str


def learned_pairs(model: Model, pairs: list[PairRelation], objects: Sequence[str],
                  categories: Sequence[str], priors: Sequence[np.ndarray],
                  rooms: Sequence[str]) -> list[PairRelation]:
    """The pair factors with eq. (55)'s learned co-location weights (docs/design.md §12.1).

    For every two objects related by a co-location relation whose categories have counts, the
    hand-set weights are the product of every pair factor between the two (co-location and
    exclusivity alike); eq. (55) gives the learned (s, r) over the two objects' location priors,
    and the first co-location factor of the pair is scaled so that the product is (s, r).
    Pairs without counts keep their factors unchanged.
    """
    assert model.learning is not None
    learning = model.learning
    cat = dict(zip(objects, categories))
    prior = dict(zip(objects, priors))
    groups: dict[frozenset, list[int]] = {}
    for i, p in enumerate(pairs):
        groups.setdefault(frozenset((p.a, p.b)), []).append(i)
    out = list(pairs)
    for members in groups.values():
        co = [i for i in members if pairs[i].label.startswith("co_location")]
        if not co:
            continue
        a, b = pairs[co[0]].a, pairs[co[0]].b
        counts = learning.counts.relation(cat[a], cat[b])
        if counts is None:
            continue
        s0 = float(np.prod([pairs[i].same_site for i in members]))
        r0 = float(np.prod([pairs[i].same_room for i in members]))
        s, r = learned_relation_weights(prior[a], prior[b], rooms, s0, r0, counts,
                                        learning.relation_strength)
        first = pairs[co[0]]
        out[co[0]] = PairRelation(first.a, first.b,
                                  first.same_site * s / s0 if s0 > 0 else s,
                                  first.same_room * r / r0 if r0 > 0 else r,
                                  first.label + " (learned)")
    return out


def model_relations(model: Model, objects: Sequence[str],
                    categories: Sequence[str]) -> tuple[list[PairRelation], float | None]:
    """A joint model's relations over a house's objects: the pair factors (co-location between
    objects of the related categories, exclusivity between every two objects, eqs. 34-35) and the
    capacity penalty (the product of its capacity relations; None without one)."""
    pairs: list[PairRelation] = []
    penalty: float | None = None
    for rel in model.relations:
        if rel.kind == "capacity":
            penalty = rel.penalty if penalty is None else penalty * rel.penalty
        elif rel.kind == "co_location":
            a_cat, b_cat = rel.categories
            for a, ca in zip(objects, categories):
                for b, cb in zip(objects, categories):
                    if ca == a_cat and cb == b_cat and a != b:
                        pairs.append(PairRelation(a, b, rel.same_site, rel.same_room, f"co_location {a}~{b}"))
        elif rel.kind == "exclusivity":
            for i, a in enumerate(objects):
                for b in objects[i + 1:]:
                    pairs.append(PairRelation(a, b, rel.weight, 1.0, f"exclusivity {a}|{b}"))
    return pairs, penalty
