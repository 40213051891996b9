"""Sweeps and their analysis (docs/design.md §11).

- paired job plans and stable keys;
- serial, process-pool and Ray backends write byte-identical CSVs for the same seeds;
- an interrupted sweep (a failure after k episodes, then a truncated last line) resumes without
  re-running finished episodes and ends with the same CSV;
- optimal-planner refusals are recorded, not raised;
- interval arithmetic against hand-computed numbers;
- bad input is one line and exit status 2;
- smoke tests of every experiments/ script at tiny N, in a subprocess.
"""

from __future__ import annotations

import copy
import csv
import json
import math
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from fg_tea.common.errors import InputError
from fg_tea.study import executors, sweep
from fg_tea.study.analysis import (
    paired_differences,
    ratio_to_reference,
    summary_table,
    t_interval,
    wilson_interval,
)
from fg_tea.study.executors import SweepError
from fg_tea.study.report import comparison_report
from fg_tea.study.rows import CsvSink, read_rows
from fg_tea.study.sweep import Job, plan_sweep, run_sweep

ROOT = Path(__file__).resolve().parents[1]
#: 3 worlds x 2 models x 2 planners = 12 headless PyBullet episodes (~0.2 s each).
TINY = dict(worlds=["correlated"], n_worlds=3, models=["factorised", "joint"], planners=["efe", "nearest"])


def tiny_jobs() -> list[Job]:
    return plan_sweep(**TINY)


@pytest.fixture(scope="module")
def process_csv(tmp_path_factory) -> bytes:
    """The tiny sweep on a two-process pool: the reference CSV of the backend tests."""
    path = tmp_path_factory.mktemp("process") / "episodes.csv"
    rows = run_sweep(tiny_jobs(), path, "process", workers=2, progress=False)
    assert len(rows) == 12
    return path.read_bytes()


# ------------------------------------------------------------------------------ jobs and plans
def test_job_key_is_stable_and_mappings_are_normalised():
    a = Job("correlated", 7, model="joint", planner="optimal", knobs={"same_site": 0.5, "prior_violation": 0},
            env_overrides={"detection_miss_rate": 0.1})
    b = Job("correlated", 7, model="joint", planner="optimal", knobs=(("prior_violation", 0.0), ("same_site", 0.5)),
            env_overrides=(("detection_miss_rate", 0.1),))
    assert a == b and hash(a) == hash(b)
    assert a.seed == 7  # the episode seed defaults to the world seed
    assert a.key == ("world=correlated|ws=000007|knobs=prior_violation=0.0,same_site=0.5|model=joint|"
                     "planner=optimal|seed=000007|eo=detection_miss_rate=0.1")
    with pytest.raises(InputError, match="unknown world knob"):
        Job("correlated", 0, knobs={"colour": 1.0})
    with pytest.raises(InputError, match=r"probability in \[0, 1\]"):
        Job("correlated", 0, knobs={"same_site": 1.5})


def test_plan_is_paired_every_configuration_solves_the_same_worlds():
    jobs = plan_sweep(["correlated"], 4, ["factorised", "joint"], ["efe", "optimal", "random"], first_seed=10)
    assert len(jobs) == 4 * 2 * 3 and len({j.key for j in jobs}) == len(jobs)
    by_config: dict[tuple, set] = {}
    for j in jobs:
        by_config.setdefault((j.model, j.planner), set()).add((j.world_seed, j.seed))
    assert len({frozenset(v) for v in by_config.values()}) == 1         # every configuration alike
    assert {ws for ws, _ in next(iter(by_config.values()))} == set(range(10, 14))
    same = plan_sweep(["correlated"], 4, ["factorised"], ["efe"], first_seed=10, episode_seeds="world")
    assert {(j.world_seed, j.seed) for j in same} == {(s, s) for s in range(10, 14)}


def test_row_holds_configuration_truth_and_flattened_metrics():
    row = sweep.run_job(Job("correlated", 0, model="joint", planner="efe", env="fake"))
    assert row["key"] == "world=correlated|ws=000000|model=joint|planner=efe|seed=000000|env=fake"
    assert row["structure"] == "joint" and row["same_site_teabag_kettle"] == 0.5
    assert {"true_site_mug", "true_site_kettle", "true_site_teabag", "truth_kettle.contains_water"} <= set(row)
    assert {"inspections_until_resolved_mug", "inspections_until_resolved_kettle",
            "inspections_until_resolved_teabag"} <= set(row)
    assert isinstance(row["skipped_actions"], str) and "goal_conditions" not in row
    trace = [float(x) for x in row["entropy_trace"].split(";")]
    assert len(trace) == row["inspections"] + 1 and trace[0] > trace[-1]
    assert not any("time" in c or c.endswith("_s") for c in row)  # never wall-clock timings


