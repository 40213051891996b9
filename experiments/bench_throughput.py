"""Episodes per CPU-second: the fake house and PyBullet, per planner, at about 13, 27 and 45 sites.

Each cell runs ``--episodes`` make-tea episodes (the factorised model, worlds 0.. of the bundled
``generated_small``, ``generated_medium`` and ``generated_large`` world distributions: fresh
generated houses of 3, 6 and 10 rooms) one after another in this process, exactly as a sweep's
worker runs them (:func:`fg_tea.study.sweep.run_job`), and times each with
``time.process_time``. Every cost is included: building the house and its navigator, the
PyBullet house's expected-pixel tables (computed cold: the table cache is a fresh folder and the
in-memory cache is emptied before each cell, so the first episode of each house pays for them),
every belief update and every planner solve. The table reports the mean CPU seconds per episode
with every episode included, its episodes per CPU-second, and the mean number of sites.

Writes ``bench_throughput.csv`` and ``bench_throughput.md`` beside ``--out`` (default
``runs/experiments/bench_throughput/bench_throughput.md``); the committed result changes only
when ``--out`` names it:

    nice python experiments/bench_throughput.py --out experiments/results/bench_throughput/bench_throughput.md
    python experiments/bench_throughput.py --quick      # one episode per cell, the fake house only
"""

from __future__ import annotations

import argparse
import csv
import io
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

from fg_tea.common.errors import run_script
from fg_tea.common.files import atomic_write_text, out_file
from fg_tea.common.options import experiment_parser
from fg_tea.common.tables import table_lines

DEFAULT_OUT = Path("runs") / "experiments" / "bench_throughput" / "bench_throughput.md"
WORLDS = ("generated_small", "generated_medium", "generated_large")
PLANNERS = ("efe", "lookahead", "greedy")
ENVS = ("fake", "pybullet")
#: The size of the large comparison whose cost the table estimates.
LARGE_RUN = 10_000
FIELDS = ("env", "world", "planner", "episodes", "sites_mean", "cpu_s_mean", "cpu_s_max",
          "episodes_per_cpu_s", "success")


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§11")
    p.add_argument("--episodes", type=int, default=4, help="episodes per cell (worlds 0..N-1)")
    p.add_argument("--planners", nargs="+", default=list(PLANNERS), help="planners measured")
    p.add_argument("--envs", nargs="+", default=list(ENVS), choices=ENVS, help="houses measured")
    p.add_argument("--worlds", nargs="+", default=list(WORLDS), help="world distributions (house sizes)")
    p.add_argument("--quick", action="store_true", help="one episode per cell, the fake house only")
    p.add_argument("--out", type=out_file, default=DEFAULT_OUT, help="the Markdown table (the CSV goes beside it)")
    return p


def measure_cell(env: str, world: str, planner: str, episodes: int) -> dict:
    """One cell: `episodes` episodes run one after another, each timed in CPU seconds."""
    from fg_tea.env import table_cache
    from fg_tea.study.sweep import job_world, plan_sweep, run_job

    jobs = plan_sweep([world], episodes, ["factorised"], [planner], env=env)
    with tempfile.TemporaryDirectory(prefix="fg_tea_bench_cache_") as cache:
        saved = os.environ.get("FG_TEA_CACHE_DIR")
        os.environ["FG_TEA_CACHE_DIR"] = cache
        table_cache.MEMORY.clear()
        try:
            cpu, sites, done = [], [], 0
            for job in jobs:
                t0 = time.process_time()
                row = run_job(job)
                cpu.append(time.process_time() - t0)
                sites.append(len(job_world(job.world, job.knobs).sample(job.world_seed).site_names))
                done += int(bool(row.get("success")))
        finally:
            if saved is None:
                os.environ.pop("FG_TEA_CACHE_DIR", None)
            else:
                os.environ["FG_TEA_CACHE_DIR"] = saved
    mean = sum(cpu) / len(cpu)
    return {"env": env, "world": world, "planner": planner, "episodes": len(cpu),
            "sites_mean": f"{sum(sites) / len(sites):.1f}", "cpu_s_mean": f"{mean:.3f}",
            "cpu_s_max": f"{max(cpu):.3f}", "episodes_per_cpu_s": f"{1.0 / mean:.3f}",
            "success": f"{done / len(cpu):.2f}"}


def markdown(rows: list[dict], command: str) -> str:
    lines = ["# Episodes per CPU-second", "", f"`{command}`", "",
             f"One process on {platform.machine()} ({os.cpu_count()} cores), Python "
             f"{platform.python_version()}; every episode's CPU included (house, tables, beliefs, planning).", ""]
    columns = ("env", "world", "sites_mean", "planner", "episodes", "cpu_s_mean", "cpu_s_max", "episodes_per_cpu_s",
               "success")
    lines += table_lines(["house", "world", "sites (mean)", "planner", "episodes", "CPU s / episode (mean)",
                          "CPU s (max)", "episodes / CPU-s", "success"], [[r[c] for c in columns] for r in rows],
                         align="llrlrrrrr")
    lines += ["", f"## {LARGE_RUN:,} worlds", "",
              f"What a comparison of {LARGE_RUN:,} worlds costs with these planners (one model): "
              f"{LARGE_RUN:,} x the sum of the planners' mean CPU seconds per episode above.", ""]
    estimates = []
    for env in dict.fromkeys(r["env"] for r in rows):
        for world in dict.fromkeys(r["world"] for r in rows if r["env"] == env):
            cell = [r for r in rows if r["env"] == env and r["world"] == world]
            hours = LARGE_RUN * sum(float(r["cpu_s_mean"]) for r in cell) / 3600
            estimates.append([env, world, ", ".join(r["planner"] for r in cell), f"{LARGE_RUN * len(cell):,}",
                              f"{hours:.1f}"])
    lines += table_lines(["house", "world", "planners", "episodes", "CPU hours (estimate)"], estimates, align="lllrr")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.episodes < 1:
        build_parser().error("--episodes must be at least 1")
    envs, episodes = (["fake"], 1) if args.quick else (args.envs, args.episodes)
    rows = []
    for env in envs:
        for world in args.worlds:
            for planner in args.planners:
                rows.append(measure_cell(env, world, planner, episodes))
                r = rows[-1]
                print(f"{env} {world} {planner}: {r['cpu_s_mean']} CPU s per episode "
                      f"({r['episodes_per_cpu_s']} per CPU-s)", file=sys.stderr, flush=True)
    out = Path(args.out)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, FIELDS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    atomic_write_text(out.with_suffix(".csv"), buffer.getvalue())
    command = "python experiments/bench_throughput.py " + " ".join(argv if argv is not None else sys.argv[1:])
    atomic_write_text(out, markdown(rows, command.strip()))
    print(f"wrote {out} and {out.with_suffix('.csv')}")
    return 0


if __name__ == "__main__":
    run_script(main, "bench_throughput.py")
