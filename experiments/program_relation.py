"""A relation no TOML family expresses: does a joint model program that states it search better?

The relation (``experiments/programs/kept_together.py``): the mug, the teabag and the kettle are
kept together — an arrangement in which every two of them stand within ``WITHIN`` (2.5) metres
weighs ``TOGETHER`` (20) times one in which they do not. It is one factor over three locations:
two of the three close and the third far weighs the same as all three apart, so its three-way
interaction is log 20 where any product of pairwise factors has none, and the co-location and
exclusivity families (pairs, by site and room) cannot state it (docs/design.md §4.8).

The worlds are drawn from the same relation: generated houses of 3 rooms (about 13 sites) and 6
rooms (about 27), objects mug, kettle and teabag, placed by the world distribution's
``together`` rule with the program's distance and weight (:mod:`fg_tea.world.together`: exact,
over every arrangement, each object's affordance prior times the weight, within the sites'
capacity).
The program's own location priors are the models' (eq. 2 with the prior floor) and its capacity
penalty is the joint model's soft one — the only differences between the worlds and the program.

The two beliefs: ``factorised`` (the bundled model) and the program (base ``joint``: the joint
model's capacity, planning, detection and transitions, its pairwise co-location factors removed,
the three-object factor added; a joint belief, planned on its exact joint). The planners: the
lookahead and eqs. 10-11 (``factorised_efe``), task ``make_tea``. Every configuration solves the
same worlds with the same episode seeds; a discovery and a confirmation set of world seeds are
declared in OUT/seed_sets.json before any episode runs, and each cell (house size × planner) is
the paired difference program − factorised, judged on each set, Holm-adjusted over the cells
(docs/design.md §11.1).

Writes under OUT (default ``runs/experiments/program_relation``): ``worlds/`` (the world files),
``episodes.csv`` (the sweep CSV, resumable), ``replication.csv`` and ``summary.md`` (the paired
differences of search travel, inspections and SPL pooled over both sets; the replication table;
means per cell), and ``commands.txt`` (every command that added rows).

Example (the committed table)::

    python experiments/program_relation.py --worlds 100 --confirmation-worlds 100 \\
        --workers 1 --out experiments/results/program_relation
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path

from fg_tea.common.errors import run_script
from fg_tea.common.files import atomic_write_text, out_folder
from fg_tea.common.options import experiment_parser
from fg_tea.common.resources import resolve_world
from fg_tea.study.analysis import (markdown_table, paired_differences,
                                   summary_markdown, summary_table)
from fg_tea.study.replication import (SeedSet, check_seed_sets, declare_seed_sets,
                                      replication_cells, replication_markdown)
from fg_tea.study.rows import read_rows, write_csv_atomic
from fg_tea.study.seeds import (add_episode_seed_argument, check_resumable,
                                episode_seed_scheme, recorded_argv)
from fg_tea.study.sweep import add_execution_arguments, plan_sweep, run_sweep

PROGRAM = "experiments/programs/kept_together.py"
SIZES = {"small": "generated_small", "medium": "generated_medium"}
TASK = "make_tea"
PLANNERS = ("lookahead", "factorised_efe")
METRICS = ("search_distance", "inspections", "spl")
LABEL = {"search_distance": "search travel (m)", "inspections": "inspections", "spl": "SPL"}
GAIN_LABEL = {"factorised_efe": "eqs. 10-11", "lookahead": "lookahead"}
DEFAULT_OUT = "runs/experiments/program_relation"


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§4.8 and §11.1")
    p.add_argument("--worlds", type=int, default=100, help="worlds of the discovery set per house size")
    p.add_argument("--first-seed", type=int, default=0, help="first world seed of the discovery set")
    p.add_argument("--confirmation-first-seed", type=int, default=10000,
                   help="first world seed of the confirmation set (disjoint from the discovery set)")
    p.add_argument("--confirmation-worlds", type=int, default=None,
                   help="worlds of the confirmation set per house size (default: --worlds)")
    p.add_argument("--sizes", nargs="+", choices=tuple(SIZES), default=list(SIZES),
                   help="house sizes: small (3 rooms, ~13 sites), medium (6 rooms, ~27 sites)")
    p.add_argument("--planners", nargs="+", default=list(PLANNERS), help="planner names")
    p.add_argument("--program", default=PROGRAM,
                   help="the model program stating the relation (its KEPT objects, WITHIN metres and "
                   "TOGETHER weight place the worlds' objects too)")
    add_episode_seed_argument(p)
    add_execution_arguments(p, "episodes.csv")
    p.add_argument("--out", type=out_folder, default=DEFAULT_OUT, help="output folder")
    return p


def parse_args(argv=None) -> argparse.Namespace:
    p = build_parser()
    args = p.parse_args(argv)
    if args.worlds < 1 or (args.confirmation_worlds is not None and args.confirmation_worlds < 1):
        p.error("--worlds and --confirmation-worlds must be at least 1")
    if args.first_seed < 0 or args.confirmation_first_seed < 0:
        p.error("world seeds must not be negative")
    from fg_tea.planning import check_planner
    from fg_tea.common.errors import InputError

    for name in args.planners:
        try:
            check_planner(name)
        except (ValueError, InputError) as exc:
            p.error(f"--planners: {exc}")
    return args


def relation(program: str) -> tuple[tuple[str, ...], float, float]:
    """(KEPT, WITHIN, TOGETHER) of the program file: the objects kept together, the distance
    within which they are together and the weight of that.

    Raises:
        InputError: the file does not define them.
    """
    from fg_tea.common.errors import InputError
    from fg_tea.model.program_file import load_program_source

    source = load_program_source(program)  # imports it with the checks and time limit of any model
    module = sys.modules.get(getattr(source.function, "__module__", ""), None)
    kept, within, weight = (getattr(module, k, None) for k in ("KEPT", "WITHIN", "TOGETHER"))
    if not (isinstance(kept, tuple) and isinstance(within, (int, float)) and isinstance(weight, (int, float))):
        raise InputError(program, "KEPT", "the study's program defines KEPT (a tuple of objects), WITHIN "
                         "(metres) and TOGETHER (a weight), which the worlds are drawn with")
    return kept, float(within), float(weight)


def world_file(out: Path, size: str, kept: tuple[str, ...], within: float, weight: float, program: str) -> str:
    """The world distribution of `size`: the generated houses of that size, `kept` placed jointly
    with the program's distance and weight (``placement.together``); written when its text differs."""
    base = json.loads(resolve_world(SIZES[size]).read_text(encoding="utf-8"))
    name = f"kept_together_{size}"
    rest = [o for o in base["generate"]["objects"] if o not in kept]
    world = {"name": name,
             "description": (f"The houses of {SIZES[size]}, with {', '.join(kept)} drawn jointly: an "
                             f"arrangement with every two of them within {within:g} m weighs {weight:g} "
                             f"times one without, the relation of {program} (each object's affordance prior "
                             "otherwise; sites never exceed their capacity). Kettle water drawn from its "
                             "prior. Written by experiments/program_relation.py."),
             "generate": base["generate"],
             "placement": {"order": list(kept) + rest, "prior_violation": 0.0, "violation": "inverse",
                           "together": [{"objects": list(kept), "within": within, "weight": weight}]},
             "states": base.get("states", {})}
    text = json.dumps(world, indent=2) + "\n"
    path = out / "worlds" / f"{name}.json"
    if not path.is_file() or path.read_text(encoding="utf-8") != text:
        atomic_write_text(path, text)
    return str(path)