# ------------------------------------------------------------------------------ backends
@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_serial_and_process_pool_write_identical_csvs(process_csv, tmp_path):
    path = tmp_path / "episodes.csv"
    run_sweep(list(reversed(tiny_jobs())), path, "serial", progress=False)
    assert path.read_bytes() == process_csv
    rows = list(csv.DictReader(path.open()))
    assert [r["key"] for r in rows] == sorted(r["key"] for r in rows)


LOOPBACK = {"127.0.0.1", "::1", "::ffff:127.0.0.1"}


def sockets_of_children() -> list[tuple[str, str, str, str, str]]:
    """Every TCP and UDP socket (IPv4 and IPv6, listening or connected) of this process's children.

    As (process name, kind, status, local address, remote address); unix sockets are not listed.
    """
    import psutil
    import ray  # noqa: F401  # Ray vendors psutil; the test extra also names it

    found = []
    for proc in psutil.Process().children(recursive=True):
        try:
            name, conns = proc.name(), proc.net_connections(kind="inet")
        except (psutil.NoSuchProcess, psutil.ZombieProcess):
            continue
        for c in conns:
            kind = ("tcp" if c.type == socket.SOCK_STREAM else "udp") + ("6" if c.family == socket.AF_INET6 else "4")
            found.append((name, kind, c.status, c.laddr.ip if c.laddr else "", c.raddr.ip if c.raddr else ""))
    return found


class HttpTrap:
    """A loopback TCP listener that records the first line of every request made to it."""

    def __init__(self) -> None:
        import threading

        self.server = socket.create_server(("127.0.0.1", 0))
        self.server.settimeout(0.2)
        self.url = f"http://127.0.0.1:{self.server.getsockname()[1]}"
        self.requests: list[str] = []
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self) -> None:
        while not self.stop.is_set():
            try:
                conn, _ = self.server.accept()
            except OSError:
                continue
            with conn:
                conn.settimeout(2)
                try:
                    self.requests.append(conn.recv(4096).decode("latin-1").split("\r\n")[0])
                except OSError:
                    pass

    def close(self) -> None:
        self.stop.set()
        self.thread.join()
        self.server.close()


@pytest.mark.slow  # an integration run of a whole sweep: the full suite (CI) runs it
def test_local_ray_binds_and_talks_on_loopback_only_and_writes_the_process_pool_csv(process_csv, tmp_path,
                                                                                     monkeypatch):
    import time

    import ray  # installed by the test extra; a missing Ray is a failure, not a skip
    from ray._raylet import AuthenticationTokenLoader

    path = tmp_path / "episodes.csv"
    before = {k: os.environ.get(k) for k in executors.loopback_ray_env()}
    trap = HttpTrap()  # stands in for the dead proxy, to see what Ray's processes send there
    monkeypatch.setattr(executors, "RAY_DEAD_PROXY", trap.url)
    try:
        with executors.local_ray(workers=2):
            run_sweep(tiny_jobs(), path, "ray", workers=2, progress=False)
            deadline = time.monotonic() + 120
            while not trap.requests and time.monotonic() < deadline:
                time.sleep(0.2)
            node_ip = ray.util.get_node_ip_address()
            found = sockets_of_children()  # while Ray is up: its servers and their connections
            token = os.environ["RAY_AUTH_TOKEN"]
            worker_token = ray.get(ray.remote(lambda: os.environ.get("RAY_AUTH_TOKEN")).remote())
            driver_token = AuthenticationTokenLoader.instance().get_raw_token()
    finally:
        trap.close()
        if ray.is_initialized():
            ray.shutdown()
    assert path.read_bytes() == process_csv
    # Ray's cloud detection (169.254.169.254, metadata.google.internal) went to the proxy on
    # loopback, not out; if Ray stops probing, this fails and the proxy can go.
    assert trap.requests and all("169.254.169.254" in r or "metadata.google.internal" in r
                                 for r in trap.requests), trap.requests
    # Token authentication, one random token shared by driver and workers; the driver's
    # environment is as it was afterwards.
    assert len(token) == 64 and driver_token == worker_token == token
    assert {k: os.environ.get(k) for k in before} == before
    names = {name for name, *_ in found}
    assert {"gcs_server", "raylet"} <= names  # the snapshot saw Ray's processes
    assert any(status == "LISTEN" for _, _, status, _, _ in found)
    outside = [s for s in found if s[3] not in LOOPBACK or (s[4] and s[4] not in LOOPBACK)]
    assert outside == []
    assert node_ip == "127.0.0.1"


