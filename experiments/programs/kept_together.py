"""The mug, the teabag and the kettle are kept together: a three-object factor (docs/design.md §4.8).

A model program (docs/how-to/model-as-program.md) for the study of ``experiments/program_relation.py``.
It starts from the bundled joint model (capacity, planning, detection, transitions), drops that
model's pairwise co-location factors, and adds one factor over three locations: an arrangement in
which every two of the mug, the teabag and the kettle stand within :data:`WITHIN` metres of each
other weighs :data:`TOGETHER` times one in which they do not. No pairwise factors express it:
two of the three close and the third far weighs the same as all three apart, so its three-way
interaction (the alternating sum of log weights over two sites per object: three close sites and
three far ones) is log TOGETHER, where any product of factors over pairs has none; and the bundled
families relate pairs by site and room only.

The study's worlds are drawn from the same relation (the world distribution's ``together`` rule
with these numbers, :mod:`fg_tea.world.together`), so this is the true model of them up to the
location priors' floor and the soft capacity penalty.
"""

import fg_tea as fg

base = "joint"
#: The objects kept together.
KEPT = ("mug", "teabag", "kettle")
#: Metres within which every two of them stand when kept together (horizontal, between sites).
WITHIN = 2.5
#: How much likelier an arrangement is when they are kept together.
TOGETHER = 20.0


def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))
    for f in m.factors:
        if f.name.startswith("co_location "):
            m.remove(f.name)

    @m.factor(*KEPT)
    def kept_together(mug, teabag, kettle):
        close = mug.distance(teabag) <= WITHIN and mug.distance(kettle) <= WITHIN \
            and teabag.distance(kettle) <= WITHIN
        return TOGETHER if close else 1.0

    return m
