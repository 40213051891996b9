"""A log is read for its meaning, not only its syntax (docs/log-format.md, "What a reader refuses").

One reader (:func:`fg_tea.episode.log.read_log`, checked by :mod:`fg_tea.episode.log_check`) serves
``explore``, ``learn`` and ``render``: ``Infinity`` or an overflowing literal where it cannot mean
anything (a seed, a pose, a probability, a metric; only an unreachable ``distance`` may be infinite),
``seq`` not rising from ``episode_start``, duplicate keys, NUL padding, a lone surrogate, a field of
the wrong type and a file of the size limit are each one stderr line naming the line and the field,
and exit 2. ``learn`` knows an episode by its content, not its bytes.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from fg_tea.cli.main import main


@pytest.fixture(scope="module")
def good_log(tmp_path_factory) -> list[str]:
    """The lines of a real episode log (``fg-tea run --no-video``)."""
    out = tmp_path_factory.mktemp("run")
    assert main(["run", "--no-video", "--out", str(out)]) == 0
    return (out / "episode.jsonl").read_text().splitlines()


@pytest.fixture
def no_render(monkeypatch):
    """``render`` reads and checks the log, then would render: here rendering is a failure."""
    import fg_tea.render.video as video

    def refuse(*args, **kwargs):
        raise AssertionError("the log was rendered, not refused")
    monkeypatch.setattr(video, "render_video", refuse)


def _write(tmp_path: Path, lines: list[str], name: str = "episode.jsonl", end: str = "\n") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(lines) + end)
    return path


def _argv(command: str, log: Path, tmp_path: Path) -> list[str]:
    out = {"explore": "page.html", "learn": "m.toml", "render": "v.mp4"}[command]
    return [command, str(log), "--out", str(tmp_path / out)]


def _refused(capsys, argv: list[str], *words: str) -> str:
    code = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err[-5:]
    assert all(w in err[0] for w in words), err[0]
    return err[0]


def _edit(lines: list[str], kind: str, change) -> tuple[list[str], int]:
    """`lines` with the first event of `kind` changed by `change(event)`; and its line number."""
    out = list(lines)
    for i, line in enumerate(out):
        event = json.loads(line)
        if event["event"] == kind:
            change(event)
            out[i] = json.dumps(event, separators=(",", ":"))
            return out, i + 1
    raise AssertionError(f"no {kind} event")


# ------------------------------------------------------------------ infinities
@pytest.mark.parametrize("kind,change,field", [
    ("episode_start", lambda e: e.update(seed=1e999), "episode_start.seed"),
    ("episode_start", lambda e: e["pose"].__setitem__(0, 1e999), "episode_start.pose[0]"),
    ("observation", lambda e: e["after"]["mug"].__setitem__(1, 1e999), "observation.after.mug[1]"),
    ("decision", lambda e: e["candidates"][0].update(probability=1e999),
     "decision.candidates[0].probability"),
    ("metrics", lambda e: e.update(spl=1e999), "metrics.spl"),
    ("metrics", lambda e: e.update(total_distance=1e999), "metrics.total_distance"),
])
@pytest.mark.parametrize("command", ["explore", "learn", "render"])
def test_infinity_where_it_cannot_mean_anything_is_refused(command, kind, change, field, good_log,
                                                            tmp_path, capsys, no_render):
    lines, n = _edit(good_log, kind, change)
    log = _write(tmp_path, lines)
    _refused(capsys, _argv(command, log, tmp_path), f"line {n}", field, "Infinity")


@pytest.mark.parametrize("literal", ["1e400", "-Infinity", "1" + "0" * 400 + ".0"])
def test_an_overflowing_literal_is_an_infinity_too(literal, good_log, tmp_path, capsys):
    lines = list(good_log)
    lines[0] = lines[0].replace('"seed":0', f'"seed":{literal}', 1)
    assert lines[0] != good_log[0]
    _refused(capsys, _argv("explore", _write(tmp_path, lines), tmp_path), "line 1", "episode_start.seed")


def test_an_unreachable_distance_may_be_infinite(good_log, tmp_path, capsys):
    lines, _ = _edit(good_log, "decision", lambda e: e["candidates"][-1].update(distance=1e999))
    assert "Infinity" in "".join(lines)
    assert main(_argv("explore", _write(tmp_path, lines), tmp_path)) == 0, capsys.readouterr().err


def test_an_unfindable_objects_cost_per_find_may_be_infinite(tmp_path):
    """The cost rule's give_up holds the weighing; with no look that can find the object its cost
    per find is infinite (fg_tea.agent.give_up.weigh). Only that key, and only +Infinity."""
    from fg_tea.common.errors import InputError
    from fg_tea.episode.log import read_log

    start = '{"seq":0,"event":"episode_start","frame":0}'
    weighed = '{"object":"mug","cost":0.0,"chance":0.0,"cost_per_find":%s,"value":60.0,"give_up":true}'
    log = tmp_path / "l.jsonl"
    log.write_text(start + '\n{"seq":1,"event":"give_up","weighed":' + weighed % "Infinity" + "}\n")
    assert read_log(log, strict=True)[1]["weighed"]["cost_per_find"] == float("inf")
    for bad, field in (("-Infinity", "give_up.weighed.cost_per_find"),):
        log.write_text(start + '\n{"seq":1,"event":"give_up","weighed":' + weighed % bad + "}\n")
        with pytest.raises(InputError, match=re.escape(f"line 2: {field}")):
            read_log(log)
    log.write_text(start + '\n{"seq":1,"event":"give_up","weighed":' + weighed % "0" + ',"value":Infinity}\n')
    with pytest.raises(InputError, match=re.escape("line 2: give_up.value")):
        read_log(log)


# ------------------------------------------------------------------ order, keys, bytes
def test_render_refuses_a_reversed_log_as_explore_does(good_log, tmp_path, capsys, no_render):
    log = _write(tmp_path, good_log[::-1])  # tac
    _refused(capsys, _argv("explore", log, tmp_path), "line 1", "episode_start")
    _refused(capsys, _argv("render", log, tmp_path), "line 1", "episode_start")


@pytest.mark.parametrize("command", ["explore", "learn", "render"])
def test_seq_must_rise_strictly(command, good_log, tmp_path, capsys, no_render):
    lines = list(good_log)
    lines[5], lines[6] = lines[6], lines[5]
    _refused(capsys, _argv(command, _write(tmp_path, lines), tmp_path), "line 7", "seq")


def test_a_second_episode_start_is_refused(good_log, tmp_path, capsys):
    lines = good_log + [good_log[0].replace('"seq":0', f'"seq":{len(good_log)}', 1)]
    _refused(capsys, _argv("learn", _write(tmp_path, lines), tmp_path), f"line {len(lines)}", "episode_start")


@pytest.mark.parametrize("command", ["explore", "learn", "render"])
def test_duplicate_keys_are_refused(command, good_log, tmp_path, capsys, no_render):
    lines = list(good_log)
    lines[3] = lines[3].replace('{"seq":3,', '{"seq":3,"event":"belief",', 1)
    assert lines[3] != good_log[3]
    _refused(capsys, _argv(command, _write(tmp_path, lines), tmp_path), "line 4", "duplicate key 'event'")


@pytest.mark.parametrize("command", ["explore", "render"])
def test_nul_padding_is_refused(command, good_log, tmp_path, capsys, no_render):
    log = _write(tmp_path, good_log)
    with open(log, "ab") as fh:
        fh.write(b"\0" * 4096)  # what a crash on some file systems leaves after the last line
    _refused(capsys, _argv(command, log, tmp_path), f"line {len(good_log) + 1}", "NUL")


# ------------------------------------------------------------------ types
@pytest.mark.parametrize("kind,change,field", [
    ("observation", lambda e: e.update(detections="mug"), "observation.detections"),
    ("observation", lambda e: e.update(motion=[[1.0, "x", 0.0]]), "observation.motion[0][1]"),
    ("confirm_search", lambda e: e.update(object=["mug"]), "confirm_search.object"),
    ("state_reading", lambda e: e.update(value="yes"), "state_reading.value"),
    ("belief", lambda e: e.update(locations=[0.5, 0.5]), "belief.locations"),
    ("decision", lambda e: e["candidates"].__setitem__(0, "mug"), "decision.candidates[0]"),
    ("episode_start", lambda e: e.update(scenario_file={"a": 1}), "episode_start.scenario_file"),
    ("episode_start", lambda e: e["sites"][0].update(position="here"), "episode_start.sites[0].position"),
    ("episode_start", lambda e: e["sites"][1].update(position=[1.0]), "episode_start.sites[1].position"),
    ("episode_start", lambda e: e["viewpoints"][2].update(position=None), "episode_start.viewpoints[2].position"),
    ("action", lambda e: e.update(frame="12"), "action.frame"),
    ("metrics", lambda e: e.update(success="yes"), "metrics.success"),
])
@pytest.mark.parametrize("command", ["explore", "learn", "render"])
def test_a_field_of_the_wrong_type_is_named(command, kind, change, field, good_log, tmp_path, capsys,
                                            no_render):
    lines, n = _edit(good_log, kind, change)
    _refused(capsys, _argv(command, _write(tmp_path, lines), tmp_path), f"line {n}", field)


@pytest.mark.parametrize("command", ["explore", "learn", "render"])
def test_a_lone_surrogate_is_refused_where_it_stands(command, good_log, tmp_path, capsys, no_render):
    lines = list(good_log)
    lines[0] = lines[0].replace('"objects":["mug"', '"objects":["mug\\ud800"', 1)
    assert lines[0] != good_log[0]
    _refused(capsys, _argv(command, _write(tmp_path, lines), tmp_path), "line 1",
             "episode_start.objects[0]", "surrogate")


def test_a_surrogate_pair_is_text(good_log, tmp_path, capsys):
    lines = list(good_log)
    lines[0] = lines[0].replace('"task":"make_tea"', '"task":"make_tea\\ud83c\\udf75"', 1)
    assert main(_argv("explore", _write(tmp_path, lines), tmp_path)) == 0, capsys.readouterr().err


# ------------------------------------------------------------------ learn counts an episode once
def test_learn_refuses_a_log_with_every_line_twice(good_log, tmp_path, capsys):
    doubled = [line for line in good_log for _ in range(2)]  # awk '{print; print}'
    _refused(capsys, _argv("learn", _write(tmp_path, doubled), tmp_path), "line 2", "a second episode_start")
    doubled = good_log[:1] + doubled[2:]  # the start once, every other line twice
    _refused(capsys, _argv("learn", _write(tmp_path, doubled), tmp_path), "line 3", "seq", "1 after 1")


@pytest.mark.parametrize("variant", ["blank_line", "keys_reordered", "spaced"])
def test_learn_knows_an_episode_by_its_content_not_its_bytes(variant, good_log, tmp_path, capsys):
    first = _write(tmp_path, good_log, "a.jsonl")
    assert main(["learn", str(first), "--out", str(tmp_path / "m1.toml")]) == 0
    if variant == "blank_line":
        again = _write(tmp_path, good_log, "b.jsonl", end="\n\n")
    else:
        events = [json.loads(line) for line in good_log]
        text = [json.dumps(dict(reversed(e.items()))) if variant == "keys_reordered" else json.dumps(e)
                for e in events]
        again = _write(tmp_path, text, "b.jsonl")
    assert again.read_bytes() != first.read_bytes()
    capsys.readouterr()
    _refused(capsys, ["learn", str(again), "--base", str(tmp_path / "m1.toml"), "--out",
                      str(tmp_path / "m2.toml")], "already counted", "a.jsonl")
    _refused(capsys, ["learn", str(first), str(again), "--out", str(tmp_path / "m3.toml")],
             "already counted")


def test_learn_still_refuses_a_log_a_model_holds_by_its_bytes(good_log, tmp_path, capsys):
    """A model learned before episodes were named by content holds the sha256 of the log's bytes."""
    import hashlib

    log = _write(tmp_path, good_log, "a.jsonl")
    assert main(["learn", str(log), "--out", str(tmp_path / "m1.toml")]) == 0
    model = (tmp_path / "m1.toml").read_text()
    raw = hashlib.sha256(log.read_bytes()).hexdigest()
    assert raw not in model  # the model names the episode by its content now
    older = tmp_path / "older.toml"
    older.write_text(re.sub(r'sha256 = "[0-9a-f]{64}"', f'sha256 = "{raw}"', model))
    capsys.readouterr()
    _refused(capsys, ["learn", str(log), "--base", str(older), "--out", str(tmp_path / "m2.toml")],
             "already counted")


