"""Benchmark whole episodes: headless (--no-video) and with video, per model, side by side.

Targets: a headless default episode under 2 s of wall time after import, and video
rendering at >= 20 output frames per second at 640x360, on this 2-core machine. Measured in one
run so the numbers share the machine's load; ratios are to the factorised headless episode.

    python experiments/bench_episode.py [--repeats 3] [--models factorised joint] [--quick]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

from fg_tea.env.house import PyBulletHouse
from fg_tea.common.options import MODELS_HELP, SCENARIO_HELP, experiment_parser
from fg_tea.episode.log import EventLog
from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
from fg_tea.model.spec import load_model
from fg_tea.render.video import VideoOptions, render_video
from fg_tea.world.scenario import load_scenario


def headless(scenario: str, model: str, seed: int, log_path: Path) -> tuple[float, list[dict]]:
    """Wall time of one headless episode (scenario and model loading included)."""
    t = time.perf_counter()
    s, m = load_scenario(scenario), load_model(model)
    env = PyBulletHouse(s, env_config_for(m))
    with EventLog(log_path) as log:
        runner = EpisodeRunner(s, m, env, RunConfig(seed=seed), log)
        runner.run()
    env.close()
    if runner.reason != "complete":
        raise SystemExit(f"episode did not complete: {runner.reason}")
    return time.perf_counter() - t, runner.events


def build_parser() -> argparse.ArgumentParser:
    parser = experiment_parser(__doc__, __file__, "§11")
    parser.add_argument("--scenario", default="default_apartment", help=SCENARIO_HELP)
    parser.add_argument("--models", nargs="+", default=["factorised", "joint"], help=MODELS_HELP)
    parser.add_argument("--repeats", type=int, default=3, help="headless repeats (median reported)")
    parser.add_argument("--width", type=int, default=640, help="video width, pixels")
    parser.add_argument("--height", type=int, default=360, help="video height, pixels")
    parser.add_argument("--quick", action="store_true", help="tiny smoke run (small video, stride 10)")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    width, height, stride = (160, 90, 10) if args.quick else (args.width, args.height, 1)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for model in args.models:
            times = []
            for r in range(args.repeats):
                print(f"[{model}] headless episode {r + 1}/{args.repeats}", file=sys.stderr, flush=True)
                dt, events = headless(args.scenario, model, 0, Path(tmp) / f"{model}.jsonl")
                times.append(dt)
            print(f"[{model}] video episode at {width}x{height}", file=sys.stderr, flush=True)
            t = time.perf_counter()
            result = render_video(events, Path(tmp) / f"{model}.mp4",
                                  VideoOptions(width=width, height=height, frame_stride=stride))
            video_s = time.perf_counter() - t
            rows.append((model, statistics.median(times), video_s, result["frames"], result["rendered"]))
    base = rows[0][1]
    print(f"\nscenario {args.scenario}, video {width}x{height} (stride {stride}), "
          f"headless median of {args.repeats}\n")
    print(f"{'model':<12} {'headless s':>10} {'ratio':>6} {'video s':>8} {'out frames':>10} "
          f"{'out fps':>8} {'rendered':>9}")
    for model, h, v, frames, rendered in rows:
        print(f"{model:<12} {h:>10.3f} {h / base:>6.2f} {v:>8.1f} {frames:>10d} {frames / v:>8.1f} {rendered:>9d}")
    ok_headless = all(r[1] < 2.0 for r in rows)
    ok_video = all(r[3] / r[2] >= 20.0 for r in rows)
    print(f"\ntarget headless < 2 s: {'met' if ok_headless else 'NOT met'}; "
          f"video >= 20 fps at {width}x{height}: {'met' if ok_video else 'NOT met'}"
          + (" (quick run: not the target size)" if args.quick else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
