"""Reproducible logs: episode_start names its inputs portably and records what made the log.

Two copies of the repository at different paths, committed identically (so at the same commit),
run the same episode, with a bundled scenario and with the user's own files given as relative
paths; the logs must be byte-identical. The log holds no absolute path, records the sha256 of
every input file (the model's extends chain included), the library versions, the commit and the
rendering parameters, and the render and analysis code still read it.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from fg_tea.episode.log import read_log
from fg_tea.episode.metrics import score
from fg_tea.episode.provenance import LIBRARIES, bundled_file, git_state, without_git

ROOT = Path(__file__).resolve().parent.parent
#: Fixed identity and dates: the same tree then gives the same commit in both copies.
GIT_ENV = {"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@example.org",
           "GIT_AUTHOR_DATE": "2024-01-01T00:00:00+00:00", "GIT_COMMITTER_NAME": "t",
           "GIT_COMMITTER_EMAIL": "t@example.org", "GIT_COMMITTER_DATE": "2024-01-01T00:00:00+00:00"}
USER_MODEL = 'extends = "joint"\nname = "my_joint"\n'


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _env(cache: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("GIT_") and k != "PYTHONPATH"}
    env.update(GIT_ENV, FG_TEA_CACHE_DIR=str(cache), PYTHONDONTWRITEBYTECODE="1")
    return env


def _checkout(dest: Path, env: dict) -> str:
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in ("fg_tea", "scenarios", "models", "cameras"):
        shutil.copytree(ROOT / name, dest / name, ignore=ignore)
    for name in ("pyproject.toml", ".gitignore"):
        shutil.copy2(ROOT / name, dest / name)
    for args in (["init", "-q"], ["add", "-A"], ["commit", "-q", "-m", "snapshot"]):
        subprocess.run(["git", "-c", "init.defaultBranch=main", *args], cwd=dest, env=env, check=True)
    # The user's own files, untracked, given as relative paths.
    (dest / "mine").mkdir()
    shutil.copy2(ROOT / "scenarios" / "default_apartment.json", dest / "mine" / "house.json")
    (dest / "mine" / "model.toml").write_text(USER_MODEL)
    return subprocess.run(["git", "rev-parse", "HEAD"], cwd=dest, env=env, check=True,
                          capture_output=True, text=True).stdout.strip()


def _run(checkout: Path, env: dict, *args: str) -> bytes:
    out = checkout / "runs" / "out"
    done = subprocess.run([sys.executable, "-m", "fg_tea.cli", "run", *args, "--no-video",
                           "--out", str(out)], cwd=checkout, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return (out / "episode.jsonl").read_bytes()


@pytest.fixture(scope="module")
def two_checkouts(tmp_path_factory):
    base = tmp_path_factory.mktemp("checkouts")
    env = _env(base / "cache")
    a, b = base / "first" / "fg_tea_repo", base / "elsewhere" / "deeper" / "copy"
    commits = [_checkout(a, env), _checkout(b, env)]
    assert commits[0] == commits[1]
    probe = subprocess.run([sys.executable, "-c", "import fg_tea; print(fg_tea.__file__)"],
                           cwd=a, env=env, capture_output=True, text=True, check=True).stdout
    assert Path(probe.strip()).resolve() == (a / "fg_tea" / "__init__.py").resolve()
    return a, b, env, commits[0]


@pytest.mark.parametrize("args", [(), ("mine/house.json", "--model", "mine/model.toml", "--seed", "2")],
                         ids=["bundled", "user-files"])
@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_two_checkouts_at_one_commit_write_byte_identical_logs(two_checkouts, args):
    a, b, env, commit = two_checkouts
    first, second = _run(a, env, *args), _run(b, env, *args)
    assert first == second
    text = first.decode()
    for checkout in (a, b):
        assert str(checkout) not in text and str(checkout.resolve()) not in text
    start = json.loads(text.splitlines()[0])
    assert start["git"] == {"commit": commit, "dirty": False}
    assert start["parameters"]["render"] is None  # --no-video


def test_episode_start_records_inputs_versions_and_hashes(two_checkouts):
    a, _, env, _ = two_checkouts
    start = json.loads(_run(a, env, "mine/house.json", "--model", "mine/model.toml").splitlines()[0])
    assert start["scenario_file"] == "mine/house.json" and start["model_file"] == "mine/model.toml"
    inputs = start["inputs"]
    assert inputs["scenario"] == {"file": "mine/house.json", "bundled": None,
                                  "sha256": _sha(a / "mine" / "house.json")}
    chain = inputs["model"]
    assert [m["file"] for m in chain] == ["mine/model.toml", "joint", "factorised"]
    assert [m["bundled"] for m in chain] == [None, "models/joint.toml", "models/factorised.toml"]
    assert chain[0]["sha256"] == _sha(a / "mine" / "model.toml")
    assert chain[1]["sha256"] == _sha(a / "models" / "joint.toml")
    assert inputs["task"] == {"file": "make_tea", "bundled": "scenarios/tasks/make_tea.json",
                              "sha256": _sha(a / "scenarios" / "tasks" / "make_tea.json")}
    assert inputs["world"] is None
    assert set(start["versions"]) == {"fg_tea", "python", *LIBRARIES}
    assert all(start["versions"][k] for k in ("fg_tea", "numpy", "scipy", "networkx", "gtsam", "pybullet"))


def test_a_modified_tracked_file_marks_the_log_dirty(two_checkouts, tmp_path):
    a, _, env, commit = two_checkouts
    readme = a / "pyproject.toml"
    original = readme.read_bytes()
    try:
        readme.write_bytes(original + b"\n# local edit\n")
        start = json.loads(_run(a, env).splitlines()[0])
    finally:
        readme.write_bytes(original)
    assert start["git"] == {"commit": commit, "dirty": True}


def test_git_state_outside_a_checkout_is_none(monkeypatch, tmp_path):
    import fg_tea.episode.provenance as provenance

    git_state.cache_clear()
    monkeypatch.setattr(provenance, "checkout_root", lambda: tmp_path)
    try:
        assert provenance.git_state() is None
    finally:
        git_state.cache_clear()


def test_render_and_analysis_read_the_new_episode_start(tmp_path, monkeypatch):
    from fg_tea.cli import main
    from fg_tea.render.compose import load_plan_scenario
    from fg_tea.render.video import VideoOptions, plan_frames

    work = tmp_path / "work"
    (work / "mine").mkdir(parents=True)
    shutil.copy2(ROOT / "scenarios" / "milk_sugar_apartment.json", work / "mine" / "house.json")
    monkeypatch.chdir(work)
    out = tmp_path / "out"
    assert main(["run", "mine/house.json", "--out", str(out), "--max-frames", "150",
                 "--width", "128", "--height", "96", "--frame-stride", "50"]) in (0, 1)
    events = read_log(out / "episode.jsonl")
    start = events[0]
    assert start["parameters"]["render"]["width"] == 128
    assert "workers" not in start["parameters"]["render"]
    assert (out / "episode.mp4").stat().st_size > 0
    options = VideoOptions(width=128, height=96, frame_stride=50)
    plan = plan_frames(events, options)
    assert load_plan_scenario(plan).name == "milk_sugar_apartment"  # the user's file, as given
    monkeypatch.chdir(tmp_path)  # elsewhere, the relative path is gone: fall back by name
    assert load_plan_scenario(plan_frames(events, options)).name == "milk_sugar_apartment"
    (work / "mine" / "house.json").write_text((work / "mine" / "house.json").read_text() + "\n")
    monkeypatch.chdir(work)
    with pytest.warns(UserWarning, match="sha256 differs"):
        load_plan_scenario(plan_frames(events, options))
    assert score(events)["frames"] == events[-1]["frames"]  # metrics still score the log
    assert without_git(events)[0].get("git", "gone") == "gone" and "git" in events[0]


def test_bundled_paths_round_trip():
    assert bundled_file("models/ablations/no_epistemic.toml").name == "no_epistemic.toml"
    assert bundled_file("../etc/passwd") is None and bundled_file("models/nothing.toml") is None


def test_sweep_episodes_record_their_world():
    from fg_tea.env.fake import FakeHouse
    from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
    from fg_tea.model.spec import load_model
    from fg_tea.world.distributions import load_world
    from fg_tea.study.sweep import world_path

    world = load_world(world_path("correlated"))
    scenario, model = world.sample(4), load_model("factorised")
    runner = EpisodeRunner(scenario, model, FakeHouse(scenario, env_config_for(model)),
                           RunConfig(seed=4), world="correlated")
    start = runner.start()
    assert start["inputs"]["world"]["file"] == "correlated"
    assert start["inputs"]["world"]["bundled"] == "scenarios/worlds/correlated.json"
    assert start["inputs"]["scenario"]["file"] == "default_apartment"
    assert start["scenario"] == "correlated#4"
