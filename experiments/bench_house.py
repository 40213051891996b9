"""How fast is the PyBullet house? Scene build, one inspection and per-frame render costs.

Reports, side by side in one run (issue 5): scene build + distance fields (construction and first
reset), one inspection with movement excluded (the agent already stands at the vantage, facing
the site; the egocentric render and the pixel counts of eq. 28 with the association test of
eq. 29), both with the region-of-interest render (default) and the full image, and the render time
per frame of the egocentric and chase cameras at 160x120 and 640x360 (and the default egocentric
size). Target: an inspection under 20 ms at the default egocentric resolution.

Usage: python experiments/bench_house.py [--repeats N] [--scenario NAME]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

from fg_tea.env.base import EnvConfig
from fg_tea.env.house import PyBulletHouse
from fg_tea.scenario import load_scenario

TARGET_MS = 20.0


def _time(fn, repeats: int) -> float:
    """Median wall time of `fn()` in milliseconds over `repeats` calls (after one warm-up)."""
    fn()
    samples = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        samples.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(samples)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="timed repetitions per row (median)")
    parser.add_argument("--scenario", default="default_apartment")
    args = parser.parse_args(argv)
    scenario = load_scenario(args.scenario)
    config = EnvConfig()
    rows: list[tuple[str, float]] = []

    def progress(msg: str) -> None:
        print(f"  ... {msg}", file=sys.stderr, flush=True)

    progress("scene build + distance fields")
    builds = []
    for _ in range(max(1, args.repeats)):
        t0 = time.perf_counter()
        house = PyBulletHouse(scenario, config)
        house.reset(0)
        builds.append((time.perf_counter() - t0) * 1e3)
        house.close()
    rows.append(("scene build + distance fields", statistics.median(builds)))

    house = PyBulletHouse(scenario, config)
    house.reset(0)
    objects = list(scenario.object_names)
    inspect = {}
    for roi in (True, False):
        house.roi = roi
        label = "ROI window" if roi else "full image"
        progress(f"inspection ({label}) at every site")
        per_site = []
        for site in scenario.sites:
            house.reset(0)
            for obj in objects:  # every object on the inspected site: the costliest case
                house.move_object(obj, site.name)
            house.inspect_site(site.name, [])  # move and face first: movement excluded below
            per_site.append(_time(lambda: house.inspect_site(site.name, objects), args.repeats))
        inspect[roi] = statistics.mean(per_site)
        rows.append((f"one inspection, {label}, {config.ego_width}x{config.ego_height}", inspect[roi]))
    house.roi = True

    house.reset(0)
    house.inspect_site("kitchen_counter", [])
    for w, h in ((160, 120), (config.ego_width, config.ego_height), (640, 360)):
        progress(f"render {w}x{h}")
        rows.append((f"egocentric frame {w}x{h}", _time(lambda: house.render_ego(w, h), args.repeats)))
        rows.append((f"chase frame {w}x{h}", _time(lambda: house.render_chase(w, h), args.repeats)))
    house.close()

    base = inspect[True]
    print(f"\nPyBullet house benchmark: scenario {scenario.name}, median of {args.repeats} runs")
    print(f"{'what':<44} {'ms':>9} {'x ROI inspection':>17}")
    for name, ms in rows:
        print(f"{name:<44} {ms:9.2f} {ms / base:17.2f}")
    met = inspect[True] < TARGET_MS
    print(f"\ntarget: one inspection < {TARGET_MS:.0f} ms at {config.ego_width}x{config.ego_height}: "
          f"{'met' if met else 'NOT met'} ({inspect[True]:.2f} ms with the ROI render; "
          f"{inspect[False]:.2f} ms rendering the full image, "
          f"{'met' if inspect[False] < TARGET_MS else 'not met'})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