def _can_unshare_network() -> bool:
    try:
        return subprocess.run(["unshare", "-n", "--", "ip", "link", "set", "lo", "up"],
                              capture_output=True, timeout=120).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


@pytest.mark.slow
def test_compare_on_a_local_ray_runs_in_a_network_namespace_with_only_loopback(tmp_path):
    """No interface but loopback, no route, no DNS: the local Ray needs none of them.

    A plain ``ray.init`` passes here too (without an interface Ray falls back to 127.0.0.1); this
    guards the token and proxy settings. The socket test above is what pins the binding."""
    pytest.importorskip("ray")
    if not sys.platform.startswith("linux") or not _can_unshare_network():
        pytest.skip("unshare -n (a private network namespace) is not permitted here")
    out = tmp_path / "out"
    script = (f"ip link set lo up && exec {sys.executable} -m fg_tea.cli compare --executor ray "
              f"--quick --env fake --worlds 2 --out {out}")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    done = subprocess.run(["unshare", "-n", "--", "bash", "-c", script], capture_output=True, text=True,
                          timeout=300, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert len(read_rows(out / "episodes.csv")) == 16


def fg_tea(argv) -> tuple[int, str]:
    """Run ``fg-tea argv`` in-process; return (exit status, stderr)."""
    import contextlib
    import io

    from fg_tea.cli import main

    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        status = main([str(a) for a in argv])
    return status, err.getvalue()


def compare_on_ray(tmp_path, *address: str) -> list[str]:
    return ["compare", "--executor", "ray", *(["--address", *address] if address else []), "--quick",
            "--env", "fake", "--worlds", "1", "--planners", "nearest", "--out", tmp_path / "out"]


def one_line_error(status: int, err: str) -> str:
    assert status == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith("fg-tea: error: ") and "<output>" not in err, err
    return err.strip()


def test_ray_address_with_a_port_that_is_not_a_number_is_one_line(tmp_path):
    pytest.importorskip("ray")
    line = one_line_error(*fg_tea(compare_on_ray(tmp_path, "127.0.0.1:notaport")))
    assert "--address" in line and "'notaport' is not a number" in line, line


def test_ray_that_cannot_start_or_connect_names_the_address_and_the_cause(tmp_path, monkeypatch):
    """Ray's own failures (a ConnectionError is an OSError) name the executor or the address and
    Ray's reason, not the ``<output>`` of a failed write; the driver's environment is restored."""
    ray = pytest.importorskip("ray")
    from ray._private import ray_constants

    def refuse(*args, **kwargs):
        raise ConnectionError(f"Failed to connect to Ray cluster at {kwargs.get('address')}.\nDetails")

    monkeypatch.setattr(ray, "init", refuse)
    before = {k: os.environ.get(k) for k in executors.loopback_ray_env()}
    cluster = ray_constants.ENABLE_RAY_CLUSTER
    line = one_line_error(*fg_tea(compare_on_ray(tmp_path)))
    assert line == ("fg-tea: error: <command line>: --executor ray: cannot start a local Ray instance "
                    "on 127.0.0.1 (ConnectionError: Failed to connect to Ray cluster at None.)")
    with socket.socket() as head:  # something answering on loopback, so the address is tried
        head.bind(("127.0.0.1", 0))
        head.listen()
        address = f"127.0.0.1:{head.getsockname()[1]}"
        line = one_line_error(*fg_tea(compare_on_ray(tmp_path, address)))
        assert line.startswith(f"fg-tea: error: <command line>: --address {address}: cannot connect to "
                               f"Ray (ConnectionError: Failed to connect to Ray cluster at {address}.); "), line
        monkeypatch.setattr(ray, "init", lambda **kw: (_ for _ in ()).throw(
            RuntimeError("Authentication token is missing or incorrect")))
        line = one_line_error(*fg_tea(compare_on_ray(tmp_path, address)))
        assert "RAY_AUTH_MODE=token" in line and "RAY_AUTH_TOKEN" in line, line
    assert {k: os.environ.get(k) for k in before} == before
    assert ray_constants.ENABLE_RAY_CLUSTER == cluster


def test_unknown_backend_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="unknown executor 'dask'"):
        run_sweep(tiny_jobs(), tmp_path / "x.csv", "dask")


