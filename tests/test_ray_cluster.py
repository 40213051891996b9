"""A real two-node Ray cluster on this machine, bound to loopback only (docs/how-to/sweep-on-ray.md).

``ray start --head`` and ``ray start --address`` (a worker node), both ``--node-ip-address
127.0.0.1`` with the token and the environment of :func:`fg_tea.study.executors.loopback_ray_env`,
as subprocesses in a temporary directory; ``fg-tea compare --executor ray --address 127.0.0.1:PORT``
runs a sweep through them. The head has no CPUs, so every episode runs on the worker node. The
test checks that the CSV is byte-identical to the process pool's, that the jobs ran in workers of
the worker node's raylet, and that every TCP/UDP socket of every Ray process (found by the
cluster's token in its environment) is on loopback, listening or connected.

Ray 2.60's ``ray start`` cannot start a loopback worker node as it comes: with
``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0`` (what keeps a node's address 127.0.0.1, see
``loopback_ray_env``) it refuses any worker node ("Multi-node Ray clusters are not supported on
Windows and OSX"), and with ``=1`` it replaces ``--node-ip-address 127.0.0.1`` by the address of
the machine's network interface (``services.resolve_ip_for_localhost``). The worker node is
therefore started by Ray's own CLI entry point (``ray.scripts.scripts.main``, the ``ray`` command)
in a Python process where those two switches are set for the ``ray start`` process only: the
multi-node guard lifted, 127.0.0.1 kept as given. Every process it starts (raylet, agents,
workers) is Ray's unchanged, with the variable at 0.

Teardown stops exactly the processes of this cluster (never ``ray stop``, which stops every Ray
process of the user on the machine, other tests' included): SIGTERM, then SIGKILL, and checks that
none is left.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LOOPBACK = {"127.0.0.1", "::1", "::ffff:127.0.0.1"}

#: ``ray start`` for a worker node on 127.0.0.1 (see the module docstring): Ray's CLI, with its
#: multi-node guard lifted and the node address kept, in this process only.
WORKER_NODE_START = (
    "import sys\n"
    "from ray._private import ray_constants, services\n"
    "ray_constants.ENABLE_RAY_CLUSTER = True\n"
    "services.resolve_ip_for_localhost = lambda host: host\n"
    "from ray.scripts.scripts import main\n"
    "sys.argv[0] = 'ray'\n"
    "sys.exit(main())\n")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def processes_with(token: str) -> list:
    """The processes whose environment holds `token`: the cluster's Ray processes and its driver."""
    import psutil

    found = []
    for proc in psutil.process_iter(["pid"]):
        try:
            with open(f"/proc/{proc.pid}/environ", "rb") as f:
                if token.encode() in f.read():
                    found.append(proc)
        except OSError:
            continue
    return found


def sockets(procs) -> list[tuple[int, int, str, str, str, str, str]]:
    """(pid, parent pid, name, kind, status, local address, remote address) of every inet socket."""
    import psutil

    found = []
    for proc in procs:
        try:
            name, ppid, conns = proc.name(), proc.ppid(), proc.net_connections(kind="inet")
        except (psutil.NoSuchProcess, psutil.ZombieProcess, psutil.AccessDenied):
            continue
        for c in conns:
            kind = ("tcp" if c.type == socket.SOCK_STREAM else "udp") + ("6" if c.family == socket.AF_INET6 else "4")
            found.append((proc.pid, ppid, name, kind, c.status, c.laddr.ip if c.laddr else "",
                          c.raddr.ip if c.raddr else ""))
    return found


def names(procs) -> dict[int, tuple[str, int]]:
    import psutil

    out = {}
    for proc in procs:
        try:
            out[proc.pid] = (proc.name(), proc.ppid())
        except (psutil.NoSuchProcess, psutil.ZombieProcess):
            continue
    return out


def stop(token: str) -> list[str]:
    """Stop every process of the cluster: SIGTERM, up to 15 s, then SIGKILL; return those left."""
    import psutil

    procs = processes_with(token)
    for proc in procs:
        try:
            proc.send_signal(signal.SIGTERM)
        except psutil.NoSuchProcess:
            pass
    _, alive = psutil.wait_procs(procs, timeout=15)
    for proc in alive:
        try:
            proc.kill()
        except psutil.NoSuchProcess:
            pass
    psutil.wait_procs(alive, timeout=15)
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline:
        left = [p for p in processes_with(token) if p.status() != psutil.STATUS_ZOMBIE]
        if not left:
            return []
        time.sleep(0.5)
    return [f"{p.pid} {p.name()}" for p in left]


