"""How fast is exact location inference, and where does each method stop being feasible?

Side by side in one run, on the same factors, for factorised and joint location models of
N objects x K sites (N in 3, 5, 8; K in 6, 12, 24; sites in rooms of four; joint = capacity 1 on
every third site with penalty 0.05, teabag-kettle co-location x3 / x2, and exclusivity 0.05
between every pair of objects; the relational factors of docs/design.md §3.7):

- (a) **update**: one evidence update (every object missed at one site, eqs. 5-6) followed by
  all N location marginals;
- (b) **planner set**: the same update, then one planner's worth of hypothetical queries — every
  object x every site, miss and seen (2·N·K posteriors of all N marginals), i.e.
  ``BeliefEngine.hypothetical_all`` (nothing computed by a separate update call is reused).

Methods:

- ``engine``: :class:`fg_tea.beliefs.engine.BeliefEngine`, numpy backend (closed forms, dense
  joint or the structured subset program, whichever is cheaper) — batched hypotheses from
  pairwise marginals;
- ``gtsam``: the same engine with ``backend="gtsam"``: gtsam ``DiscreteMarginals`` per query and
  one re-solve per hypothesis;
- ``pgmpy``: pgmpy ``VariableElimination`` on the same factors (unary evidence merged per
  variable first, avoiding pgmpy's duplicate-factor pitfall), one query per hypothesis;
- ``dense``: numpy enumeration of the K^N joint, re-marginalised per hypothesis.

Each call is timed (best of repeats for fast calls). A method is stopped once one call exceeds the
per-call budget; larger sizes whose predicted cost (growth with K^N, or 2·N·K single queries)
exceeds the budget are marked ``> budget``, and sizes whose K^N tables cannot be held are marked
``infeasible``. All methods are checked against the engine in the same run (max |difference|).

Run ``python experiments/bench_inference.py`` (a few minutes on 2 cores; writes
``runs/experiments/bench_inference/bench_inference.md``) or ``--quick`` for a smoke run (no file
unless ``--out`` is given). The committed table changes only when ``--out`` names it:

    python experiments/bench_inference.py --out experiments/results/bench_inference.md

``--paths`` instead measures the bundled models through the compiled path (``fg.compile_program``
of the model's program) against the engine's path side by side (experiments/bench_paths.py; CPU per
belief update and per decision, and their ratio against the target of 1.2x):

    python experiments/bench_inference.py --paths --out experiments/results/bench_paths.md
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")   # one thread per method, so every method is timed alike

import numpy as np  # noqa: E402

from fg_tea.common.files import atomic_write_text, out_file  # noqa: E402
from fg_tea.beliefs.engine import BeliefEngine  # noqa: E402
from fg_tea.common.options import experiment_parser  # noqa: E402
from fg_tea.common.tables import table_lines  # noqa: E402
from fg_tea.beliefs.factors import detection_factor, miss_factor  # noqa: E402
from fg_tea.beliefs.graph import DENSE_LIMIT, BeliefGraph, assemble_graph  # noqa: E402
from fg_tea.model.spec import Model, Relation, load_model  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: Output of the full run, relative to the working directory like every fg-tea output under runs/;
#: the committed table (experiments/results/bench_inference.md) changes only when --out names it.
DEFAULT_OUT = Path("runs") / "experiments" / "bench_inference" / "bench_inference.md"
METHODS = ("engine", "gtsam", "pgmpy", "dense")
SITES_PER_ROOM = 4


# ------------------------------------------------------------------ models
def bench_model(structure: str) -> Model:
    """The factorised model, or the joint model with the benchmark's relations."""
    base = load_model(ROOT / "models" / f"{structure}.toml")
    if structure == "factorised":
        return base.with_overrides(positive_update="likelihood")
    relations = (Relation("capacity", penalty=0.05),
                 Relation("co_location", categories=("teabag", "kettle"), same_site=3.0, same_room=2.0),
                 Relation("exclusivity", weight=0.05))
    return base.with_overrides(relations=relations, positive_update="likelihood")