def seed_sets(args) -> list[SeedSet]:
    sets = [SeedSet("discovery", args.first_seed, args.worlds),
            SeedSet("confirmation", args.confirmation_first_seed, args.confirmation_worlds or args.worlds)]
    check_seed_sets(sets)
    return sets


def plan(args, out: Path, sets: list[SeedSet]):
    kept, within, weight = relation(args.program)
    jobs = []
    for s in sets:
        for size in args.sizes:
            world = world_file(out, size, kept, within, weight, args.program)
            jobs += plan_sweep([world], s.count, ["factorised", args.program], args.planners,
                               first_seed=s.first, env=args.env, task=TASK,
                               episode_seeds=episode_seed_scheme(args))
    return jobs


def size_of(world: str) -> str | None:
    prefix = "kept_together_"
    return world[len(prefix):] if world.startswith(prefix) and world[len(prefix):] in SIZES else None


def wall_time(path: Path, seconds: float, ran: int) -> str:
    """This command's wall-time line; a report regenerated from the rows (no new episode) keeps
    the line of the report it replaces."""
    if not ran and path.is_file():
        for line in path.read_text(encoding="utf-8").splitlines():
            if line.startswith("Wall time: ") and " for 0 new episodes" not in line:
                return line
    return f"Wall time: {seconds:.0f} s for {ran} new episodes."


