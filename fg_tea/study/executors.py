"""Where sweep jobs run: in this process, a process pool, or Ray (docs/design.md §11).

Each executor takes the function that runs one job and yields its rows as they finish, keeping at
most :func:`in_flight_window` jobs submitted at a time (:class:`Window`), so the driver's cost per
job stays the same however many jobs a sweep has. A local Ray instance binds 127.0.0.1 only, with
usage statistics and cloud-metadata probing off and a token shared by the driver and its workers
(:func:`local_ray`, docs/design.md §11 "Ray, loopback only").
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from typing import Any, Callable, Iterator, Mapping, Sequence

from fg_tea.common.errors import InputError

#: Runs one sweep job (a :class:`fg_tea.study.sweep.Job`) and returns its CSV row (or what the
#: caller asks for: :func:`fg_tea.study.sweep.run_job_timed` returns the row and its CPU seconds).
Run = Callable[[Any], Any]


# ---------------------------------------------------------------------------------- backends
def _serial(run: Run, jobs: Sequence[Any], workers: int | None, address: str | None) -> Iterator[Any]:
    for job in jobs:
        try:
            row = run(job)
        except (InputError, KeyboardInterrupt):
            raise
        except BaseException as exc:  # SystemExit too: a job that exits has failed, not succeeded
            raise SweepError(job, exc) from exc
        yield row


class JobFailed(RuntimeError):
    """A worker's error that could not cross back to this process as itself (it cannot be
    pickled, or rebuilt from its pickle): its type's name and its message, so nothing is lost
    but the object."""

    def __init__(self, kind: str, message: str) -> None:
        super().__init__(message)
        self.kind = kind

    def __reduce__(self):
        return (type(self), (self.kind, str(self)))


def _portable(run: Run, job: Any) -> Any:
    """``run(job)`` in a worker process, with every error made one the parent can unpickle.

    An exception that does not survive a pickle round trip would otherwise break the whole pool
    (``BrokenProcessPool: ... terminated abruptly``) and lose its cause; a ``BaseException``
    (``SystemExit`` among them) would end the sweep as if it had succeeded.
    """
    import pickle

    try:
        return run(job)
    except KeyboardInterrupt:
        raise
    except BaseException as exc:
        if isinstance(exc, Exception):
            try:
                pickle.loads(pickle.dumps(exc))
            except Exception:
                pass
            else:
                raise
        raise JobFailed(type(exc).__name__, str(exc)) from None


#: Jobs in flight per worker: a sweep submits this many per worker, then one more each time a
#: job finishes, so waiting costs the same per job at 1,000 jobs and at 1,000,000
#: (experiments/bench_sweep_driver.py). Two keep a worker busy while its next job travels to it.
IN_FLIGHT_PER_WORKER = 2


def in_flight_window(workers: int) -> int:
    """How many jobs a sweep keeps submitted at once on `workers` workers (at least 2)."""
    return max(2, IN_FLIGHT_PER_WORKER * max(1, int(workers)))


class Window:
    """Submit jobs in order, never more than `size` at once; iterate (job, handle) as each finishes.

    `submit(job)` starts a job and returns its handle; `wait_one(pending)` blocks until at least one
    handle of the list `pending` is done and returns (done, still pending). Only the window is ever
    waited on, so the driver's cost per job does not grow with the number of jobs (waiting on every
    pending handle costs time in proportion to their number, each time). Jobs start in the order
    given, so the jobs of one world, adjacent in a planned sweep, run close together in time.
    :attr:`pending` holds the handles in flight (to cancel them when a job fails).
    """

    def __init__(self, jobs: Sequence[Any], size: int, submit: Callable[[Any], Any],
                 wait_one: Callable[[list], tuple[list, list]]) -> None:
        self.size, self.submit, self.wait_one = max(1, int(size)), submit, wait_one
        self._queue = iter(jobs)
        self._job_of: dict[Any, Any] = {}
        self.pending: list = []

    def _top_up(self) -> None:
        if len(self.pending) >= self.size:
            return
        for job in self._queue:
            handle = self.submit(job)
            self._job_of[handle] = job
            self.pending.append(handle)
            if len(self.pending) >= self.size:
                return

    def __iter__(self) -> Iterator[tuple[Any, Any]]:
        self._top_up()
        while self.pending:
            done, self.pending = self.wait_one(self.pending)
            for handle in done:
                yield self._job_of.pop(handle), handle
            self._top_up()


def _process(run: Run, jobs: Sequence[Any], workers: int | None, address: str | None) -> Iterator[Any]:
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    workers = workers or os.cpu_count() or 1
    context = multiprocessing.get_context("spawn")  # no inherited simulator or BLAS state
    from fg_tea.common.process import die_with_parent

    pool = ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=die_with_parent,
                               initargs=(os.getpid(),))  # no orphans if this process is killed

    def wait_one(pending: list) -> tuple[list, list]:
        done, rest = wait(pending, return_when=FIRST_COMPLETED)
        return [f for f in pending if f in done], [f for f in pending if f in rest]

    try:
        for job, future in Window(jobs, in_flight_window(workers),
                                  lambda job: pool.submit(_portable, run, job), wait_one):
            try:
                yield future.result()
            except InputError:  # a bad input file found by a worker: one line, status 2
                raise
            except Exception as exc:
                raise SweepError(job, exc) from exc
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _import_ray():
    try:
        import ray
    except ImportError:
        from fg_tea.common.install import install_command

        raise InputError("<command line>", "--executor ray", "Ray is not installed; install it "
                         f"with {install_command('ray')}") from None
    return ray


def _ray_options() -> dict[str, Any]:
    import logging

    return {"include_dashboard": False, "logging_level": logging.WARNING, "log_to_driver": False}


#: The one address a local Ray instance started by fg_tea binds and talks on.
RAY_LOOPBACK = "127.0.0.1"


_LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")


#: The HTTP(S) proxy of a local Ray's processes: a loopback port where nothing listens, so an
#: HTTP request to anywhere but loopback fails at once, on this machine (see loopback_ray_env).
RAY_DEAD_PROXY = "http://127.0.0.1:1"


_ray_token: str | None = None


def loopback_ray_env() -> dict[str, str]:
    """The environment variables of a loopback-only local Ray instance (docs/design.md §11).

    Ray's processes (GCS, raylet, workers, agents) inherit them from the driver, so they are set
    before ``ray.init`` (:func:`local_ray` does so, and restores the old values afterwards):

    - ``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0``: Ray (2.60, ``services.resolve_ip_for_localhost``)
      replaces a node address of 127.0.0.1 by the address of the machine's network interface
      unless this is 0, as it is by default only on Windows and macOS. With it the node address
      stays 127.0.0.1, and every Ray server (GCS, raylet, object manager, workers, runtime-env
      agent) listens on 127.0.0.1 and connects to 127.0.0.1.
    - ``RAY_USAGE_STATS_ENABLED=0`` (and no prompt): no usage report.
    - ``http_proxy``/``https_proxy`` (both spellings) :data:`RAY_DEAD_PROXY`, ``no_proxy``
      loopback: Ray's dashboard process starts even with ``include_dashboard=False``, to load
      ``UsageStatsHead``, whose ``run`` detects the cloud provider whether or not usage
      statistics are enabled (``usage_lib.get_cloud_from_metadata_requests``: HTTP to
      169.254.169.254 twice and to metadata.google.internal). Ray has no switch for it;
      ``requests`` sends these through the proxy, which refuses them on loopback, so no packet
      and no DNS query leaves the machine. gRPC honours ``no_proxy``, so Ray's own loopback
      connections are direct.
    - ``RAY_AUTH_MODE=token`` with ``RAY_AUTH_TOKEN``, a random 256-bit token made once per
      fg_tea process. Binding to loopback keeps other machines out but not other users of this
      one: without a token any local process could connect and run code as the sweep's user.
      Disabling authentication would drop that protection (Ray 2.60 enables tokens by default
      for ``ray.init``); Ray's own default instead writes a token to ``~/.ray/auth_token``. An
      environment token reaches exactly the driver and the processes it starts (readable only
      by the same user) and is never written to disk. Rays without token authentication ignore
      these variables.
    """
    global _ray_token
    if _ray_token is None:
        import secrets

        _ray_token = secrets.token_hex(32)
    env = {"RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0", "RAY_USAGE_STATS_ENABLED": "0",
           "RAY_USAGE_STATS_PROMPT_ENABLED": "0", "RAY_AUTH_MODE": "token",
           "RAY_AUTH_TOKEN": _ray_token}
    for name in ("http_proxy", "https_proxy"):
        env[name] = env[name.upper()] = RAY_DEAD_PROXY
    env["no_proxy"] = env["NO_PROXY"] = ",".join(_LOOPBACK_HOSTS)
    return env


def _reload_ray_config() -> None:
    """Make this process's Ray read its configuration (authentication mode, token) from the
    environment again: Ray caches both on first use, possibly before the variables were set."""
    import importlib

    raylet = importlib.import_module("ray._raylet")  # its stubs lack these two
    config = getattr(raylet, "Config", None)
    loader = getattr(raylet, "AuthenticationTokenLoader", None)
    if config is None or loader is None:  # a Ray without token authentication
        return
    config.initialize("")
    loader.instance().reset_cache()


@contextmanager
def _ray_environment(ray, env: Mapping[str, str]) -> Iterator[None]:
    """Set `env` (and Ray's copy of ``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER``, read when ray was
    imported) for the duration, then restore both."""
    from ray._private import ray_constants

    saved = {k: os.environ.get(k) for k in env}
    saved_cluster = ray_constants.ENABLE_RAY_CLUSTER
    os.environ.update(env)
    if "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER" in env:
        ray_constants.ENABLE_RAY_CLUSTER = env["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] != "0"
    _reload_ray_config()
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        ray_constants.ENABLE_RAY_CLUSTER = saved_cluster
        _reload_ray_config()


def _cause(exc: BaseException) -> str:
    """One line naming an exception: its type and the first line of its message."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    text = f"{type(exc).__name__}: {lines[0]}" if lines else type(exc).__name__
    return text if len(text) <= 300 else text[:297] + "..."


