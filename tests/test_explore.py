"""`fg-tea explore` and the compare index, without a browser (docs/design.md §9.2): the page's data
against the log it came from, the alignment of two episodes, and every input fault as one line
(the browser tests are in tests/test_explorer_browser.py)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from fg_tea.episode.log import read_log
from fg_tea.render.explore import align, episode_data, page_data, read_episode

ROOT = Path(__file__).resolve().parent.parent


def _cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "fg_tea.cli", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """The default episode, factorised and joint (they part at the second decision), in the
    PyBullet house: the logs a user explores."""
    from fg_tea.episode.run import run_episode
    from fg_tea.model.spec import load_model
    from fg_tea.world.scenario import load_scenario

    tmp = tmp_path_factory.mktemp("explore")
    scenario = load_scenario("default_apartment")
    for model in ("factorised", "joint"):
        run_episode(scenario, load_model(model), log=tmp / f"{model}.jsonl")
    return tmp


def page_of(html: str) -> dict:
    match = re.search(r'<script id="data" type="application/json">(.*?)</script>', html, re.S)
    assert match, "the page carries its data"
    return json.loads(match.group(1))


def test_every_event_is_a_step_with_the_logs_beliefs(logs):
    events = read_log(logs / "factorised.jsonl")
    ep = episode_data(events)
    assert len(ep["steps"]) == len(events) and ep["lacks"] == [] and ep["outcome"] == "complete"
    for step, e in zip(ep["steps"], events):
        assert step["seq"] == e["seq"] and step["event"] == e["event"]
        if e["event"] == "observation":
            for obj, p in e["after"].items():
                assert step["locations"][obj] == p
        if e["event"] == "belief":
            assert step["locations"] == e["locations"] and step["states"] == {**step["states"], **e["states"]}
        if e["event"] == "decision":
            table = ep["decisions"][step["decision"]]
            chosen = dict(zip(table["columns"], table["rows"][table["chosen"]]))
            assert (chosen["object"], chosen["viewpoint"], chosen["total"]) == (e["object"], e["viewpoint"], e["total"])
            assert len(table["rows"]) == len(e["candidates"])
    last = ep["steps"][-1]
    assert all(code == ep["task_codes"].index("complete") for code in last["tasks"])


def test_two_episodes_part_at_the_first_decision_whose_choice_differs(logs):
    a, b = (episode_data(read_log(logs / f"{m}.jsonl")) for m in ("factorised", "joint"))
    choices = [[(d["object"], d["viewpoint"]) for d in ep["decisions"]] for ep in (a, b)]
    first = next(k for k in range(min(map(len, choices))) if choices[0][k] != choices[1][k])
    aligned = align(a, b)
    div = aligned["divergence"]
    assert div["decision"] == first
    assert (div["a"]["object"], div["a"]["viewpoint"]) == choices[0][first]
    assert (div["b"]["object"], div["b"]["viewpoint"]) == choices[1][first]
    assert aligned["pairs"][div["pair"]] == [div["a"]["step"], div["b"]["step"]]
    # every step of each episode is on the slider, in order
    for side, ep in enumerate((a, b)):
        shown = [p[side] for p in aligned["pairs"]]
        assert shown == sorted(shown) and set(shown) == set(range(len(ep["steps"])))
    same = align(a, a)
    assert same["divergence"] is None and all(x == y for x, y in same["pairs"])


def test_explore_writes_one_page_with_its_data_inlined(logs, tmp_path):
    proc = _cli("explore", logs / "factorised.jsonl", "--out", tmp_path / "e.html", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    html = (tmp_path / "e.html").read_text()
    assert "<script src" not in html and "<link " not in html and "http://" not in html.split("<script id")[0]
    data = page_of(html)
    assert data["episodes"][0]["steps"][-1]["event"] == "metrics" and data["house"]["walls"]
    assert data["task_edges"] and (tmp_path / "e.html").stat().st_size < 2e6
    proc = _cli("explore", logs / "factorised.jsonl", logs / "joint.jsonl", "--out", tmp_path / "ab.html",
                cwd=tmp_path)
    assert proc.returncode == 0 and "choices differ first at decision 2" in proc.stdout, proc.stdout + proc.stderr
    assert page_of((tmp_path / "ab.html").read_text())["divergence"]["decision"] == 1


def _one_line(proc, *needles):
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr[-1500:]
    for needle in needles:
        assert needle in lines[0], lines[0]


def test_faults_are_one_line_and_exit_2(logs, tmp_path):
    text = (logs / "factorised.jsonl").read_text().splitlines()
    corrupt = tmp_path / "corrupt.jsonl"
    corrupt.write_text("\n".join(text[:5] + ["{not json"] + text[5:]) + "\n")
    _one_line(_cli("explore", corrupt, cwd=tmp_path), "corrupt.jsonl", "line 6")
    newer = tmp_path / "newer.jsonl"
    start = json.loads(text[0])
    start["versions"]["fg_tea"] = "99.0.0"
    newer.write_text("\n".join([json.dumps(start)] + text[1:]) + "\n")
    _one_line(_cli("explore", newer, cwd=tmp_path), "newer.jsonl", "fg_tea 99.0.0")
    not_a_log = tmp_path / "x.jsonl"
    not_a_log.write_text('{"event": "decision"}\n')
    _one_line(_cli("explore", not_a_log, cwd=tmp_path), "x.jsonl", "episode_start")
    _one_line(_cli("explore", logs / "factorised.jsonl", "--video", tmp_path / "gone.mp4",
                   "--out", tmp_path / "v.html", cwd=tmp_path), "gone.mp4", "--video")
    other = tmp_path / "other.jsonl"
    start = json.loads(text[0])
    start["world"]["placements"]["mug"] = [0.0, 0.0, 0.0]
    other.write_text("\n".join([json.dumps(start)] + text[1:]) + "\n")
    _one_line(_cli("explore", logs / "factorised.jsonl", other, "--out", tmp_path / "o.html", cwd=tmp_path),
              "other.jsonl", "same world")
    assert not list(tmp_path.glob("*.html")), "nothing is written for bad input"


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_a_truncated_log_and_a_deleted_scenario_give_a_page_that_says_what_is_missing(logs, tmp_path):
    text = (logs / "factorised.jsonl").read_text()
    cut = tmp_path / "cut.jsonl"
    cut.write_text(text[: len(text) // 2])  # a crash mid-line
    proc = _cli("explore", cut, "--out", tmp_path / "cut.html", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    lacks = page_of((tmp_path / "cut.html").read_text())["episodes"][0]["lacks"]
    assert any("episode_end" in x for x in lacks)
    # a user's scenario file, deleted after the run
    house = tmp_path / "my_house.json"
    data = json.loads((ROOT / "scenarios" / "default_apartment.json").read_text())
    data["description"] = "my own copy"  # other bytes than the bundled house of the same name
    house.write_text(json.dumps(data))
    proc = _cli("run", house, "--no-video", "--out", tmp_path / "run", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    house.unlink()
    proc = _cli("explore", tmp_path / "run" / "episode.jsonl", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    data = page_of((tmp_path / "run" / "episode.html").read_text())
    assert "my_house.json" in data["house"]["missing"] and not data["house"]["walls"]
    assert len(data["house"]["sites"]) == 8 and data["task_edges"] is None


def test_an_older_log_without_viewpoints_still_opens_and_says_so(logs):
    events = read_log(logs / "factorised.jsonl")
    old = []
    for e in events:
        e = {k: v for k, v in e.items() if k not in ("viewpoints", "viewpoint_kind", "sites_in_view")}
        if "viewpoint" in e:
            e["site"] = e.pop("viewpoint")
        old.append(e)
    data = page_data([("old.jsonl", old)])
    ep = data["episodes"][0]
    assert any("viewpoints" in x for x in ep["lacks"])
    looks = [s["look"] for s in ep["steps"] if s["event"] == "observation"]
    assert looks and all(look["sites"] == [look["viewpoint"]] for look in looks)


def test_read_episode_checks_the_first_event(tmp_path):
    from fg_tea.common.errors import InputError

    empty = tmp_path / "e.jsonl"
    empty.write_text("")
    with pytest.raises(InputError, match="episode_start"):
        read_episode(empty)


@pytest.mark.slow
def test_compare_writes_an_index_linking_each_worlds_pair(tmp_path):
    proc = _cli("compare", "--quick", "--env", "fake", "--worlds", "3", "--planners", "efe",
                "--models", "factorised_close", "joint_close", "--executor", "serial", "--out", tmp_path / "c",
                cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    index = (tmp_path / "c" / "index.html").read_text()
    links = re.findall(r'href="(explore/world\d+\.html)"', index)
    assert len(links) == 3 and all((tmp_path / "c" / link).is_file() for link in links)
    diffs = [abs(float(x)) for x in re.findall(r"<td class=num>([+-]\d+\.\d+)</td>", index)]
    assert diffs == sorted(diffs, reverse=True), "sorted by the size of the difference"
    assert "mismatch" not in index.split("</style>")[1], "the re-run episodes are the sweep's own"
    page = page_of((tmp_path / "c" / links[0]).read_text())
    assert [ep["model"] for ep in page["episodes"]] == ["factorised_close", "joint_close"]


def test_the_page_never_overwrites_its_inputs(logs, tmp_path):
    log = tmp_path / "v.jsonl"
    log.write_bytes((logs / "factorised.jsonl").read_bytes())
    before = log.read_bytes()
    _one_line(_cli("explore", log, "--out", log, cwd=tmp_path), "--out", "input LOG")
    assert log.read_bytes() == before
    _one_line(_cli("explore", log, "--label", "a", "b", cwd=tmp_path), "--label")


@pytest.mark.parametrize("field,value,fault", [
    ("belief", {}, "belief.locations"), ("sites", None, "sites"), ("sites", [], "sites"),
    ("pose", None, "pose"), ("sites", [{"name": "x"}], "sites[0]"),
])
def test_a_damaged_start_is_one_line(logs, tmp_path, field, value, fault):
    text = (logs / "factorised.jsonl").read_text().splitlines()
    start = json.loads(text[0])
    start[field] = value
    bad = tmp_path / "bad.jsonl"
    bad.write_text("\n".join([json.dumps(start)] + text[1:]) + "\n")
    _one_line(_cli("explore", bad, cwd=tmp_path), "bad.jsonl", fault)


def test_a_damaged_event_is_one_line_naming_its_line(logs, tmp_path):
    text = (logs / "factorised.jsonl").read_text().splitlines()
    n = next(i for i, line in enumerate(text) if '"motion"' in line)
    event = json.loads(text[n])
    event["motion"] = [["a", "b", "c"]]
    bad = tmp_path / "bad.jsonl"
    bad.write_text("\n".join(text[:n] + [json.dumps(event)] + text[n + 1:]) + "\n")
    _one_line(_cli("explore", bad, cwd=tmp_path), "bad.jsonl", f"line {n + 1}", event["event"])


def test_a_partial_last_line_is_named_on_the_page(logs):
    text = (logs / "factorised.jsonl").read_text()
    path = logs / "partial.jsonl"
    path.write_text(text + '{"event": "bro')
    ep = episode_data(read_episode(path))
    assert any("last line" in x for x in ep["lacks"]) and ep["outcome"] == "complete"
    assert not any("entropy" in x for x in ep["lacks"])


def test_two_episodes_of_different_tasks_each_get_their_own_graph(tmp_path):
    from fg_tea.study.sweep import Job, run_job

    for task in ("make_tea", "find_mug"):
        run_job(Job("independent", 1, "factorised", "efe", task=task, env="fake"), tmp_path / f"{task}.jsonl")
    data = page_data([(str(tmp_path / f"{t}.jsonl"), read_episode(tmp_path / f"{t}.jsonl"))
                      for t in ("make_tea", "find_mug")])
    a, b = data["episodes"]
    assert {x for e in a["task_edges"] for x in e} <= set(a["tasks"])
    assert b["task_edges"] == [] and b["tasks"] == ["search_mug"]


def test_a_log_written_before_viewpoints_and_inputs_opens(tmp_path):
    """A log written by fg_tea before room glances existed (commit before eba4514: no
    viewpoints, no `inputs`, absolute paths) opens, says what it lacks, and still finds its task
    graph from the model file's name and the bundled task."""
    old = ROOT / "tests" / "data" / "old_logs" / "before_viewpoints.jsonl"
    proc = _cli("explore", old, "--out", tmp_path / "old.html", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    data = page_of((tmp_path / "old.html").read_text())
    ep = data["episodes"][0]
    assert any("viewpoints" in x for x in ep["lacks"]) and ep["outcome"] == "complete"
    assert data["house"]["walls"] and data["task_edges"], "the bundled house and task stand in"
    assert len(ep["decisions"]) == 4 and all(d["chosen"] is not None for d in ep["decisions"])
