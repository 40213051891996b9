"""How far is each planner from the best possible search? Its cost against the exact limit.

The limit is the optimal expected cost of finding every object when looks can miss, bracketed
from both sides (fg_tea/planning/limit.py, docs/design.md §6.9). Each planner runs a search-only
task (``find_mug``, ``find_three``) on worlds drawn from the model's own prior (``independent``),
in the fake house with a detector that misses as often as the model says, so the ratio of its
mean cost to the limit measures planning alone. Writes ``summary.md`` and ``episodes.csv`` to
``--out``, and one JSON file per episode under ``--out``/episodes (a re-run resumes).

    python experiments/search_limit.py --worlds 50                  # a quick look, about a minute
    # the committed table (experiments/results/search_limit/):
    python experiments/search_limit.py --worlds 200 --planners efe lookahead lookahead:relook=1 \\
        lookahead:relook=1,nodes=60 exact exact:cap=2 optimal --out experiments/results/search_limit
"""

from __future__ import annotations

import argparse
import csv
import shlex
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from fg_tea.common.errors import InputError, run_script  # noqa: E402
from fg_tea.common.files import atomic_path, atomic_write_text, out_folder  # noqa: E402

TASKS = ("find_mug", "find_three")
#: Planners that draw random numbers: their policy is no function of the belief, so it is only
#: sampled, never enumerated.
RANDOMISED = ("random", "pouct", "pomcp")


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.options import MODEL_HELP, WORLD_HELP, experiment_parser

    p = experiment_parser(__doc__, __file__, "§6.9")
    p.add_argument("--worlds", type=int, default=200, help="worlds per task and planner (seeds from --first-seed)")
    p.add_argument("--first-seed", type=int, default=0, help="first world seed (and episode seed)")
    p.add_argument("--world", default="independent", help=WORLD_HELP)
    p.add_argument("--model", default="factorised_close", help=MODEL_HELP)
    p.add_argument("--tasks", nargs="+", default=list(TASKS), help="search-only tasks")
    p.add_argument("--planners", nargs="+", default=["efe", "lookahead", "exact", "optimal"],
                   help="planner names, with options as in lookahead:nodes=60")
    p.add_argument("--tolerance", type=float, default=1e-3,
                   help="width of the limit's bracket to stop at, metres (if memory allows)")
    p.add_argument("--gaps", nargs="*", default=["lookahead"],
                   help="planners whose decisions are compared with the exact policy's (gaps.md)")
    p.add_argument("--out", type=out_folder, default="runs/experiments/search_limit",
                   help="output folder")
    return p


def main(argv: list[str] | None = None) -> int:
    from fg_tea.study.rows import Progress
    from fg_tea.study import yardstick
    from fg_tea.study.frontier import check_inputs

    args = build_parser().parse_args(argv)
    check_inputs(args.world, args.worlds, [args.model], args.planners)
    if not (args.tolerance > 0):
        raise InputError("<command line>", "--tolerance", f"{args.tolerance}: must be above 0")
    out = Path(args.out)
    limits = {}
    for task in args.tasks:
        try:
            limits[task] = yardstick.start_limit(args.world, args.model, task, args.tolerance)
        except ValueError as exc:  # the limit does not fit, or the belief is correlated
            raise InputError("<command line>", "--model", str(exc)) from None
        lim = limits[task][0]
        print(f"{task}: limit [{lim.lower:.4f}, {lim.upper:.4f}] m (cap {lim.cap})", flush=True)
    rows = []
    seeds = range(args.first_seed, args.first_seed + args.worlds)
    for task in args.tasks:
        bar = Progress(len(args.planners) * len(seeds), label=task)
        rows += yardstick.run(args.world, seeds, args.model, args.planners, task, out,
                              progress=lambda done, total: bar.update())
    policies = {}
    for task in args.tasks:
        for planner in args.planners:
            if planner.split(":")[0] not in RANDOMISED:
                policies[(task, planner)] = yardstick.evaluate_policy(args.world, args.model, planner, task)
    command = "python experiments/search_limit.py " + shlex.join(argv if argv is not None else sys.argv[1:])
    text = yardstick.summarise(rows, limits, args.world, args.model, command, policies)
    atomic_write_text(out / "summary.md", text)
    with atomic_path(out / "episodes.csv") as tmp, tmp.open("w", newline="") as fh:
        columns = ["task", "planner", "seed", "cost", "looks", "success", "reason"]
        w = csv.DictWriter(fh, columns, extrasaction="ignore", lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    gaps = ["# Where each planner loses against the exact policy", "",
            "At every decision the planner makes (every branch of its policy, reached with the "
            "probability shown), the regret is the exact Q-value of its look minus the best look's "
            "(the tables of the upper cut, docs/design.md §6.9); weighted by the chance of reaching "
            "the decision, the regrets sum to the planner's excess cost over the exact policy.", ""]
    summary = ["## Summary", "", "| planner | task | policy cost (m) | exact policy (m) | summed regret (m) | "
               "at re-looks (m) | at the first decision (m) |", "|---|---|---|---|---|---|---|"]
    details: list[str] = []
    for planner in args.gaps:
        for task in args.tasks:
            g = yardstick.gap_analysis(args.world, args.model, planner, task)
            relook = sum(r["weighted"] for r in g["rows"] if r["best"] == r["here"])
            root = sum(r["weighted"] for r in g["rows"] if r["here"] is None)
            summary.append(f"| {planner} | {task} | {g['policy'].cost:.4f} | {g['cut_policy']:.4f} | "
                           f"{g['excess']:.4f} | {relook:.4f} | {root:.4f} |")
            details += [f"## `{planner}`, task `{task}`", "",
                     f"Policy cost {g['policy'].cost:.4f} m; the exact (cut) policy's {g['cut_policy']:.4f} m; "
                     f"summed weighted regret {g['excess']:.4f} m, of which {relook:.4f} m where the best "
                     f"look was a re-look from where the agent stood and {root:.4f} m at the first "
                     f"decision. Decisions beyond the cut (not weighed): probability {g['beyond_cut']:.2g}.",
                     "", "| weighted regret (m) | probability | stood at | looks so far | still searched | "
                     "chose | best | regret (m) |", "|---|---|---|---|---|---|---|---|"]
            for r in g["rows"][:12]:
                details.append(f"| {r['weighted']:.4f} | {r['weight']:.3f} | {r['here'] or 'start'} | "
                            f"{sum(r['looks'].values())} | {', '.join(r['pending'])} | {r['chosen']} | "
                            f"{r['best']} | {r['regret']:.3f} |")
            details.append("")
    atomic_write_text(out / "gaps.md", "\n".join(gaps + summary + [""] + details))
    print(text)
    return 0


if __name__ == "__main__":
    run_script(main, "search_limit.py")