def bench_graph(model: Model, n: int, k: int, seed: int = 7) -> BeliefGraph:
    """N objects (kettle, teabag, mug, then others) over K sites in rooms of four."""
    rng = np.random.default_rng(seed + 100 * n + k)
    categories = (["kettle", "teabag", "mug"] + [f"thing{i}" for i in range(n)])[:n]
    return assemble_graph(model, sites=[f"site{j}" for j in range(k)],
                          rooms=[f"room{j // SITES_PER_ROOM}" for j in range(k)],
                          objects=[f"obj{i}" for i in range(n)], categories=categories,
                          weights=rng.gamma(1.0, 1.0, size=(n, k)) + 0.02,
                          capacities=[1 if j % 3 == 0 else None for j in range(k)])


# ------------------------------------------------------------------ the reference factor set
@dataclass
class Problem:
    """One size: the graph, the evidence, and the factors every method is handed."""

    model: Model
    graph: BeliefGraph
    site: str
    unary: np.ndarray                         # (N, K) prior x evidence, merged per variable
    relational: list = field(default_factory=list)   # (variable indices, table)

    @property
    def n(self) -> int:
        return len(self.graph.objects)

    @property
    def k(self) -> int:
        return len(self.graph.sites)

    def likelihoods(self) -> list[tuple[int, int, bool, np.ndarray]]:
        """Every hypothesis (object, site, seen?, likelihood over that object's sites)."""
        mu, fp = self.model.miss_likelihood, self.model.false_positive_rate
        out = []
        for o, obj in enumerate(self.graph.objects):
            for j in range(self.k):
                out.append((o, j, False, miss_factor(obj, j, self.k, mu).table))
                out.append((o, j, True, detection_factor(obj, j, self.k, mu, fp).table))
        return out


def make_problem(structure: str, n: int, k: int) -> Problem:
    model = bench_model(structure)
    graph = bench_graph(model, n, k)
    site = graph.sites[1]
    unary = np.stack([f.table for f in graph.location_priors])
    unary = unary * np.stack([miss_factor(o, 1, k, model.miss_likelihood).table for o in graph.objects])
    problem = Problem(model, graph, site, unary / unary.sum(axis=1, keepdims=True))
    if graph.correlated and graph.joint_size <= DENSE_LIMIT:
        index = {f"L[{o}]": i for i, o in enumerate(graph.objects)}
        problem.relational = [([index[v] for v in f.variables], f.table) for f in graph.relational]
    return problem


def relational_feasible(p: Problem) -> bool:
    return not p.graph.correlated or p.graph.joint_size <= DENSE_LIMIT


# ------------------------------------------------------------------ the four methods
class EngineMethod:
    """fg_tea's BeliefEngine (numpy backend, or every query through gtsam)."""

    def __init__(self, p: Problem, backend: str) -> None:
        self.p = p
        self.base = BeliefEngine(p.graph, p.model, backend=backend)
        self.base.location_matrix()

    def _updated(self) -> BeliefEngine:
        belief = self.base.copy()
        belief.observe_site(self.p.site, {o: False for o in self.p.graph.objects})
        return belief

    def update(self) -> np.ndarray:
        return self._updated().location_matrix()

    def planner(self) -> tuple[np.ndarray, np.ndarray]:
        # From the belief before the update: nothing the update computed is reused.
        return self._updated().hypothetical_all()


class DenseMethod:
    """Numpy enumeration of the K^N joint; every hypothesis re-marginalised."""

    def __init__(self, p: Problem) -> None:
        self.p = p
        n, k = p.n, p.k
        rel = np.ones((k,) * n)
        for axes, table in p.relational:
            shape = [1] * n
            for a, size in zip(axes, table.shape):
                shape[a] = size
            rel = rel * table.reshape(shape)
        self.rel = rel

    def _joint(self, unary: np.ndarray) -> np.ndarray:
        n, k = unary.shape
        joint = self.rel
        for o in range(n):
            shape = [1] * n
            shape[o] = k
            joint = joint * unary[o].reshape(shape)
        return joint

    @staticmethod
    def _marginals(joint: np.ndarray) -> np.ndarray:
        n = joint.ndim
        total = joint.sum()
        return np.stack([joint.sum(axis=tuple(a for a in range(n) if a != o)) / total for o in range(n)])

    def update(self) -> np.ndarray:
        return self._marginals(self._joint(self.p.unary))

    def planner(self) -> tuple[np.ndarray, np.ndarray]:
        n, k = self.p.n, self.p.k
        joint = self._joint(self.p.unary)
        out = {False: np.empty((n, k, n, k)), True: np.empty((n, k, n, k))}
        for o, j, seen, lik in self.p.likelihoods():
            shape = [1] * n
            shape[o] = k
            out[seen][o, j] = self._marginals(joint * lik.reshape(shape))
        return out[False], out[True]