@contextmanager
def local_ray(workers: int | None = None) -> Iterator[Any]:
    """Start a local Ray instance bound to 127.0.0.1 only; yield the ray module; shut Ray down.

    The ``ray`` executor without an address runs its jobs here, and the tests start Ray through
    it. Its environment is :func:`loopback_ray_env` (loopback node address, no usage statistics,
    no cloud-metadata requests, a per-process authentication token); the dashboard is off and
    the instance has `workers` CPUs (None or 0: every core) and no GPUs.

    Raises:
        InputError: Ray is not installed, cannot start, or took a node address other than
            127.0.0.1 (then it is shut down before any job runs).
    """
    ray = _import_ray()
    where = f"cannot start a local Ray instance on {RAY_LOOPBACK}"
    with _ray_environment(ray, loopback_ray_env()):
        try:
            ray.init(num_cpus=workers or os.cpu_count() or 1, num_gpus=0,
                     _node_ip_address=RAY_LOOPBACK, dashboard_host=RAY_LOOPBACK, **_ray_options())
        except Exception as exc:
            ray.shutdown()
            raise InputError("<command line>", "--executor ray", f"{where} ({_cause(exc)})") from None
        try:
            node = ray.util.get_node_ip_address()
            if node != RAY_LOOPBACK:
                raise InputError("<command line>", "--executor ray",
                                 f"{where} (Ray took the node address {node})")
            yield ray
        finally:
            ray.shutdown()