# ------------------------------------------------------------------------------ resume
@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_interrupted_sweep_resumes_without_repeating_finished_episodes(process_csv, tmp_path, monkeypatch):
    path = tmp_path / "episodes.csv"
    real = sweep.run_job
    calls: list[str] = []

    def crash_after_five(job):
        if len(calls) == 5:
            raise RuntimeError("simulated crash")
        calls.append(job.key)
        return real(job)

    monkeypatch.setattr(sweep, "run_job", crash_after_five)
    with pytest.raises(SweepError, match="simulated crash"):
        run_sweep(tiny_jobs(), path, "serial", progress=False)
    assert len(read_rows(path)) == 5
    # A crash in the middle of a write leaves a partial last line (no newline).
    with path.open("a") as fh:
        fh.write("world=correlated|ws=000002|model=joint|planner=efe|seed=000002,correlat")
    finished = set(calls)

    calls.clear()
    monkeypatch.setattr(sweep, "run_job", lambda job: (calls.append(job.key), real(job))[1])
    rows = run_sweep(tiny_jobs(), path, "serial", progress=False)
    assert len(calls) == 12 - 5 and not finished & set(calls)
    assert len(rows) == 12
    assert path.read_bytes() == process_csv


def test_sink_drops_truncated_line_and_keeps_complete_rows(tmp_path):
    path = tmp_path / "s.csv"
    path.write_text("key,a\nk1,1\nk2,2\nk3,")
    sink = CsvSink(path)
    assert sink.done("k1") and sink.done("k2") and not sink.done("k3")
    sink.write({"key": "k0", "a": 0})
    sink.finalize()
    assert path.read_text() == "key,a\nk0,0\nk1,1\nk2,2\n"
    assert CsvSink(path, resume=False).resumed == 0 and not path.exists()


# ------------------------------------------------------------------------------ refusals
def test_optimal_planner_refusal_is_recorded_not_raised(tmp_path):
    data = json.loads((ROOT / "scenarios" / "default_apartment.json").read_text())
    for i in range(3):  # 8 + 3 = 11 sites: one more than the optimal planner's DP accepts
        site = copy.deepcopy(data["sites"][i])
        site["name"] += f"_copy{i}"
        data["sites"].append(site)
    (tmp_path / "many.json").write_text(json.dumps(data))
    world = tmp_path / "many_world.json"
    world.write_text(json.dumps({"name": "many", "base_scenario": "many.json", "placement": {}}))
    jobs = plan_sweep([str(world)], 1, ["factorised"], ["optimal", "nearest"], env="fake")
    rows = {r["planner"]: r for r in run_sweep(jobs, tmp_path / "e.csv", "serial", progress=False)}
    assert rows["optimal"]["reason"].startswith("refused: size: optimal planner: 11 sites exceed the limit of 10")
    assert rows["optimal"]["success"] is False
    assert rows["nearest"]["reason"] == "complete"
    summary = summary_table(list(rows.values()))
    assert sorted((s["planner"], s["n"], s["refused"]) for s in summary) == [("nearest", 1, 0), ("optimal", 0, 1)]


def test_step_limit_stops_an_unfinished_episode_and_is_reported(tmp_path):
    job = Job("correlated", 0, planner="efe", env="fake", max_steps=5)
    assert job.key.endswith("|env=fake|steps=5")
    row = sweep.run_job(job)
    assert row["reason"] == "step_limit: not finished after 5 steps (frame %d)" % row["frames"]
    assert row["success"] is False
    ok = sweep.run_job(Job("correlated", 0, planner="efe", env="fake"))
    (s,) = summary_table([row, ok])
    assert (s["n"], s["step_limited"], s["success"].mean) == (1, 1, 0.5)  # a failure, not a measurement
    assert s["search_distance"].mean == ok["search_distance"]


# ------------------------------------------------------------------------------ statistics
def test_t_interval_on_a_known_sample():
    # mean 3, s = sqrt(2.5) = 1.5811, se = 0.70711, t_{0.975,4} = 2.776445: half width 1.963243
    iv = t_interval([1, 2, 3, 4, 5])
    assert iv.n == 5 and iv.mean == pytest.approx(3.0)
    assert (iv.low, iv.high) == pytest.approx((1.036757, 4.963243), abs=1e-6)
    one = t_interval([4.0, None])
    assert one.mean == 4.0 and math.isnan(one.low) and one.fmt() == "4.00"
    assert t_interval([]).n == 0


