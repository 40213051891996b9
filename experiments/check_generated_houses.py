"""Do generated houses always work? Generate, validate and run one PyBullet episode per house.

For every room count (default 3-10) and seed (default 0-49) this script generates a house with
:func:`fg_tea.world.housegen.generate_house`, validates it (:func:`fg_tea.world.scenario.parse_scenario`),
builds it in the PyBullet house and runs one headless make-tea episode through the public runner
API (``EpisodeRunner(...).step()`` until done, ``RunConfig(seed=...)``). Any exception, an episode
that does not succeed, or one still running after ``--max-steps`` runner steps counts as a
failure. It prints a table per room count (houses, failures, sites, episode frames, seconds) and
writes ``houses.csv`` (one row per house) and ``summary.md`` to ``--out`` (default
``runs/experiments/check_generated_houses``).

    python experiments/check_generated_houses.py                 # 50 seeds x rooms 3-10, serial
    python experiments/check_generated_houses.py --seeds 5 --rooms 3 4 --workers 2

Wall-clock times are measured on this machine and vary with load; everything else is a pure
function of the arguments.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

#: Default output folder, relative to the working directory like every fg-tea output under runs/.
DEFAULT_OUT = Path("runs") / "experiments" / "check_generated_houses"

from fg_tea.common.files import out_folder, atomic_path, atomic_write_text
from fg_tea.common.options import MODEL_HELP, WORKERS_HELP, experiment_parser
from fg_tea.common.tables import table_lines

COLUMNS = ("rooms", "seed", "ok", "stage", "error", "sites", "room_vantages", "success", "reason",
           "frames", "inspections", "generate_s", "build_s", "episode_s")


def check_one(job: tuple[int, int, str, int]) -> dict:
    """Generate, validate, build and run house (rooms, seed); return its row."""
    rooms, seed, model_name, max_steps = job
    from fg_tea.env.house import PyBulletHouse
    from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
    from fg_tea.world.housegen import generate_house
    from fg_tea.model.spec import load_model
    from fg_tea.world.scenario import parse_scenario

    row: dict = {"rooms": rooms, "seed": seed, "ok": False, "stage": "generate", "error": ""}
    env = None
    try:
        t0 = time.perf_counter()
        doc = generate_house(rooms, seed)
        row["stage"] = "validate"
        scenario = parse_scenario(doc, f"<house rooms={rooms} seed={seed}>")
        row["sites"], row["room_vantages"] = len(scenario.sites), len(scenario.room_vantages)
        t1 = time.perf_counter()
        row["stage"] = "build"
        model = load_model(model_name)
        env = PyBulletHouse(scenario, env_config_for(model))
        runner = EpisodeRunner(scenario, model, env, RunConfig(seed=seed))
        t2 = time.perf_counter()
        row["stage"] = "episode"
        steps = 0
        while not runner.done and steps < max_steps:
            runner.step()
            steps += 1
        t3 = time.perf_counter()
        metrics = runner.metrics()
        row.update(success=bool(metrics["success"]) and runner.done,
                   reason=metrics["reason"] if runner.done else f"not done after {max_steps} steps",
                   frames=metrics.get("frames"), inspections=metrics.get("inspections"),
                   generate_s=round(t1 - t0, 3), build_s=round(t2 - t1, 3), episode_s=round(t3 - t2, 3))
        row["ok"] = row["success"]
        row["stage"] = "done"
    except Exception as exc:  # a failure to report, not to hide: the row keeps the message
        row["error"] = f"{type(exc).__name__}: {' '.join(str(exc).split())}"[:300]
        row["traceback"] = traceback.format_exc()
    finally:
        if env is not None:
            env.close()
    return row


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§8.1")
    p.add_argument("--seeds", type=int, default=50, help="house seeds 0..N-1 per room count")
    p.add_argument("--rooms", type=int, nargs="+", default=list(range(3, 11)),
                   help="room counts of the generated houses")
    p.add_argument("--model", default="factorised", help=MODEL_HELP)
    p.add_argument("--max-steps", type=int, default=2000, help="runner steps per episode")
    p.add_argument("--workers", type=int, default=1, help=WORKERS_HELP)
    p.add_argument("--out", type=out_folder, default=str(DEFAULT_OUT), help="output folder (default: %(default)s)")
    return p


def main(argv: list[str] | None = None) -> int:
    p = build_parser()
    args = p.parse_args(argv)

    jobs = [(r, s, args.model, args.max_steps) for r in args.rooms for s in range(args.seeds)]
    t0 = time.perf_counter()
    if args.workers > 1:
        with ProcessPoolExecutor(args.workers) as pool:
            rows = list(pool.map(check_one, jobs, chunksize=4))
    else:
        rows = []
        for i, job in enumerate(jobs):
            rows.append(check_one(job))
            if (i + 1) % 25 == 0:
                print(f"  {i + 1}/{len(jobs)} houses, {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    wall = time.perf_counter() - t0

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / "houses.csv") as tmp, tmp.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, COLUMNS, extrasaction="ignore", lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)

    by_rooms = []
    for rooms in args.rooms:
        rs = [r for r in rows if r["rooms"] == rooms]
        good = [r for r in rs if "episode_s" in r]
        sites = [r["sites"] for r in rs if "sites" in r]
        mean = lambda k: statistics.fmean(r[k] for r in good) if good else float("nan")  # noqa: E731
        by_rooms.append([
            rooms, len(rs), sum(not r["ok"] for r in rs),
            f"{min(sites, default=0)}-{max(sites, default=0)}, {statistics.fmean(sites) if sites else 0:.1f}",
            f"{mean('room_vantages'):.1f}", f"{statistics.median(r['frames'] for r in good) if good else 0:.0f}",
            f"{mean('generate_s'):.2f}", f"{mean('build_s'):.2f}",
            f"{mean('episode_s'):.2f}, {max((r['episode_s'] for r in good), default=0):.2f}"])
    lines = table_lines(["rooms", "houses", "failures", "sites (min-max, mean)", "room vantages (mean)",
                         "frames (median)", "generate s (mean)", "build s (mean)", "episode s (mean, max)"],
                        by_rooms, align="left")
    failures = [r for r in rows if not r["ok"]]
    totals = [len(rows), sum(r["stage"] in ("build", "episode", "done") for r in rows),
              sum(r["stage"] in ("episode", "done") for r in rows), sum(r["ok"] for r in rows), len(failures)]
    fail_lines = [f"- rooms {r['rooms']} seed {r['seed']}: {r['stage']}: {r.get('error') or r.get('reason')}"
                  for r in failures] or ["- none"]
    text = "\n".join([
        "# Generated houses: validation and one PyBullet episode each", "",
        f"Command: `python experiments/check_generated_houses.py --seeds {args.seeds} --rooms "
        f"{' '.join(map(str, args.rooms))} --model {args.model} --workers {args.workers}`", "",
        f"{len(rows)} houses, {len(failures)} failures, {wall:.0f} s wall clock "
        f"({args.workers} worker(s); times depend on machine load).", "", "## Totals", "",
        *table_lines(["houses", "validated", "built", "complete", "failures"], [totals], align="left"),
        "", "## By room count", "", *lines, "", "## Failures", "",
        *fail_lines, ""])
    atomic_write_text(out / "summary.md", text)
    print(text)
    for r in failures[:3]:
        print(r.get("traceback", ""), file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    raise SystemExit(main())
