"""How much CPU does a sweep's driver spend per job, at 1,000, 10,000 and 100,000 jobs (docs/design.md §11)?

The jobs are a stub (no episode: the job returns a one-cell row at once, or with
``--job-seconds S`` after sleeping S seconds, so that results come back one at a time as
episodes' do), so what is timed is the driver alone: submitting jobs, waiting for them, and taking their results, through the real
executors' loop (:mod:`fg_tea.study.executors`: the process pool, and a local Ray instance), on
``--workers`` workers. Driver CPU is ``time.process_time`` of this process (every thread of it,
Ray's own threads in the driver included) around the executor's loop; the pool's or Ray's
start-up is outside it. Wall time is shown beside it.

With ``--before``, the same is measured for the loop the executors had before the in-flight
window: every job submitted first, then a wait on all pending jobs for each result
(``concurrent.futures.wait(pending, FIRST_COMPLETED)``; ``ray.wait(pending, num_returns=1)``),
whose cost per job grows with the number of jobs; it runs only up to ``--before-max`` jobs.

Run ``nice python experiments/bench_sweep_driver.py`` (several minutes on two cores; writes
``runs/experiments/bench_sweep_driver/bench_sweep_driver.md``), or ``--quick`` for a smoke run.
The committed table changes only when ``--out`` names it:

    nice python experiments/bench_sweep_driver.py --before --out experiments/results/bench_sweep_driver.md
    nice python experiments/bench_sweep_driver.py --executors process --before --job-seconds 0.002 \
        --out experiments/results/bench_sweep_driver_sleep.md
"""

from __future__ import annotations

import os
import platform
import sys
import time
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

from fg_tea.common.files import atomic_write_text, out_file
from fg_tea.common.options import experiment_parser
from fg_tea.study import executors
from fg_tea.common.tables import table_lines

DEFAULT_OUT = Path("runs") / "experiments" / "bench_sweep_driver" / "bench_sweep_driver.md"
SIZES = (1_000, 10_000, 100_000)
QUICK_SIZES = (50, 200)


def stub_job(job: int) -> dict[str, Any]:
    """The stub: no episode, a one-cell row."""
    return {"key": job}


class SleepingStub:
    """A stub that sleeps `seconds` (no CPU) before its row, so jobs finish one by one as episodes do."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds

    def __call__(self, job: int) -> dict[str, Any]:
        time.sleep(self.seconds)
        return {"key": job}


def _before_process(run: Callable, jobs: Sequence[Any], workers: int) -> Iterator[Any]:
    """The process pool's former loop: submit everything, wait on everything pending each time."""
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        pool.submit(int).result()  # start-up, outside the timing as for the window's pool (below)
        yield "started"
        pending = {pool.submit(executors._portable, run, job): job for job in jobs}
        while pending:
            finished, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in finished:
                pending.pop(future)
                yield future.result()


def _before_ray(ray, run: Callable, jobs: Sequence[Any]) -> Iterator[Any]:
    """Ray's former loop: every task submitted, then ``ray.wait`` over all pending for each result."""
    remote = ray.remote(num_cpus=1)(run)
    pending = [remote.remote(job) for job in jobs]
    while pending:
        finished, pending = ray.wait(pending, num_returns=1)
        yield ray.get(finished[0])


def _window_process(run: Callable, jobs: Sequence[Any], workers: int) -> Iterator[Any]:
    """The executor's own loop; the pool starts on the first job, which the timing leaves out."""
    loop = executors._process(run, [-1, *jobs], workers, None)
    next(loop)
    yield "started"
    yield from loop


def measure(loop: Iterator[Any], n: int) -> dict[str, float]:
    """Drive `loop` (after its "started" item, when it has one) and time the driver over `n` results."""
    got = 0
    cpu0, wall0 = time.process_time(), time.perf_counter()
    for item in loop:
        if item == "started":
            cpu0, wall0 = time.process_time(), time.perf_counter()
            continue
        got += 1
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    if got != n:
        raise RuntimeError(f"expected {n} results, got {got}")
    return {"cpu": cpu, "wall": wall}


