"""How fast is exact inference for a user factor beyond the dense joint (docs/design.md §4.8)?

A 45-site house (rooms of four or five sites), five objects (kettle, teabag, mug, spoon, jar), the
bundled joint model's relations (teabag-kettle co-location; capacity where named) and a user
factor over three objects (kettle, mug, spoon: x3 when the three share a room, x0.5 when the mug
and the spoon share a site, x1.5 when the kettle is on one of the first five sites): 45^5 =
184,528,125 joint states, beyond the dense limit, so the engine answers by variable elimination
(:mod:`fg_tea.beliefs.eliminated`). Each run absorbs a sequence of looks (eq. 4's collapse for a
detection, eqs. 5-6 for misses) and times, in CPU seconds (``time.process_time``), every call:

- **update**: ``observe_site`` then all five location marginals;
- **hypotheticals**: ``hypothetical_all()`` — every object x every site, miss and seen (450
  posteriors of all five marginals), from the pairwise marginals of the new evidence;
- **EFE decision** (after every tenth look): the EFE planner over close looks at all 45 sites for
  every object still unfound, with its exact joint information gain from the elimination method
  (:mod:`fg_tea.planning.eliminated_gain`: one elimination per object and site).

Median, mean (every call included) and 95th percentile are reported. Cases: without capacity,
with capacity 1 on three sites, and with capacity 1 on every third site (15 sites), which is
refused in one line by the budget. The same evidence on the same house cut to 12 sites (248,832
states) is answered by the dense joint and by elimination, and their largest difference over the
marginals and every hypothetical posterior is reported, with the elimination method's distance
from gtsam's marginals (the exactness checks of the run).

Run ``nice python experiments/bench_program_scale.py`` (about a minute; writes
``runs/experiments/bench_program_scale/bench_program_scale.md``) or ``--quick`` for a smoke run.
The committed table changes only when ``--out`` names it:

    nice python experiments/bench_program_scale.py --out experiments/results/bench_program_scale.md
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from fg_tea.beliefs.eliminated import EliminationRefused  # noqa: E402
from fg_tea.beliefs.engine import BeliefEngine  # noqa: E402
from fg_tea.beliefs.factors import Factor  # noqa: E402
from fg_tea.beliefs.graph import BeliefGraph, assemble_graph  # noqa: E402
from fg_tea.common.errors import PlannerRefused  # noqa: E402
from fg_tea.common.files import atomic_write_text, out_file  # noqa: E402
from fg_tea.common.options import experiment_parser  # noqa: E402
from fg_tea.common.tables import table_lines  # noqa: E402
from fg_tea.model.spec import Model, load_model  # noqa: E402
from fg_tea.planning.base import DistanceTable  # noqa: E402
from fg_tea.planning.efe import EFEPlanner  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = Path("runs") / "experiments" / "bench_program_scale" / "bench_program_scale.md"
OBJECTS = ("kettle", "teabag", "mug", "spoon", "jar")
USER_SCOPE = ("kettle", "mug", "spoon")
TARGET_UPDATE_MS, TARGET_HYPOTHETICAL_MS = 20.0, 100.0


def rooms_of(k: int) -> list[str]:
    return [f"room{j * 10 // 45}" for j in range(k)]


def user_factor(k: int) -> Factor:
    """The user's factor over (kettle, mug, spoon), as a dense K^3 table."""
    rooms = np.array(rooms_of(k))
    same_room = (rooms[:, None, None] == rooms[None, :, None]) & (rooms[None, :, None] == rooms[None, None, :])
    table = np.where(same_room, 3.0, 1.0)
    table = table * np.where(np.eye(k, dtype=bool)[None, :, :], 0.5, 1.0)
    table = table * np.where(np.arange(k)[:, None, None] < 5, 1.5, 1.0)
    return Factor(tuple(f"L[{o}]" for o in USER_SCOPE), table, "user kettle~mug~spoon")


def house(model: Model, k: int, capacity_every: int | None, seed: int = 3) -> BeliefGraph:
    rng = np.random.default_rng(seed)
    caps = [1 if capacity_every and j % capacity_every == 0 else None for j in range(k)]
    graph = assemble_graph(model, [f"site{j}" for j in range(k)], rooms_of(k), list(OBJECTS),
                           ["kettle", "teabag", "mug", "spoon", "jar"],
                           rng.gamma(1.0, 1.0, (len(OBJECTS), k)) + 0.02, capacities=caps)
    return replace(graph, extra=(user_factor(k),))


def looks(k: int, count: int, seed: int = 5) -> list[tuple[int, dict[str, bool]]]:
    """A search: misses of every object at random sites, one detection of the jar midway."""
    rng = np.random.default_rng(seed)
    out = []
    for t in range(count):
        site = int(rng.integers(0, k))
        outcome = {o: False for o in OBJECTS}
        if t == count // 2:
            outcome["jar"] = True
        out.append((site, outcome))
    return out