class PgmpyMethod:
    """pgmpy VariableElimination over the same factors, one query per hypothesis."""

    def __init__(self, p: Problem) -> None:
        warnings.filterwarnings("ignore")
        import logging

        logging.getLogger("pgmpy").setLevel(logging.ERROR)
        from pgmpy.factors.discrete import DiscreteFactor
        from pgmpy.inference import VariableElimination
        from pgmpy.models import DiscreteMarkovNetwork

        self.p = p
        self._factor, self._ve, self._net = DiscreteFactor, VariableElimination, DiscreteMarkovNetwork
        self.names = [f"L{o}" for o in range(p.n)]
        self.rel = [DiscreteFactor([self.names[a] for a in axes], list(table.shape), table.ravel())
                    for axes, table in p.relational]
        self.edges = sorted({(self.names[a], self.names[b]) for axes, _ in p.relational
                             for i, a in enumerate(axes) for b in axes[i + 1:]})

    def _marginals(self, unary: np.ndarray) -> np.ndarray:
        net = self._net()
        net.add_nodes_from(self.names)
        net.add_edges_from(self.edges)
        # Unary evidence is merged per variable: pgmpy keeps factors in sets, so two identical
        # evidence factors (the same miss twice) would collapse into one.
        net.add_factors(*[self._factor([v], [self.p.k], unary[o]) for o, v in enumerate(self.names)],
                        *self.rel)
        result = self._ve(net).query(self.names, joint=False, show_progress=False)
        rows = [np.asarray(result[v].values, dtype=float) for v in self.names]
        return np.stack([r / r.sum() for r in rows])

    def update(self) -> np.ndarray:
        return self._marginals(self.p.unary)

    def planner(self) -> tuple[np.ndarray, np.ndarray]:
        n, k = self.p.n, self.p.k
        out = {False: np.empty((n, k, n, k)), True: np.empty((n, k, n, k))}
        for o, j, seen, lik in self.p.likelihoods():
            unary = self.p.unary.copy()
            unary[o] = unary[o] * lik
            out[seen][o, j] = self._marginals(unary)
        return out[False], out[True]


def build(method: str, p: Problem):
    if method == "engine":
        return EngineMethod(p, "numpy")
    if method == "gtsam":
        return EngineMethod(p, "gtsam")
    if method == "pgmpy":
        return PgmpyMethod(p)
    return DenseMethod(p)


# ------------------------------------------------------------------ timing
@dataclass
class Cell:
    """One measurement: seconds, or why there is none."""

    seconds: float | None = None
    note: str = ""

    def text(self, reference: "Cell | None" = None) -> str:
        if self.seconds is None:
            return self.note
        s = self.seconds
        t = f"{s * 1e6:.0f} µs" if s < 1e-3 else f"{s * 1e3:.2f} ms" if s < 1 else f"{s:.2f} s"
        if reference is not None and reference.seconds:
            t += f" ({s / reference.seconds:.3g}×)"
        return t


def timed(fn, budget: float, min_total: float = 0.2, max_reps: int = 25):
    """(best seconds, result, over budget?) — repeats fast calls, never a slow one."""
    start = time.perf_counter()
    result = fn()
    best = time.perf_counter() - start
    if best > budget:
        return best, result, True
    total, reps = best, 1
    while total < min_total and reps < max_reps:
        start = time.perf_counter()
        fn()
        elapsed = time.perf_counter() - start
        best, total, reps = min(best, elapsed), total + elapsed, reps + 1
    return best, result, False


def fmt_s(seconds: float) -> str:
    return f"{seconds * 1e3:.0f} ms" if seconds < 1 else f"{seconds:.0f} s"