def run_process(sizes: Sequence[int], workers: int, before_max: int, before: bool,
                job: Callable = stub_job) -> list[tuple]:
    rows = []
    for n in sizes:
        m = measure(_window_process(job, range(n), workers), n)
        rows.append(("process", "window", n, m))
        print(f"process window {n}: {m}", file=sys.stderr, flush=True)
        if before and n <= before_max:
            m = measure(_before_process(job, range(n), workers), n)
            rows.append(("process", "before", n, m))
            print(f"process before {n}: {m}", file=sys.stderr, flush=True)
    return rows


def run_ray(sizes: Sequence[int], workers: int, before_max: int, before: bool,
            job: Callable = stub_job) -> list[tuple]:
    rows = []
    if isinstance(job, SleepingStub):  # Ray's tasks are functions (cloudpickled from here), not callables
        seconds = job.seconds

        def job(item: int) -> dict[str, Any]:
            time.sleep(seconds)
            return {"key": item}

    with executors.local_ray(workers) as ray:
        ray.get(ray.remote(num_cpus=1)(stub_job).remote(0))  # workers started, outside the timing
        for n in sizes:
            m = measure(executors._ray_tasks(ray, job, range(n)), n)
            rows.append(("ray", "window", n, m))
            print(f"ray window {n}: {m}", file=sys.stderr, flush=True)
            if before and n <= before_max:
                m = measure(_before_ray(ray, job, range(n)), n)
                rows.append(("ray", "before", n, m))
                print(f"ray before {n}: {m}", file=sys.stderr, flush=True)
    return rows


def table(rows: list[tuple], workers: int, job_seconds: float) -> str:
    stub = f"stub jobs sleeping {job_seconds:g} s" if job_seconds else "stub jobs"
    lines = [f"# Sweep driver overhead per job ({stub}, {workers} workers)", "",
             f"Made by `experiments/bench_sweep_driver.py` on {platform.machine()} with "
             f"{os.cpu_count()} cores (shared: wall times are indicative; CPU is the driver's own, "
             "`time.process_time`). *window*: the executors' loop (at most "
             f"{executors.in_flight_window(workers)} jobs in flight); *before*: every job submitted, "
             "then a wait on all pending jobs per result (the loop the executors had before).", ""]
    lines += table_lines(["executor", "loop", "jobs", "driver CPU (s)", "driver CPU per job (ms)", "wall (s)",
                          "jobs/s"],
                         [[executor, loop, n, m["cpu"], 1e3 * m["cpu"] / n, m["wall"], n / m["wall"]]
                          for executor, loop, n, m in rows],
                         align="llrrrrr", formats=["", "", ",", ".2f", ".3f", ".1f", ",.0f"])
    return "\n".join(lines) + "\n"


def build_parser():
    p = experiment_parser(__doc__, __file__, "§11")
    p.add_argument("--sizes", type=int, nargs="+", default=list(SIZES), help="job counts")
    p.add_argument("--executors", nargs="+", choices=("process", "ray"), default=["process", "ray"],
                   help="which executors")
    p.add_argument("--workers", type=int, default=2, help="processes or local Ray CPUs")
    p.add_argument("--job-seconds", type=float, default=0.0, help="the stub sleeps this long (0: none)")
    p.add_argument("--before", action="store_true", help="also time the former submit-everything loop")
    p.add_argument("--before-max", type=int, default=10_000, help="largest job count for --before")
    p.add_argument("--quick", action="store_true", help=f"job counts {QUICK_SIZES}, the process pool only")
    p.add_argument("--out", type=out_file, default=DEFAULT_OUT, help="the Markdown table")
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    sizes = list(QUICK_SIZES) if args.quick else args.sizes
    chosen = ["process"] if args.quick else args.executors
    job = SleepingStub(args.job_seconds) if args.job_seconds > 0 else stub_job
    rows = []
    if "process" in chosen:
        rows += run_process(sizes, args.workers, args.before_max, args.before, job)
    if "ray" in chosen:
        rows += run_ray(sizes, args.workers, args.before_max, args.before, job)
    atomic_write_text(args.out, table(rows, args.workers, args.job_seconds))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
