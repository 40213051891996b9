"""The `fg-tea` command line: a thin wrapper over the package's public API.

Every input fault (scenario, model or task file; bad option) is printed as one line naming the
file, the field and what is wrong, and the command exits with status 2.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Callable, Sequence

from fg_tea.errors import InputError
from fg_tea.resources import DEFAULT_MODEL, DEFAULT_SCENARIO

COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {}


def _command(name: str):
    def register(fn):
        COMMANDS[name] = fn
        return fn
    return register


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage faults in one line with exit status 2."""

    def error(self, message: str) -> None:  # noqa: D401 - argparse API
        sys.stderr.write(f"fg-tea: error: {message}\n")
        raise SystemExit(2)


def _format_table(rows: list[list[str]], header: list[str]) -> str:
    widths = [max(len(str(r[i])) for r in rows + [header]) for i in range(len(header))]
    fmt = "  ".join(f"{{:{'<' if i == 0 else '>'}{w}}}" for i, w in enumerate(widths))
    lines = [fmt.format(*header), "  ".join("-" * w for w in widths)]
    lines += [fmt.format(*r) for r in rows]
    return "\n".join(lines)


@_command("beliefs")
def cmd_beliefs(args: argparse.Namespace) -> int:
    """Print the prior marginals of every object and task state (eq. 2, eq. 21)."""
    from fg_tea.beliefs.engine import BeliefEngine, entropy
    from fg_tea.model import load_model
    from fg_tea.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    model = load_model(args.model)
    belief = BeliefEngine(scenario, model, backend=args.backend)
    locations = belief.locations()
    header = ["site (room)"] + [f"q(L[{o}])" for o in belief.objects]
    rows = [[f"{s.name} ({s.room})"] + [f"{locations[o][i]:.4f}" for o in belief.objects]
            for i, s in enumerate(scenario.sites)]
    rows.append(["entropy (nats)"] + [f"{entropy(locations[o]):.4f}" for o in belief.objects])
    print(f"scenario {scenario.name} · model {model.name} ({model.structure}) · backend {belief.backend}")
    print(_format_table(rows, header))
    print()
    print(_format_table([[s, f"{p:.4f}"] for s, p in sorted(belief.states().items())],
                        ["task state", "q(true)"]))
    print()
    print("most probable arrangement (gtsam max-product): " +
          ", ".join(f"{o} on {s}" for o, s in belief.map_estimate().items()))
    print(f"agreement with gtsam: max |difference| = {belief.check_against_gtsam():.2e}")
    return 0


@_command("validate")
def cmd_validate(args: argparse.Namespace) -> int:
    """Check scenario (.json), model (.toml) and task files; print one line per file."""
    from fg_tea.model import load_model
    from fg_tea.scenario import load_scenario

    for name in args.files:
        path = Path(name)
        if path.suffix == ".toml":
            load_model(path)
        elif "tasks" in path.parts:
            from fg_tea.tasks.load import load_task

            load_task(path, load_model(args.model), load_scenario(args.scenario))
        else:
            load_scenario(path)
        print(f"{path}: ok")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="fg-tea", description="A tea-making drone that reasons with exact beliefs.")
    from fg_tea import __version__

    parser.add_argument("--version", action="version", version=f"fg-tea {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("beliefs", help="print the prior location and task-state beliefs of a scenario")
    p.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO,
                   help="scenario file or bundled name (default: %(default)s)")
    p.add_argument("--model", default=DEFAULT_MODEL, help="model file or bundled name (default: %(default)s)")
    p.add_argument("--backend", choices=("numpy", "gtsam"), default="numpy",
                   help="exact solver: fast numpy path or gtsam elimination (default: %(default)s)")

    p = sub.add_parser("validate", help="check scenario, model and task files")
    p.add_argument("files", nargs="+")
    p.add_argument("--scenario", default=DEFAULT_SCENARIO, help="scenario to check task files against")
    p.add_argument("--model", default=DEFAULT_MODEL, help="model to check task files against")

    for extend in _EXTENSIONS:
        extend(sub)
    return parser


# Later layers (episode runner, experiments) register their sub-commands here.
_EXTENSIONS: list[Callable[[argparse._SubParsersAction], None]] = []


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return COMMANDS[args.command](args)
    except InputError as exc:
        sys.stderr.write(f"fg-tea: error: {exc}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("fg-tea: interrupted\n")
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
