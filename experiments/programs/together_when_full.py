"""Task states with several objects' locations: a full kettle means tea is under way, and then the
mug and the teabag are in one room (docs/design.md §4.8, fg_tea/beliefs/coupling.py).

A model program (docs/how-to/model-as-program.md) on the factorised model: one factor over the
kettle's water and the locations of the mug and the teabag weighs :data:`TOGETHER` times one an
arrangement with both in one room while the kettle holds water. A reading of the kettle's water
moves where the agent expects the mug and the teabag (and their joint); a look at either moves the
belief about the water. Run it with ``fg-tea run --env fake --model
experiments/programs/together_when_full.py``.
"""

import fg_tea as fg

base = "factorised"
#: How much likelier the mug and the teabag share a room when the kettle holds water.
TOGETHER = 8.0


def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))

    @m.factor("kettle.contains_water", "mug", "teabag")
    def together_when_full(full, mug, teabag):
        return TOGETHER if full and mug.room == teabag.room else 1.0

    return m
