"""``fg-tea beliefs``: the prior marginals of every object and task state (eq. 2, eq. 21), and with
``--top K`` the K most probable joint arrangements of the model's program, with ``--joint A B ...``
the joint marginal of any set of its variables (docs/design.md §4.8).
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
    except InputError:  # names its own file and field: a model program's factor, its budget
        raise
    except ValueError as exc:
        raise InputError(scenario.source or "<scenario>", "$.objects",
                         f"with model {model.name!r}: {exc}") from None
    # The program's queries first, so a refused one (an unknown variable) prints nothing else.
    extra = ([top_text(scenario, model, args.top)] if args.top is not None else []) + \
        ([joint_text(scenario, model, args.joint)] if args.joint else [])
    locations = belief.locations()
    header = ["site (room)"] + [f"q(L[{o}])" for o in belief.objects]
    rows = [[f"{s.name} ({s.room})"] + [f"{locations[o][i]:.4f}" for o in belief.objects]
            for i, s in enumerate(scenario.sites)]
    rows.append(["entropy (nats)"] + [f"{entropy(locations[o]):.4f}" for o in belief.objects])
    print(f"scenario {scenario.name} · model {model.name} ({model.structure}) · solver {belief.backend}")
    print(format_table(rows, header))
    print()
    print(format_table([[s, f"{p:.4f}"] for s, p in sorted(belief.states().items())],
                        ["task state", "q(true)"]))
    print()
    print("most probable arrangement (gtsam max-product): " +
          ", ".join(f"{o} on {s}" for o, s in belief.map_estimate().items()))
    print(f"agreement with gtsam: max |difference| = {belief.check_against_gtsam():.2e}")
    for text in extra:
        print()
        print(text, end="")
    return 0


#: Most rows ``--joint`` prints (the rest are counted, with their total probability).
JOINT_ROWS = 40


def joint_text(scenario, model, names: list[str]) -> str:
    """The joint marginal of `names` under the model's program, exactly: its most probable rows
    (at most :data:`JOINT_ROWS`; the rest counted with their total probability)."""
    import numpy as np

    from fg_tea.beliefs.compiled import compile_program
    from fg_tea.model.program_bundled import model_program

    compiled = compile_program(model_program(scenario, model))
    table = compiled.joint(names)
    labels = [[str(v).lower() if isinstance(v, bool) else str(v) for v in compiled.values(n)] for n in names]
    order = np.argsort(-table, axis=None, kind="stable")
    shown = [i for i in order[:JOINT_ROWS] if table.flat[i] > 0]
    rows = [[labels[a][j] for a, j in enumerate(np.unravel_index(i, table.shape))] + [f"{table.flat[i]:.6f}"]
            for i in shown]
    text = f"joint of {', '.join(names)} (exact, the compiled program):\n"
    text += format_table(rows, list(names) + ["probability"]) + "\n"
    rest = int(table.size) - len(shown)
    if rest:
        left = float(table.sum() - sum(table.flat[i] for i in shown))
        text += f"... {rest:,} more assignments, of total probability {max(left, 0.0):.6f}\n"
    return text


def top_text(scenario, model, k: int) -> str:
    """The `k` most probable joint arrangements of the model's program over `scenario`, exactly
    (K-best MAP of the compiled program: every location, task state and variable of its own)."""
    from fg_tea.beliefs.compiled import compile_program
    from fg_tea.model.program_bundled import model_program

    compiled = compile_program(model_program(scenario, model))
    best = compiled.kbest(k)
    lines = [f"{len(best)} most probable arrangements (exact K-best of the compiled program):"]
    for rank, a in enumerate(best, 1):
        values = ", ".join(f"{name} on {value}" if hasattr(value, "room") else f"{name}={value}"
                           for name, value in a.values.items())
        lines.append(f"{rank:3d}. p={a.probability:.6f}  {values}")
    return "\n".join(lines) + "\n"


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {text!r}")
    return value


def add_parser(sub) -> None:
    p = sub.add_parser("beliefs", help="print the prior location and task-state beliefs of a scenario")
    p.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO,
                   help="scenario file or bundled name (default: %(default)s)")
    p.add_argument("--model", default=DEFAULT_MODEL, help=MODEL_HELP)
    p.add_argument("--top", type=_positive, default=None, metavar="K",
                   help="also print the K most probable joint arrangements of every variable of the "
                   "model's program (locations, task states, variables of its own), exactly")
    p.add_argument("--joint", nargs="+", default=None, metavar="VAR",
                   help="also print the joint marginal of these variables of the model's program "
                   "(objects' locations by object name, task states such as mug.served, variables of "
                   f"its own), exactly: its {JOINT_ROWS} most probable rows")
    add_solver_argument(p)
