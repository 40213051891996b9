"""fg_tea: a tea-making drone that reasons with exact factor-graph beliefs.

Layers, in the order data flows (see docs/design.md §1): scenario -> model -> beliefs -> planning ->
tasks -> env -> episode -> render. The agent side (beliefs, planning, tasks) never imports the
simulator.
"""

from fg_tea._version import __version__