def report(out: Path, rows: list[dict], sets: list[SeedSet], command: str, seconds: float, ran: int,
           program_name: str) -> Path:
    rank = {s: i for i, s in enumerate(SIZES)}
    tagged = [{**r, "size": size_of(str(r["world"])), "belief": r["structure"]} for r in rows
              if size_of(str(r["world"])) and r["model"] in ("factorised", program_name)]
    diffs = paired_differences(tagged, "belief", "factorised", METRICS + ("success",), by=("size", "planner"))
    diffs.sort(key=lambda d: (rank[d["size"]], str(d["planner"])))
    header = ["size", "planner", "pairs"] + [f"{LABEL[m]}: factorised → program" for m in METRICS] + \
        [f"{LABEL[m]}: program − factorised [95 % CI]" for m in METRICS] + ["success: program − factorised"]
    body = [[d["size"], GAIN_LABEL.get(d["planner"], d["planner"]), d["pairs"]]
            + [f"{d[m + '_baseline'].mean:.2f} → {d[m + '_other'].mean:.2f}" for m in METRICS]
            + [d[m].fmt(2 if m != "spl" else 3) for m in METRICS] + [d["success"].fmt(3)] for d in diffs]
    cells = replication_cells(tagged, sets, vary="belief", baseline="factorised", other="joint",
                              by=("size", "planner"))
    cells.sort(key=lambda c: (rank[c["size"]], str(c["planner"])))
    flat = []
    for c in cells:
        row = {"size": c["size"], "planner": c["planner"]}
        for s in sets:
            e = c[s.name]
            row.update({f"{s.name}_pairs": e["pairs"], f"{s.name}_diff": e["difference"].mean,
                        f"{s.name}_low": e["difference"].low, f"{s.name}_high": e["difference"].high,
                        f"{s.name}_baseline": e["baseline"], f"{s.name}_p": e["p"],
                        f"{s.name}_p_holm": e["p_holm"]})
        row.update(pairs_needed=c["pairs_needed"], verdict=c["verdict"])
        flat.append(row)
        c["planner"] = GAIN_LABEL.get(c["planner"], c["planner"])
    write_csv_atomic(out / "replication.csv", flat)
    summary = summary_table(sorted(tagged, key=lambda r: r["key"]), ("size", "model", "planner"),
                            METRICS + ("clairvoyant_search_travel",))  # it adds the success rate
    worlds = len({(r["world"], r["world_seed"]) for r in tagged})
    lines = ["# A relation no TOML family expresses: the program against the factorised belief", "",
             "Reproduce with:", "", f"    {command}", "",
             f"{len(tagged)} episodes over {worlds} sampled worlds (house size × world seed). The "
             f"relation, the worlds and the models: `experiments/program_relation.py`'s docstring; "
             f"the program is `{program_name}` (a joint belief), the baseline the bundled `factorised` "
             "model. Every configuration solves the same worlds with the same episode seeds. Each "
             "cell is the paired difference program − factorised (negative travel or inspections, "
             "positive SPL: the program did better), mean with a 95 % Student-t interval over worlds.",
             "", wall_time(out / "summary.md", seconds, ran), "",
             "## Paired differences (both seed sets pooled)", "", markdown_table(header, body), "",
             "## Replication: program − factorised search travel (m)", "",
             replication_markdown(cells, sets, ("size", "planner")),
             "## Means per cell, model and planner", "",
             summary_markdown(summary, ("size", "model", "planner"),
                              METRICS + ("clairvoyant_search_travel",)), ""]
    return atomic_write_text(out / "summary.md", "\n".join(lines))


def main(argv=None) -> int:
    args = parse_args(argv)
    out = Path(args.out)
    sets = seed_sets(args)
    jobs = plan(args, out, sets)
    csv_path = out / "episodes.csv"
    check_resumable(jobs, csv_path, args.resume)
    declare_seed_sets(out, sets)  # before any episode runs; a folder keeps its declaration
    before = len(read_rows(csv_path)) if args.resume and csv_path.is_file() else 0
    t0 = time.perf_counter()
    run_sweep(jobs, csv_path, args.executor, workers=args.workers or None, address=args.address,
              resume=args.resume, label="program_relation")
    seconds = time.perf_counter() - t0
    rows = read_rows(csv_path)
    ran = max(len(rows) - before, 0)
    command = shlex.join(["python", "experiments/program_relation.py",
                          *recorded_argv(sys.argv[1:] if argv is None else argv, args)])
    log = out / "commands.txt"
    commands = log.read_text(encoding="utf-8").splitlines() if log.is_file() else []
    if ran and command not in commands:
        commands.append(command)
        atomic_write_text(log, "\n".join(commands) + "\n")
    from fg_tea.model.spec import load_model

    path = report(out, rows, sets, "\n    ".join(commands or [command]), seconds, ran,
                  load_model(args.program).name)
    print(f"episodes: {csv_path} ({len(rows)} rows); report: {path}")
    return 0


if __name__ == "__main__":
    run_script(main, "program_relation.py")