@contextmanager
def connected_ray(address: str) -> Iterator[Any]:
    """Connect to the Ray cluster at `address`; yield the ray module; disconnect.

    Usage statistics are off for this driver; for a head on this machine's loopback
    (``127.0.0.1:PORT``, ``localhost:PORT``) the driver keeps 127.0.0.1 as its own address too
    (see :func:`loopback_ray_env`). Authentication is the cluster's: the driver needs
    ``RAY_AUTH_MODE`` and the token the head was started with.

    Raises:
        InputError: the address is malformed, nothing answers there, or Ray cannot connect.
    """
    ray = _import_ray()
    host = _check_reachable(address)
    env = {"RAY_USAGE_STATS_ENABLED": "0", "RAY_USAGE_STATS_PROMPT_ENABLED": "0"}
    if host in _LOOPBACK_HOSTS:
        env["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
    with _ray_environment(ray, env):
        try:
            ray.init(address=address, **_ray_options())
        except Exception as exc:
            ray.shutdown()
            # Something answered at the address, so a refusal is most often authentication.
            hint = ("; a cluster with token authentication needs RAY_AUTH_MODE=token and its "
                    "RAY_AUTH_TOKEN (or ~/.ray/auth_token) here as for its ray start")
            raise InputError("<command line>", f"--address {address}",
                             f"cannot connect to Ray ({_cause(exc)}){hint}") from None
        try:
            yield ray
        finally:
            ray.shutdown()


def _ray_window(ray) -> int:
    """The in-flight window on Ray: :func:`in_flight_window` of the cluster's CPUs (at connection)."""
    try:
        cpus = int(ray.cluster_resources().get("CPU", 1))
    except Exception:  # a Ray without the call: one CPU's window, still bounded
        cpus = 1
    return in_flight_window(cpus)


def _ray_cause(exc: BaseException) -> BaseException:
    """The job's own error inside Ray's wrapper (``RayTaskError(ValueError)`` holds a traceback
    in its message and the ValueError in ``cause``), so a failed Ray job reads as one line, as
    a failed process-pool job does."""
    inner = getattr(exc, "cause", None)
    return inner if isinstance(inner, BaseException) else exc


def _ray_tasks(ray, run: Run, jobs: Sequence[Any]) -> Iterator[Any]:
    def sweep_job(job: Any) -> Any:  # errors that cannot cross back become JobFailed, as in a pool
        return _portable(run, job)

    remote = ray.remote(num_cpus=1)(sweep_job)

    def wait_one(pending: list) -> tuple[list, list]:
        return ray.wait(pending, num_returns=1)

    window = Window(jobs, _ray_window(ray), lambda job: remote.remote(job), wait_one)
    for job, ref in window:
        try:
            row = ray.get(ref)
        except Exception as exc:
            for other in window.pending:
                ray.cancel(other)
            cause = _ray_cause(exc)
            if isinstance(cause, InputError):  # a bad input file found by a worker: one line, status 2
                raise cause from None
            raise SweepError(job, cause) from exc
        yield row


def _ray(run: Run, jobs: Sequence[Any], workers: int | None, address: str | None) -> Iterator[Any]:
    ray = _import_ray()
    if ray.is_initialized():  # a caller's own Ray (e.g. :func:`local_ray`): used as it is
        yield from _ray_tasks(ray, run, jobs)
    elif address:
        with connected_ray(address):
            yield from _ray_tasks(ray, run, jobs)
    else:
        with local_ray(workers):
            yield from _ray_tasks(ray, run, jobs)


#: Seconds to wait for a Ray head to accept a connection before giving up.
RAY_CONNECT_TIMEOUT_S = 5.0


def _check_reachable(address: str) -> str | None:
    """Check a Ray ``[scheme://]host:port`` address; fail fast, with one line, when nothing listens.

    ``ray.init`` itself retries for minutes; ``"auto"`` and addresses without a port are left to
    it. Returns the host (None for those left to Ray).

    Raises:
        InputError: the port is not a number in 1..65535, or nothing answers within
            :data:`RAY_CONNECT_TIMEOUT_S`.
    """
    import socket

    target = address.split("://", 1)[-1]
    host, sep, port = target.rpartition(":")
    if not sep or "]" in port:
        return None
    if not port.isdigit() or not 1 <= int(port) <= 65535:
        raise InputError("<command line>", "--address", f"{address!r}: the port {port!r} is not a "
                         "number in 1..65535 (expected HOST:PORT, ray://HOST:PORT or auto)")
    host = host.strip("[]") or "127.0.0.1"
    try:
        with socket.create_connection((host, int(port)), timeout=RAY_CONNECT_TIMEOUT_S):
            pass
    except (OSError, ValueError, OverflowError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        raise InputError("<command line>", "--address",
                         f"no Ray head answers at {address!r} within "
                         f"{RAY_CONNECT_TIMEOUT_S:g} s ({reason})") from None
    return host


_BACKENDS: dict[str, Callable[[Run, Sequence[Any], int | None, str | None], Iterator[Any]]] = {
    "serial": _serial, "process": _process, "ray": _ray}


class SweepError(RuntimeError):
    """A job failed for a reason other than a refusal; rows finished before it are in the CSV."""

    def __init__(self, job: Any, cause: BaseException) -> None:
        self.job, self.cause = job, cause
        kind = cause.kind if isinstance(cause, JobFailed) else type(cause).__name__
        super().__init__(f"job {job.key} failed: {kind}: {cause}")


__all__ = ["SweepError", "JobFailed", "Window", "in_flight_window", "IN_FLIGHT_PER_WORKER", "local_ray",
           "connected_ray", "loopback_ray_env", "RAY_LOOPBACK", "RAY_DEAD_PROXY", "RAY_CONNECT_TIMEOUT_S"]