@pytest.fixture
def cluster():
    """A head (no CPUs) and a worker node (2 CPUs) on 127.0.0.1; yields (address, env, token, worker
    raylet pid); stops every process of the cluster afterwards."""
    pytest.importorskip("psutil")
    pytest.importorskip("ray")
    if not sys.platform.startswith("linux"):
        pytest.skip("reads /proc to find the cluster's processes")
    from fg_tea.study.executors import loopback_ray_env

    temp = tempfile.mkdtemp(prefix="fgray", dir="/tmp")  # short: Ray's unix socket paths live here
    env = dict(os.environ, **loopback_ray_env())
    env["RAY_AUTH_TOKEN"] = os.urandom(32).hex()  # this cluster's own token: it finds its processes
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    token = env["RAY_AUTH_TOKEN"]
    port = free_port()
    common = ["--node-ip-address", "127.0.0.1", "--disable-usage-stats", "--temp-dir", temp,
              "--object-store-memory", str(100 * 1024 * 1024)]
    ray_cli = str(Path(sys.executable).with_name("ray"))
    try:
        head = subprocess.run([ray_cli, "start", "--head", "--port", str(port), "--num-cpus", "0",
                               "--include-dashboard", "false", "--dashboard-host", "127.0.0.1", *common],
                              env=env, capture_output=True, text=True, timeout=180)
        assert head.returncode == 0, head.stderr[-3000:]
        on_head = {p.pid for p in processes_with(token)}
        worker = subprocess.run([sys.executable, "-c", WORKER_NODE_START, "start", "--address",
                                 f"127.0.0.1:{port}", "--num-cpus", "2", *common],
                                env=env, capture_output=True, text=True, timeout=180)
        assert worker.returncode == 0, worker.stderr[-3000:]
        raylets = [pid for pid, (name, _) in names(processes_with(token)).items()
                   if name == "raylet" and pid not in on_head]
        assert len(raylets) == 1, names(processes_with(token))
        yield f"127.0.0.1:{port}", env, token, raylets[0]
    finally:
        left = stop(token)
        shutil.rmtree(temp, ignore_errors=True)
        assert left == [], f"Ray processes left running: {left}"


def compare_args(out: Path) -> list[str]:
    return ["compare", "--quick", "--env", "fake", "--worlds", "2", "--planners", "efe", "nearest",
            "--out", str(out)]


@pytest.mark.slow  # two Ray nodes and a sweep (about 40 s): the full suite (CI) runs it
def test_a_sweep_on_a_two_node_loopback_cluster_writes_the_local_csv_and_talks_on_loopback_only(cluster,
                                                                                                   tmp_path):
    address, env, token, worker_raylet = cluster
    local = tmp_path / "local"
    done = subprocess.run([sys.executable, "-m", "fg_tea.cli", *compare_args(local), "--executor",
                           "process", "--workers", "2"], capture_output=True, text=True, timeout=600,
                          env={k: v for k, v in env.items() if k != "RAY_AUTH_TOKEN"})
    assert done.returncode == 0, done.stderr[-3000:]

    remote = tmp_path / "remote"
    driver = subprocess.Popen([sys.executable, "-m", "fg_tea.cli", *compare_args(remote), "--executor", "ray",
                               "--address", address], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, env=env)
    seen: set = set()
    processes: dict[int, tuple[str, int]] = {}
    titles: set[tuple[int, str, int]] = set()  # every (pid, name, parent) seen: a worker's title changes
    deadline = time.monotonic() + 600
    while driver.poll() is None and time.monotonic() < deadline:  # while the sweep runs
        procs = processes_with(token)
        seen.update(sockets(procs))
        processes.update(names(procs))
        titles.update((pid, name, ppid) for pid, (name, ppid) in names(procs).items())
        time.sleep(0.1)
    if driver.poll() is None:
        driver.kill()
    _, err = driver.communicate(timeout=60)
    procs = processes_with(token)
    seen.update(sockets(procs))  # and after it: the cluster's servers, idle
    processes.update(names(procs))
    assert driver.returncode == 0, err[-3000:]

    assert (remote / "episodes.csv").read_bytes() == (local / "episodes.csv").read_bytes()
    # Both nodes were up, and the episodes ran in workers of the worker node's raylet (the head has
    # no CPUs).
    assert sum(name == "raylet" for name, _ in processes.values()) == 2 and "gcs_server" in \
        {name for name, _ in processes.values()}
    # A worker is titled ray::<function> while it runs a task (sweep_job, the executor's wrapper of
    # run_job_timed; the kernel keeps 15 characters) and ray::IDLE between tasks, so every title
    # seen counts.
    ran = {pid for pid, name, ppid in titles if name.startswith("ray::sweep_job") and ppid == worker_raylet}
    assert ran, sorted(titles)
    # Every socket of every Ray process (and the driver), listening or connected, is on loopback.
    assert any(status == "LISTEN" for *_, status, _, _ in seen)
    assert {name for _, _, name, *_ in seen} >= {"gcs_server", "raylet"}
    outside = sorted(s for s in seen if s[5] not in LOOPBACK or (s[6] and s[6] not in LOOPBACK))
    assert outside == []