def test_learn_counts_different_episodes(good_log, tmp_path, capsys):
    """The guard is not too eager: the same house, another seed, is another episode."""
    out = tmp_path / "run2"
    assert main(["run", "--no-video", "--seed", "1", "--out", str(out)]) == 0
    first = _write(tmp_path, good_log, "a.jsonl")
    assert main(["learn", str(first), str(out / "episode.jsonl"), "--out", str(tmp_path / "m.toml")]) == 0
    assert "2 new log(s)" in capsys.readouterr().out


# ------------------------------------------------------------------ the size limit
@pytest.mark.skipif(not hasattr(os, "truncate") or sys.platform != "linux", reason="sparse files")
def test_a_log_of_exactly_the_size_limit_is_one_line(good_log, tmp_path):
    """A file of exactly LOG_MAX_BYTES (sparse: NUL bytes after a real log) is refused in one line
    within a memory budget a workstation has, never a MemoryError's traceback."""
    from fg_tea.episode.log import LOG_MAX_BYTES

    log = _write(tmp_path, good_log)
    os.truncate(log, LOG_MAX_BYTES)
    code = ("import resource, sys; resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30)); "
            "from fg_tea.cli.main import main; sys.exit(main(sys.argv[1:]))")
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    for command in ("learn", "explore"):
        proc = subprocess.run([sys.executable, "-c", code, *_argv(command, log, tmp_path)],
                              capture_output=True, text=True, timeout=300, env=env)
        lines = proc.stderr.strip().splitlines()
        assert proc.returncode == 2 and len(lines) == 1, proc.stderr[-800:]


def test_the_checks_cover_every_documented_kind_and_the_doc_states_the_limit():
    from fg_tea.episode.log import EVENT_KINDS, LOG_MAX_BYTES
    from fg_tea.episode.log_check import FIELDS

    assert set(FIELDS) == set(EVENT_KINDS)
    doc = (Path(__file__).resolve().parents[1] / "docs" / "log-format.md").read_text()
    assert f"a file over {LOG_MAX_BYTES // 2 ** 20} MiB" in doc