def test_wilson_interval_on_nine_of_ten():
    # p = 0.9, z^2 = 3.841459: centre (0.9 + 0.192073) / 1.384146 = 0.788986,
    # half 1.959964 * sqrt(0.009 + 0.0096036) / 1.384146 = 0.193136
    iv = wilson_interval(9, 10)
    assert iv.mean == 0.9
    assert (iv.low, iv.high) == pytest.approx((0.595850, 0.982121), abs=1e-5)
    all_ok = wilson_interval(5, 5)
    assert all_ok.high == pytest.approx(1.0) and all_ok.low < 1.0


def _row(model, planner, seed, d, refused=False):
    return {"key": f"{model}|{planner}|{seed}", "world": "w", "world_seed": seed, "seed": seed, "model": model,
            "planner": planner, "search_distance": d, "total_distance": d, "inspections": 1,
            "success": not refused, "reason": "refused: too many" if refused else "complete"}


def test_paired_difference_on_hand_computed_pairs():
    # factorised 10, 12, 14; joint 9, 10, 14: differences -1, -2, 0; mean -1, s = 1,
    # se = 0.57735, t_{0.975,2} = 4.302653: half width 2.484138
    rows = [_row("factorised", "efe", s, d) for s, d in enumerate([10, 12, 14])]
    rows += [_row("joint", "efe", s, d) for s, d in enumerate([9, 10, 14])]
    rows.append(_row("joint", "efe", 3, 99.0))  # unpaired: ignored
    (d,) = paired_differences(rows, "model", "factorised", ("search_distance",), by=("planner",))
    assert d["model"] == "joint" and d["pairs"] == 3
    assert d["search_distance"].mean == pytest.approx(-1.0)
    assert (d["search_distance"].low, d["search_distance"].high) == pytest.approx((-3.484138, 1.484138), abs=1e-6)
    assert d["search_distance_baseline"].mean == pytest.approx(12.0)
    with pytest.raises(ValueError, match="share the pairing key"):
        paired_differences(rows + [_row("joint", "efe", 0, 1.0)], "model", "factorised", by=())


def test_ratio_to_optimal_on_hand_computed_pairs():
    # ratios 15/10 = 1.5 and 20/20 = 1.0 (the world where optimal travelled 0 m is skipped);
    # mean 1.25, s = 0.353553, se = 0.25, t_{0.975,1} = 12.706205: half width 3.176551
    rows = [_row("m", "optimal", s, d) for s, d in enumerate([10, 20, 0])]
    rows += [_row("m", "efe", s, d) for s, d in enumerate([15, 20, 5])]
    rows.append(_row("m", "efe", 9, 1.0, refused=True))
    ratios = {r["planner"]: r for r in ratio_to_reference(rows)}
    efe = ratios["efe"]
    assert efe["pairs"] == 3 and efe["zero_reference"] == 1
    assert efe["ratio"].mean == pytest.approx(1.25)
    assert (efe["ratio"].low, efe["ratio"].high) == pytest.approx((-1.926551, 4.426551), abs=1e-6)
    assert efe["difference"].mean == pytest.approx(10 / 3)
    assert ratios["optimal"]["ratio"].mean == pytest.approx(1.0)


def test_report_writes_every_file_atomically(process_csv, tmp_path):
    csv_path = tmp_path / "episodes.csv"
    csv_path.write_bytes(process_csv)
    files = comparison_report(read_rows(csv_path), tmp_path, title="tiny")
    for name in ("summary.md", "summary.csv", "paired.csv", "travel_inspections.png", "entropy.png"):
        assert files[name].exists() and files[name].stat().st_size > 0
    assert files["travel_inspections.png"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary files left
    text = files["summary.md"].read_text()
    assert "| factorised | efe | 3 |" in text and "joint − factorised" in text


# ------------------------------------------------------------------------------ bad input
@pytest.mark.parametrize("argv, needle", [
    (["--models", "factorised", "nosuch"], "unknown model 'nosuch'"),
    (["--world", "nosuch"], "unknown world 'nosuch'"),
    (["--worlds", "0"], "argument --worlds: expected an integer from 1 to"),
    (["--planners", "bogus"], "unknown planner 'bogus'"),
])
def test_compare_bad_input_is_one_line_and_exit_2(argv, needle, tmp_path):
    proc = subprocess.run([sys.executable, "-m", "fg_tea.cli", "compare", "--out", str(tmp_path / "o"), *argv],
                          capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], proc.stderr
    assert not (tmp_path / "o" / "episodes.csv").exists()


# ------------------------------------------------------------------------------ experiments
def _script(name: str, *argv: str, timeout: float = 300) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, str(ROOT / "experiments" / name), *argv], capture_output=True,
                          text=True, timeout=timeout, env=env, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc


