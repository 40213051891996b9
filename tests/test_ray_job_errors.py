"""A job that fails under Ray reads as one under the process pool does: ``job K failed: Type:
message`` (no Ray traceback in it), an error that cannot be pickled keeps its type and message,
and a bad input file found by a worker stays the one-line InputError (docs/how-to/sweep-on-ray.md)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from fg_tea.common.errors import InputError
from fg_tea.study import executors
from fg_tea.study.executors import SweepError

HERE = Path(__file__).resolve().parent


class _Wrapped(Exception):
    """What Ray raises for a task's error: a long message, and the error itself in ``cause``."""

    def __init__(self, cause: BaseException):
        super().__init__("ray::run() (pid=1, ip=127.0.0.1)\n  File ...\n" + repr(cause))
        self.cause = cause


class _Job:
    key = "j1"


class _Ray:
    """The part of the ray module the executor uses, failing its one task with `error`."""

    def __init__(self, error: BaseException):
        self.error = error

    def cluster_resources(self):
        return {"CPU": 1.0}

    def remote(self, **options):
        return lambda fn: type("Remote", (), {"remote": staticmethod(lambda job: job)})

    def wait(self, pending, num_returns):
        return pending[:1], pending[1:]

    def get(self, ref):
        raise self.error

    def cancel(self, ref):
        pass


def test_the_cause_inside_rays_wrapper_is_what_the_sweep_reports():
    with pytest.raises(SweepError) as failed:
        list(executors._ray_tasks(_Ray(_Wrapped(ValueError("boom"))), lambda job: job, [_Job()]))
    assert str(failed.value) == "job j1 failed: ValueError: boom"
    with pytest.raises(InputError, match="bad.json"):
        list(executors._ray_tasks(_Ray(_Wrapped(InputError("bad.json", "$.x", "no"))), lambda j: j, [_Job()]))


@pytest.mark.slow
def test_a_real_local_ray_reports_job_errors_in_one_line(monkeypatch):
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(HERE), os.environ.get("PYTHONPATH")])))
    ray = pytest.importorskip("ray")
    from plugin_fault_planners import FakeJob, raise_unpicklable

    def boom(job):
        raise ValueError("boom")

    with executors.local_ray(1):
        with pytest.raises(SweepError) as plain:
            list(executors._ray_tasks(ray, boom, [FakeJob("j1")]))
        with pytest.raises(SweepError) as odd:
            list(executors._ray_tasks(ray, raise_unpicklable, [FakeJob("j2")]))
    assert str(plain.value) == "job j1 failed: ValueError: boom"
    assert str(odd.value) == "job j2 failed: Unpicklable: left and right"
