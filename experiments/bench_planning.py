"""Decision latency of every planner at 3 objects x {6, 8, 12} sites, factorised and joint beliefs.

Which question it answers: how long does one planning decision (docs/design.md eq. (17), or a baseline
behind the same interface) take on the agent's belief, and does the EFE planner meet the target of
under 5 ms per decision on the joint 3-object x 8-site model?

Houses are synthetic, random but seeded: K sites scattered over four rooms of a 10 m x 8 m floor,
random affordance weights for mug, kettle and teabag, a few sites with capacity 1-2; built through
``fg_tea.scenario.parse_scenario``. Models are the bundled ``factorised`` and ``joint`` ones. Each
timed decision follows a fresh observation (a miss of every object at a random site, applied to a
copy of the belief before the clock starts), as in an episode, so caches hold only what
``observe_site`` itself computes. The inspection counts passed are empty, so every planner (the
optimal one included) plans over all K sites. The optimal planner runs only where it is feasible
and prints "refused" beyond its site limit.

Usage::

    PYTHONPATH=. python experiments/bench_planning.py [--repeats 20] [--seed 0] [--sites 6 8 12]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from fg_tea.beliefs.engine import BeliefEngine
from fg_tea.model import load_model
from fg_tea.planning import euclidean_distances, make_planner, planner_names
from fg_tea.scenario import parse_scenario

OBJECTS = ("mug", "kettle", "teabag")
ROOMS = (("kitchen", (0.0, 0.0), (5.0, 4.0)), ("dining", (0.0, 4.0), (5.0, 8.0)),
         ("living", (5.0, 0.0), (10.0, 4.0)), ("study", (5.0, 4.0), (10.0, 8.0)))
TARGET_MS = 5.0


def synthetic_scenario(n_sites: int, rng: np.random.Generator):
    """A seeded random house with `n_sites` sites and the three tea objects."""
    sites = []
    for i in range(n_sites):
        room, lo, hi = ROOMS[i % len(ROOMS)]
        x, y = rng.uniform(np.add(lo, 0.6), np.subtract(hi, 0.6))
        site = {"name": f"site_{i:02d}", "room": room, "position": [float(x), float(y), 0.8],
                "vantage_position": [float(x), float(y) - 0.5, 0.0],
                "affordances": {o: float(rng.uniform(0.01, 1.0)) for o in OBJECTS}}
        if rng.random() < 0.25:
            site["capacity"] = int(rng.integers(1, 3))
        sites.append(site)
    objects = [{"name": o, "category": o, "true_site": sites[int(rng.integers(n_sites))]["name"],
                "semantic_id": 100 + i} for i, o in enumerate(OBJECTS)]
    return parse_scenario({
        "schema_version": 2, "name": f"synthetic_{n_sites}", "start_pose": {"position": [5.0, 4.0]},
        "house": {"floor": {"min": [0, 0], "max": [10, 8]}, "walls": [], "furniture": []},
        "sites": sites, "objects": objects}, f"<synthetic {n_sites} sites>")


def time_decisions(planner_name: str, model, scenario, repeats: int, seed: int) -> tuple[str, list[float]]:
    """Median-ready decision times (ms) of one planner, or ("refused", []) when it declines."""
    rng = np.random.default_rng(seed)
    base = BeliefEngine(scenario, model)
    planner = make_planner(planner_name, model, np.random.default_rng(seed))
    relevance = {"mug": 1.0, "kettle": 0.9, "teabag": 0.6}
    times = []
    for _ in range(repeats):
        belief = base.copy()
        site = scenario.site_names[int(rng.integers(len(scenario.sites)))]
        belief.observe_site(site, {o: False for o in OBJECTS})
        distances = euclidean_distances(scenario, rng.uniform([0, 0], [10, 8]))
        start = time.perf_counter()
        try:
            planner.choose(belief, list(OBJECTS), relevance, distances, {})
        except ValueError as exc:
            if "exceed the limit" in str(exc):
                return "refused", []
            raise
        times.append((time.perf_counter() - start) * 1e3)
    return "ok", times


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=10, help="decisions timed per cell (default 10)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--sites", type=int, nargs="+", default=[6, 8, 12])
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")

    models = {"factorised": load_model("factorised"), "joint": load_model("joint")}
    names = planner_names()
    cells = [(m, k) for m in models for k in args.sites]
    results: dict[tuple[str, int, str], str | float] = {}
    total, done = len(cells) * len(names), 0
    for m, k in cells:
        scenario = synthetic_scenario(k, np.random.default_rng(args.seed * 1000 + k))
        for name in names:
            status, times = time_decisions(name, models[m], scenario, args.repeats, args.seed)
            done += 1
            value = statistics.median(times) if times else status
            results[(m, k, name)] = value
            shown = f"{value:8.3f} ms" if isinstance(value, float) else value
            print(f"[{done:2d}/{total}] {m:10s} 3x{k:<2d} {name:15s} {shown}", flush=True)

    print()
    print(f"median decision latency (ms) over {args.repeats} decisions; ratio = planner / efe")
    header = f"{'model':10s} {'size':5s} " + " ".join(f"{n:>20s}" for n in names)
    print(header)
    print("-" * len(header))
    for m, k in cells:
        ref = results[(m, k, "efe")]
        row = []
        for n in names:
            v = results[(m, k, n)]
            row.append(f"{v:9.3f} ({v / ref:6.2f}x)" if isinstance(v, float) else f"{v:>20s}")
        print(f"{m:10s} 3x{k:<3d} " + " ".join(f"{c:>20s}" for c in row))
    print()
    key = ("joint", 8, "efe")
    if key in results and isinstance(results[key], float):
        met = results[key] < TARGET_MS
        print(f"target: EFE decision on the joint 3x8 model < {TARGET_MS:.0f} ms: "
              f"{results[key]:.3f} ms -> {'met' if met else 'NOT met'}")
        return 0 if met else 1
    print("target: joint 3x8 not measured (pass --sites including 8)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
