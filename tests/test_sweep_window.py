"""Sweeps that scale (docs/design.md §11): a bounded in-flight window and a cost estimate.

- the process pool and Ray keep at most ``in_flight_window(workers)`` jobs submitted, waiting
  only on those (waiting on every pending job made the driver's cost grow with the square of the
  job count);
- a failed Ray job cancels exactly the jobs in flight;
- a sweep of more than ``ESTIMATE_ABOVE`` episodes says how many before any is back, then their
  estimated CPU time from the first submitted (not the first finished), and its CSV is unchanged.
"""

from __future__ import annotations

import concurrent.futures
import io

import pytest

from fg_tea.study import cost, executors
from fg_tea.study.executors import SweepError, Window, in_flight_window
from fg_tea.study.sweep import plan_sweep, run_sweep


class Handle:
    def __init__(self, job):
        self.job = job


def test_window_submits_in_order_never_more_than_its_size_and_yields_every_job_once():
    submitted, sizes = [], []

    def submit(job):
        submitted.append(job)
        return Handle(job)

    def wait_one(pending):  # the oldest two finish (at most what is pending)
        sizes.append(len(pending))
        return pending[:2], pending[2:]

    window = Window(range(1000), 7, submit, wait_one)
    finished = [job for job, handle in window if handle.job == job]
    assert submitted == list(range(1000)) and sorted(finished) == list(range(1000))
    assert max(sizes) == 7 and window.pending == []


def test_window_of_fewer_jobs_than_its_size_and_of_none():
    assert [j for j, _ in Window([1, 2], 10, Handle, lambda p: (p[:1], p[1:]))] == [1, 2]
    assert list(Window([], 10, Handle, lambda p: (p, []))) == []


def test_in_flight_window_is_two_per_worker_at_least_two():
    assert in_flight_window(1) == 2 and in_flight_window(2) == 4 and in_flight_window(64) == 128
    assert in_flight_window(0) == 2


def test_process_pool_waits_on_the_window_only(monkeypatch):
    """Before the window, the pool waited on all 60 futures at once; now on at most 4."""
    sizes = []
    real_wait = concurrent.futures.wait

    def recording_wait(fs, *args, **kwargs):
        sizes.append(len(fs))
        return real_wait(fs, *args, **kwargs)

    monkeypatch.setattr(concurrent.futures, "wait", recording_wait)
    rows = list(executors._process(abs, [-i for i in range(60)], 2, None))  # abs: a job that is a number
    assert sorted(rows) == list(range(60))
    assert sizes and max(sizes) <= in_flight_window(2) == 4


class FakeRay:
    """The part of the ray module the Ray executor uses: tasks finish in submission order."""

    def __init__(self, cpus: int, fail: int | None = None):
        self.cpus, self.fail = cpus, fail
        self.waited, self.cancelled, self.submitted = [], [], 0

    def cluster_resources(self):
        return {"CPU": float(self.cpus)}

    def remote(self, **options):
        assert options == {"num_cpus": 1}

        def wrap(run):
            ray = self

            class Remote:
                @staticmethod
                def remote(job):
                    ray.submitted += 1
                    return ("ref", job, run)

            return Remote

        return wrap

    def wait(self, pending, num_returns):
        assert num_returns == 1
        self.waited.append(len(pending))
        return pending[:1], pending[1:]

    def get(self, ref):
        _, job, run = ref
        if job.value == self.fail:
            raise RuntimeError("boom")
        return run(job)

    def cancel(self, ref):
        self.cancelled.append(ref[1].value)


class Job:
    def __init__(self, value):
        self.value, self.key = value, f"job-{value}"


def test_ray_waits_on_twice_the_cluster_cpus_only():
    ray = FakeRay(cpus=3)
    rows = list(executors._ray_tasks(ray, lambda job: job.value, [Job(i) for i in range(500)]))
    assert rows == list(range(500)) and ray.submitted == 500
    assert max(ray.waited) == in_flight_window(3) == 6


def test_a_failed_ray_job_cancels_the_jobs_in_flight_and_submits_no_more():
    ray = FakeRay(cpus=2, fail=10)
    with pytest.raises(SweepError, match="job job-10 failed: RuntimeError: boom"):
        list(executors._ray_tasks(ray, lambda job: job.value, [Job(i) for i in range(500)]))
    assert ray.cancelled == [11, 12, 13] and ray.submitted == 14  # a window of 4, one done


# ------------------------------------------------------------------------------ the estimate
def test_estimate_times_the_first_jobs_submitted_not_the_first_finished():
    out = io.StringIO()
    estimate = cost.CostEstimate([f"k{i}" for i in range(3000)], "compare", out, above=1000, timing=3)
    estimate.start()
    assert out.getvalue() == ("compare: 3,000 episodes to run; an estimate of their CPU time follows "
                              "when the first 3 are back\n")
    for key, seconds in (("k2", 1.0), ("k7", 100.0), ("k0", 2.0)):  # k7 is not timed
        estimate.record(key, seconds)
    assert estimate.line is None
    estimate.record("k1", 3.0)  # mean 2 s x 3000 = 6000 s
    assert estimate.line == ("compare: 3,000 episodes, about 1.7 CPU-hours (from a timing of 3 episodes: "
                             "2.00 s CPU each, mean; each worker's start-up included)")
    assert out.getvalue().endswith(estimate.line + "\n")


def test_a_sweep_of_at_most_the_threshold_says_nothing():
    out = io.StringIO()
    estimate = cost.CostEstimate([f"k{i}" for i in range(1000)], stream=out)
    estimate.start()
    estimate.record("k0", 1.0)
    assert not estimate.active and out.getvalue() == ""


@pytest.mark.parametrize("hours,text", [(0.0123, "0.012"), (1.71, "1.7"), (57.4, "57"), (1234.5, "1,234")])
def test_cpu_hours_are_a_few_significant_figures(hours, text):
    assert cost.cpu_hours_text(hours) == text


def test_a_large_sweep_prints_its_size_and_estimate_and_writes_the_same_csv(tmp_path, monkeypatch, capsys):
    jobs = plan_sweep(["correlated"], 2, ["factorised"], ["nearest", "greedy"], env="fake")
    quiet = tmp_path / "quiet.csv"
    run_sweep(jobs, quiet, "serial", progress=False)
    monkeypatch.setattr(cost, "ESTIMATE_ABOVE", 3)  # "large" is more than 3 episodes here
    monkeypatch.setattr(cost, "TIMING_EPISODES", 2)
    loud = tmp_path / "loud.csv"
    run_sweep(jobs, loud, "serial", label="compare")
    err = capsys.readouterr().err
    assert "compare: 4 episodes to run; an estimate of their CPU time follows when the first 2 are back" in err
    assert "compare: 4 episodes, about " in err and " CPU-hours (from a timing of 2 episodes: " in err
    assert err.index("episodes to run") < err.index("CPU-hours") < err.index("4/4 episodes")
    assert loud.read_bytes() == quiet.read_bytes()