# ------------------------------------------------------------------ the run
def run(sizes: list[tuple[int, int]], structures: tuple[str, ...], budget: float,
        log=print) -> dict:
    """Measure every method on every size; returns cells, agreement and stopping points."""
    cells: dict[tuple, Cell] = {}
    agreement = {m: 0.0 for m in METHODS}
    order = sorted(sizes, key=lambda nk: (nk[1] ** nk[0], nk))
    for structure in structures:
        state = {m: {"last": None, "stopped": None} for m in METHODS}   # last = (K^N, seconds)
        for n, k in order:
            p = make_problem(structure, n, k)
            size = k ** n
            ref_update = ref_planner = None
            for method in METHODS:
                key = (structure, n, k, method)
                upd, plan = Cell(), Cell()
                st = state[method]
                infeasible = (method != "engine" and not relational_feasible(p)) or \
                             (method == "dense" and size > DENSE_LIMIT)
                if infeasible:
                    upd.note = plan.note = "infeasible"
                elif st["stopped"] is not None:
                    upd.note = plan.note = f"> budget (stopped at {st['stopped']})"
                elif st["last"] is not None and method != "engine" and \
                        st["last"][1] * size / st["last"][0] > budget:
                    guess = st["last"][1] * size / st["last"][0]
                    upd.note = plan.note = f"> budget (~{fmt_s(guess)})"
                else:
                    impl = build(method, p)
                    t, marg, over = timed(impl.update, budget)
                    upd.seconds = t
                    st["last"] = (size, t)
                    if method == "engine":
                        ref_update = marg
                    else:
                        agreement[method] = max(agreement[method], float(np.max(np.abs(marg - ref_update))))
                    if over:
                        st["stopped"] = f"{n}×{k}"
                    predicted = t * 2 * n * k
                    if method in ("engine",):
                        predicted = 0.0
                    if predicted > budget:
                        plan.note = f"> budget (~{fmt_s(predicted)})"
                    else:
                        t, hyp, over = timed(impl.planner, budget)
                        plan.seconds = t
                        if method == "engine":
                            ref_planner = hyp
                        else:
                            diff = max(float(np.max(np.abs(a - b))) for a, b in zip(hyp, ref_planner))
                            agreement[method] = max(agreement[method], diff)
                        if over:
                            st["stopped"] = f"{n}×{k}"
                cells[key] = (upd, plan)
                log(f"  {structure:10s} {n}×{k:<3d} {method:7s} update {upd.text():>24s}   "
                    f"planner {plan.text():>24s}")
    return {"cells": cells, "agreement": agreement}


def target_check(budget: float) -> dict:
    """The issue's target: joint 3 objects x 8 sites, full planner query set."""
    p = make_problem("joint", 3, 8)
    engine = build("engine", p)
    t_update, _, _ = timed(engine.update, budget, min_total=0.5, max_reps=200)
    t_plan, _, _ = timed(engine.planner, budget, min_total=0.5, max_reps=200)
    return {"update": t_update, "planner": t_plan, "method": engine.base.location_method}