@pytest.mark.slow
def test_compare_beliefs_smoke(tmp_path):
    _script("compare_beliefs.py", "--worlds", "2", "--planners", "efe", "optimal", "--workers", "2",
            "--out", str(tmp_path))
    rows = read_rows(tmp_path / "episodes.csv")
    assert len(rows) == 2 * 2 * 2 and all(r["success"] for r in rows)
    text = (tmp_path / "summary.md").read_text()
    assert "## Paired differences: joint − factorised" in text and "Bayes-optimal limit" in text
    for png in ("travel_inspections.png", "entropy.png", "ratio_to_optimal.png"):
        assert (tmp_path / png).stat().st_size > 0


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_ablations_smoke(tmp_path):
    proc = _script("ablations.py", "--worlds", "2", "--ablations", "no_epistemic", "euclidean",
                   "--workers", "2", "--out", str(tmp_path))
    assert len(read_rows(tmp_path / "ablations.csv")) == 2 * 3
    text = (tmp_path / "ablations.md").read_text()
    assert "| no_epistemic | yes |" in text and "| euclidean | yes |" in text and text in proc.stdout
    assert (tmp_path / "ablations.png").exists()


@pytest.mark.slow  # an integration run of a whole sweep: the full suite (CI) runs it
def test_value_of_correlation_smoke(tmp_path):
    _script("value_of_correlation.py", "--worlds", "2", "--quick", "--workers", "2", "--out", str(tmp_path))
    rows = read_rows(tmp_path / "value_of_correlation.csv")
    # 4 sweeps x 2 values x 2 models x 2 worlds, less the room sweep's 0.0 point, which is the same
    # job as the correlation sweep's 0.0 point (no co-location at all) and is run once.
    assert len(rows) == 4 * 2 * 2 * 2 - 2 * 2
    assert {r["detection_miss_rate"] for r in rows} == {0.0, 0.3}
    assert {r["same_room_teabag_kettle"] for r in rows if r["same_site_teabag_kettle"] == 0.0} >= {0.0, 0.9}
    assert {r["miss_likelihood"] for r in rows if r["detection_miss_rate"] == 0.3} == {0.3}
    text = (tmp_path / "value_of_correlation.md").read_text()
    for section in ("(a) correlation strength", "(b) detector miss rate", "(c) prior violation",
                    "(d) room correlation"):
        assert section in text
    for png in ("voc_correlation.png", "voc_miss_rate.png", "voc_prior_violation.png",
                "voc_room_correlation.png"):
        assert (tmp_path / png).exists()


@pytest.mark.slow  # an integration run of a whole sweep: the full suite (CI) runs it
def test_quick_compare_is_the_ten_world_ci_run(tmp_path):
    """`fg-tea compare --quick`: 10 paired worlds x 2 models x 4 planners, report and plots."""
    out = tmp_path / "quick"
    proc = subprocess.run([sys.executable, "-m", "fg_tea.cli", "compare", "--quick", "--out", str(out)],
                          capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = read_rows(out / "episodes.csv")
    assert len(rows) == 10 * 2 * 4
    assert {r["world_seed"] for r in rows} == set(range(10))
    assert {r["planner"] for r in rows} == {"efe", "greedy", "nearest", "optimal"}
    resolution = [line for line in proc.stdout.splitlines() if line.startswith("resolution: ")]
    assert len(resolution) == 4 and all("over 10 pairs" in line for line in resolution)
    summary = (out / "summary.md").read_text()
    assert "## Paired differences: joint − factorised" in summary and "Bayes-optimal limit" in summary


def test_an_interrupted_experiment_script_says_so_in_one_line(capsys):
    """Ctrl-C in an experiment script (run_script): one line and status 130, not a traceback."""
    from fg_tea.common.errors import run_script

    def main() -> int:
        raise KeyboardInterrupt

    with pytest.raises(SystemExit) as stop:
        run_script(main, "compare_at_scale.py")
    assert stop.value.code == 130
    assert capsys.readouterr().err == "compare_at_scale.py: interrupted\n"
