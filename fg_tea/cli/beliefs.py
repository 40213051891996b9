"""``fg-tea beliefs``: the prior marginals of every object and task state (eq. 2, eq. 21).
"""

from __future__ import annotations

import argparse

from fg_tea.cli.common import MODEL_HELP, add_solver_argument, command, format_table
from fg_tea.common.errors import InputError
from fg_tea.common.resources import DEFAULT_MODEL, DEFAULT_SCENARIO


@command("beliefs")
def cmd_beliefs(args: argparse.Namespace) -> int:
    """Print the prior marginals of every object and task state (eq. 2, eq. 21)."""
    from fg_tea.beliefs.engine import BeliefEngine, entropy
    from fg_tea.model.spec import load_model
    from fg_tea.world.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    model = load_model(args.model)
    try:
        belief = BeliefEngine(scenario, model, backend=args.solver)
    except ValueError as exc:
        raise InputError(scenario.source or "<scenario>", "$.objects",
                         f"with model {model.name!r}: {exc}") from None
    locations = belief.locations()
    header = ["site (room)"] + [f"q(L[{o}])" for o in belief.objects]
    rows = [[f"{s.name} ({s.room})"] + [f"{locations[o][i]:.4f}" for o in belief.objects]
            for i, s in enumerate(scenario.sites)]
    rows.append(["entropy (nats)"] + [f"{entropy(locations[o]):.4f}" for o in belief.objects])
    print(f"scenario {scenario.name} · model {model.name} ({model.structure}) · backend {belief.backend}")
    print(format_table(rows, header))
    print()
    print(format_table([[s, f"{p:.4f}"] for s, p in sorted(belief.states().items())],
                        ["task state", "q(true)"]))
    print()
    print("most probable arrangement (gtsam max-product): " +
          ", ".join(f"{o} on {s}" for o, s in belief.map_estimate().items()))
    print(f"agreement with gtsam: max |difference| = {belief.check_against_gtsam():.2e}")
    return 0


def add_parser(sub) -> None:
    p = sub.add_parser("beliefs", help="print the prior location and task-state beliefs of a scenario")
    p.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO,
                   help="scenario file or bundled name (default: %(default)s)")
    p.add_argument("--model", default=DEFAULT_MODEL, help=MODEL_HELP)
    add_solver_argument(p)