def report(result: dict, sizes, structures, budget: float, target: dict) -> str:
    cells = result["cells"]
    header = ["model", "N×K", "K^N"] + [f"{m} {what}" for m in METHODS for what in ("update", "planner set")]
    body = []
    for structure in structures:
        for n, k in sizes:
            ref = cells[(structure, n, k, "engine")]
            row = [structure, f"{n}×{k}", f"{k ** n:.3g}"]
            for m in METHODS:
                upd, plan = cells[(structure, n, k, m)]
                row += [upd.text(None if m == "engine" else ref[0]),
                        plan.text(None if m == "engine" else ref[1])]
            body.append(row)
    lines = table_lines(header, body, align="left")
    out = ["## Exact location inference: engine vs gtsam vs pgmpy vs dense numpy", "",
           f"One thread; per-call budget {budget:g} s. Update = one evidence update (every object "
           "missed at one site) + all N marginals. Planner set = the same update, then every object × "
           "every site, miss and seen (2·N·K hypothetical posteriors of all N marginals). Ratios are to the engine "
           "(> 1 = slower than the engine). Joint = capacity 1 on every third site (penalty 0.05), "
           "teabag–kettle co-location (×3 same site, ×2 same room), exclusivity 0.05 between every "
           "pair; sites in rooms of four. `> budget (~X)`: not run, the cost predicted from the "
           "previous size (growth with K^N, or 2·N·K single queries) exceeds the budget; "
           f"`infeasible`: a K^N table (the capacity factor over all objects, or the dense joint) "
           f"would exceed the dense limit of {DENSE_LIMIT:,} entries.", "", *lines, ""]
    # where each method stops
    out.append("Where each method stops being feasible (largest size measured within budget, by K^N):")
    out.append("")
    for structure in structures:
        for m in METHODS:
            ran = [(n, k) for n, k in sizes if cells[(structure, n, k, m)][1].seconds is not None]
            ran_u = [(n, k) for n, k in sizes if cells[(structure, n, k, m)][0].seconds is not None]
            big = lambda xs: max(xs, key=lambda nk: nk[1] ** nk[0]) if xs else None  # noqa: E731
            u, pl = big(ran_u), big(ran)
            out.append(f"- {structure}, {m}: update up to "
                       f"{'—' if u is None else f'{u[0]}×{u[1]}'}, planner set up to "
                       f"{'—' if pl is None else f'{pl[0]}×{pl[1]}'}")
    out.append("")
    agree = result["agreement"]
    out.append("Agreement with the engine in this run (max |difference| over all marginals and "
               "hypothetical posteriors): " + ", ".join(f"{m} {agree[m]:.1e}" for m in METHODS if m != "engine"))
    out.append("")
    # targets
    faster, compared = True, 0
    slower_cases = []
    for structure in structures:
        for n, k in sizes:
            e = cells[(structure, n, k, "engine")]
            g = cells[(structure, n, k, "pgmpy")]
            for i, what in ((0, "update"), (1, "planner set")):
                if e[i].seconds is not None and g[i].seconds is not None:
                    compared += 1
                    if e[i].seconds >= g[i].seconds:
                        faster = False
                        slower_cases.append(f"{structure} {n}×{k} {what}")
    ok_target = target["planner"] < 2e-3
    out.append(f"Targets: joint 3×8 full planner query set {target['planner'] * 1e3:.3f} ms "
               f"(update {target['update'] * 1e3:.3f} ms, method {target['method']}) — "
               f"{'holds' if ok_target else 'MISSED'} (< 2 ms). Faster than pgmpy on every size "
               f"where both run ({compared} comparisons): "
               f"{'holds' if faster else 'MISSED: ' + ', '.join(slower_cases)}.")
    out.append("")
    return "\n".join(out)


def output_path(args: argparse.Namespace) -> Path | None:
    """Where the markdown goes: ``--out`` if given, else DEFAULT_OUT for a full run, none for --quick."""
    if args.out is not None:
        return args.out
    return None if args.quick else DEFAULT_OUT


def build_parser() -> argparse.ArgumentParser:
    parser = experiment_parser(__doc__, __file__, "§4 (the relational factors: §3.7)")
    parser.add_argument("--quick", action="store_true", help="tiny smoke run (3×6 and 3×8 only)")
    parser.add_argument("--budget", type=float, default=None,
                        help="time budget per call, seconds (default 5, quick 1)")
    parser.add_argument("--out", type=out_file, default=None,
                        help=f"markdown output (default: {DEFAULT_OUT} for the full run, none for "
                             "--quick; committed: experiments/results/bench_inference.md)")
    parser.add_argument("--paths", action="store_true",
                        help="only the bundled models, compiled path vs engine path (experiments/bench_paths.py; "
                             "committed: experiments/results/bench_paths.md)")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.paths:
        import bench_paths  # experiments/ is on sys.path when run as a script

        text = bench_paths.run()
        print(text)
        if args.out is not None:
            atomic_write_text(args.out, text)
            print(f"wrote {args.out}")
        return 0
    if args.quick:
        sizes, budget = [(3, 6), (3, 8)], args.budget or 1.0
    else:
        sizes = [(n, k) for n in (3, 5, 8) for k in (6, 12, 24)]
        budget = args.budget or 5.0
    structures = ("factorised", "joint")
    print(f"bench_inference: sizes {', '.join(f'{n}×{k}' for n, k in sizes)}; budget {budget:g} s per call")
    start = time.perf_counter()
    result = run(sizes, structures, budget)
    target = target_check(budget)
    text = report(result, sizes, structures, budget, target)
    print()
    print(text)
    print(f"(total {time.perf_counter() - start:.0f} s)")
    out = output_path(args)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text)
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