def timed_run(engine: BeliefEngine, sequence) -> tuple[list[float], list[float], list[float] | str]:
    """CPU seconds of every update and every hypothetical_all; and of an EFE decision (close looks,
    every object, the exact joint gain) after every tenth look, or the planner's refusal."""
    updates, hypotheticals = [], []
    decisions: list[float] | str = []
    planner = EFEPlanner(engine.model.planning)
    try:
        planner.check(engine, list(engine.objects))
    except PlannerRefused as exc:
        decisions = str(exc)
    k = len(engine.sites)
    distances = DistanceTable(engine.sites, tuple(float(j % 7) for j in range(k)),
                              tuple(tuple(float(abs(a - b) % 7) for b in range(k)) for a in range(k)))
    for t, (site, outcome) in enumerate(sequence):
        start = time.process_time()
        engine.observe_site(engine.sites[site], outcome)
        engine.location_matrix()
        updates.append(time.process_time() - start)
        start = time.process_time()
        engine.hypothetical_all()
        hypotheticals.append(time.process_time() - start)
        if t % 10 == 0 and isinstance(decisions, list):
            unfound = [o for o in engine.objects if o != "jar" or t < len(sequence) // 2]
            start = time.process_time()
            planner.choose(engine, unfound, {o: 1.0 for o in unfound}, distances, {})
            decisions.append(time.process_time() - start)
    return updates, hypotheticals, decisions


def stats(xs: list[float]) -> tuple[float, float, float]:
    ms = np.array(xs) * 1e3
    return float(np.median(ms)), float(np.mean(ms)), float(np.percentile(ms, 95))


def exactness(model: Model, sequence) -> tuple[float, float]:
    """Largest |elimination - dense| over marginals and hypotheticals, the house cut to 12 sites,
    and the largest difference of the elimination method's marginals from gtsam's."""
    k = 12
    graph = house(model, k, 6)
    engines = [BeliefEngine(graph, model, location_solver=s) for s in ("elimination", "dense")]
    worst = 0.0
    for site, outcome in sequence[:6]:
        for e in engines:
            e.observe_site(e.sites[site % k], outcome)
        worst = max(worst, float(np.abs(engines[0].location_matrix() - engines[1].location_matrix()).max()))
        for a, b in zip(engines[0].hypothetical_all(), engines[1].hypothetical_all()):
            worst = max(worst, float(np.abs(a - b).max()))
    return worst, engines[0].check_against_gtsam()


def run(count: int) -> str:
    joint = load_model(ROOT / "models" / "joint.toml")
    no_capacity = joint.with_overrides(relations=tuple(r for r in joint.relations if r.kind != "capacity"))
    k = 45
    sequence = looks(k, count)
    lines = ["# Exact inference with a user factor beyond the dense joint", "",
             f"45 sites, 5 objects, a user factor over {', '.join(USER_SCOPE)}; 45^5 = {45 ** 5:,} "
             f"joint states. {count} looks (misses of every object, one detection of the jar), each "
             "timed in CPU ms (median / mean of every call / 95th percentile).", ""]
    cases = []
    verdicts = []
    for name, model, every in (("co-location + user factor", no_capacity, None),
                               ("+ capacity 1 on 3 sites", joint, 15),
                               ("+ capacity 1 on 15 sites", joint, 3)):
        try:
            engine = BeliefEngine(house(model, k, every), model)
        except EliminationRefused as exc:
            cases.append([name, "refused"] + ["—"] * 9)
            verdicts.append(f"- {name}: refused in one line: `{exc}`")
            continue
        plan = engine._elim_plan
        parts = " + ".join(str(len(c.objects)) for c in plan.components)
        updates, hyps, decisions = timed_run(engine, sequence)
        u, h = stats(updates), stats(hyps)
        if isinstance(decisions, str):
            dec_cells = ["refused", "—"]
        else:
            dec = stats(decisions)
            dec_cells = [f"{dec[0]:.0f}", f"{dec[1]:.0f}"]
        cases.append([name, engine.location_method, parts, f"{u[0]:.1f}", f"{u[1]:.1f}", f"{u[2]:.1f}",
                      f"{h[0]:.1f}", f"{h[1]:.1f}", f"{h[2]:.1f}", *dec_cells])
        ok = u[0] <= TARGET_UPDATE_MS and h[0] <= TARGET_HYPOTHETICAL_MS
        verdicts.append(f"- {name}: update median {u[0]:.1f} ms (target <= {TARGET_UPDATE_MS:g}), all "
                        f"hypothetical posteriors median {h[0]:.1f} ms (target <= {TARGET_HYPOTHETICAL_MS:g}): "
                        f"{'holds' if ok else 'MISSED'}")
        if isinstance(decisions, str):
            verdicts.append(f"- {name}: the EFE planner refuses in one line: `{decisions}`")
    lines += table_lines(["case", "method", "components (objects)", "update median", "mean", "p95",
                          "hypothetical_all median", "mean", "p95", "EFE decision median", "mean"], cases, align="left")
    dense_gap, gtsam_gap = exactness(joint, sequence)
    lines += ["", "Targets:", *verdicts, "",
              f"Exactness: the same looks on the house cut to 12 sites (248,832 states, capacity 1 on "
              f"two sites), elimination vs the dense joint, largest difference over marginals and every "
              f"hypothetical posterior: {dense_gap:.1e}; vs gtsam's marginals (check_against_gtsam): "
              f"{gtsam_gap:.1e}.", ""]
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    parser = experiment_parser(__doc__, __file__, "§4.8")
    parser.add_argument("--quick", action="store_true", help="smoke run (6 looks)")
    parser.add_argument("--looks", type=int, default=40, help="looks absorbed per case")
    parser.add_argument("--out", type=out_file, default=DEFAULT_OUT,
                        help="markdown output (committed: experiments/results/bench_program_scale.md)")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    start = time.perf_counter()
    text = run(6 if args.quick else args.looks)
    print(text)
    print(f"(total {time.perf_counter() - start:.0f} s)")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, text)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
