"""When should a search be given up? The probability rule against the rule that weighs the cost.

Runs the same worlds under the probability give-up (the earlier default), under ``give_up = "cost"``
(the default: the cost is weighed once the misses are improbable) and under the cost rule weighed
from the first look (``weigh_early``), with the value of finishing the task at each of ``--values``
sweeps of the house (docs/design.md §7.8), and reports both sides of the trade:

- *false give-ups*: searches given up although every object was there to be found (worlds of
  ``--worlds-findable``), with the search travel of all episodes;
- *wasted travel*: with one object the camera never reports (``--unfindable``, a stand-in for an
  object that is not in the house), the search travel and looks until the search is given up.

The values are declared before the run, not chosen from its outcome: the tea is worth walking
through every viewpoint of the house three times (the default model's value), and 1 and 10 show
the trade around it. Model files for the variants are written to ``--out``/models. Writes
``episodes.csv`` and ``summary.md`` to ``--out``; a re-run resumes.

    python experiments/give_up.py --worlds 20                     # a quick look
    # the committed table (experiments/results/give_up/):
    python experiments/give_up.py --worlds 200 --workers 1 --episode-seeds world \\
        --out experiments/results/give_up
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from fg_tea.common.errors import InputError, run_script
from fg_tea.common.files import atomic_write_text, out_folder


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.options import MODELS_HELP, WORKERS_HELP, experiment_parser
    from fg_tea.study.seeds import add_episode_seed_argument

    p = experiment_parser(__doc__, __file__, "§7.8")
    p.add_argument("--worlds", type=int, default=200, help="worlds per world distribution")
    p.add_argument("--worlds-findable", nargs="+", default=["correlated", "generated_small_milk_sugar"],
                   help="world distributions whose objects are all findable")
    p.add_argument("--unfindable", default="mug", help="the object the camera never reports")
    p.add_argument("--unfindable-world", default="correlated", help="worlds for the unfindable object")
    p.add_argument("--models", nargs="+", default=["factorised", "factorised_close"], help=MODELS_HELP)
    p.add_argument("--values", type=float, nargs="+", default=[1.0, 3.0, 10.0],
                   help="values of finishing the task, in sweeps of the house")
    p.add_argument("--env", choices=("fake", "pybullet"), default="fake", help="environment")
    p.add_argument("--workers", type=int, default=2, help=WORKERS_HELP)
    add_episode_seed_argument(p)
    p.add_argument("--out", type=out_folder, default="runs/experiments/give_up", help="output folder")
    return p


def variants(models: list[str], values: list[float], folder: Path) -> list[tuple[str, str, str]]:
    """(label, model, rule) per model: a model file per arm, each naming its rule, so that an arm
    means the same whatever the default becomes: the probability rule; the cost rule (the default)
    at each value; and the cost rule weighed from the first look (``weigh_early``) at each value."""
    from fg_tea.study.sweep import model_path

    out = []
    folder.mkdir(parents=True, exist_ok=True)
    for model in models:
        model_path(model, "--models")  # a bundled name or a file, checked before any episode
        parent = model if not Path(model).suffix else str(Path(model).resolve())
        stem = Path(model).stem

        def arm(name: str, planning: str, label: str, rule: str) -> tuple[str, str, str]:
            path = folder / f"{name}.toml"
            atomic_write_text(path, f'extends = "{parent}"\nname = "{name}"\n\n[planning]\n{planning}')
            return (label, str(path), rule)

        out.append(arm(f"{stem}_probability", 'give_up = "probability"\n', f"{model}, probability", "probability"))
        for early in (False, True):
            for v in values:
                name = f"{stem}_cost{'_early' if early else ''}_{v:g}"
                weigh = "weigh_early = true\n" if early else ""
                out.append(arm(name, f'give_up = "cost"\n{weigh}\n[planning.task_value]\ndefault = {v!r}\n',
                               f"{model}, cost{' from the first look' if early else ''}, {v:g} sweeps",
                               f"cost{' early' if early else ''} {v:g}"))
    return out


def main(argv: list[str] | None = None) -> int:
    from fg_tea.common.stats import wilson_interval
    from fg_tea.study.analysis import markdown_table
    from fg_tea.study.rows import read_rows
    from fg_tea.study.seeds import check_resumable, episode_seed, episode_seed_scheme, recorded_argv
    from fg_tea.study.sweep import Job, run_sweep

    args = build_parser().parse_args(argv)
    if args.worlds < 1:
        raise InputError("<command line>", "--worlds", f"{args.worlds}: must be at least 1")
    if any(v <= 0 for v in args.values):
        raise InputError("<command line>", "--values", "every value must be above 0")
    out = Path(args.out)
    independent = episode_seed_scheme(args) == "independent"

    def seed(world: str, w: int) -> int:
        """The episode seed of world seed w (docs/design.md §11)."""
        return episode_seed(world, w) if independent else w

    arms = variants(args.models, args.values, out / "models")
    jobs = []
    for label, model, _ in arms:
        for world in args.worlds_findable:
            task = "make_tea_milk_sugar" if "milk_sugar" in world else "make_tea"
            jobs += [Job(world, s, model, "efe", env=args.env, task=task, seed=seed(world, s))
                     for s in range(args.worlds)]
        jobs += [Job(args.unfindable_world, s, model, "efe", env=args.env, seed=seed(args.unfindable_world, s),
                     env_overrides=(("unfindable", args.unfindable),)) for s in range(args.worlds)]
    csv_path = out / "episodes.csv"
    check_resumable(jobs, csv_path)
    run_sweep(jobs, csv_path, "process", workers=args.workers, label="give_up")
    rows = read_rows(csv_path)
    body = []
    for label, model, _ in arms:
        for world in args.worlds_findable:
            mine = [r for r in rows if r["model_ref"] == model and r["world"] == world
                    and not r.get("env_overrides")]
            gave = [r for r in mine if str(r["reason"]).startswith("not_found")]
            travel = sum(float(r["search_distance"]) for r in mine) / max(len(mine), 1)
            body.append([label, world, "findable", len(mine), len(gave),
                         wilson_interval(len(gave), len(mine)).fmt(3), f"{travel:.2f}", "–"])
        mine = [r for r in rows if r["model_ref"] == model and r.get("env_overrides")]
        gave = [r for r in mine if str(r["reason"]).startswith(f"not_found: {args.unfindable}")]
        travel = sum(float(r["search_distance"]) for r in mine) / max(len(mine), 1)
        looks = sum(float(r["inspections"]) for r in mine) / max(len(mine), 1)
        body.append([label, args.unfindable_world, f"{args.unfindable} unfindable", len(mine),
                     len(gave), wilson_interval(len(gave), len(mine)).fmt(3), f"{travel:.2f}", f"{looks:.1f}"])
    command = "python experiments/give_up.py " + shlex.join(recorded_argv(argv if argv is not None else sys.argv[1:], args))
    text = "\n".join([
        "# Giving up a search: the probability rule against the cost rule", "",
        f"Regenerate: `{command}`", "",
        "Findable worlds: every object is there; a give-up is a false one. Unfindable: the camera "
        f"never reports the {args.unfindable}; every episode should end by giving it up, and the "
        "search travel is what the search cost first. Values of finishing the task are in sweeps "
        "of the house (docs/design.md §7.8), declared before the run.", "",
        "## Give-ups", "",
        markdown_table(["arm", "worlds", "objects", "episodes", "given up", "share given up [95 %]",
                        "search travel (m), mean", "looks, mean"], body), ""])
    atomic_write_text(out / "summary.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    run_script(main, "give_up.py")
