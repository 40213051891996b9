"""The comparison at scale and the generated-house quick compare: SPL columns, tables, resume."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from fg_tea.common.errors import InputError
from fg_tea.study.rows import read_rows

ROOT = Path(__file__).resolve().parent.parent


def _run(*argv: str, timeout: int = 600) -> subprocess.CompletedProcess:
    proc = subprocess.run([sys.executable, *argv], capture_output=True, text=True, timeout=timeout,
                          stdin=subprocess.DEVNULL, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc


def _check_spl(rows):
    assert rows and all("clairvoyant_search_travel" in r and "spl" in r for r in rows)
    for r in rows:
        assert r["clairvoyant_search_travel"] > 0
        assert 0.0 <= r["spl"] <= 1.0


@pytest.mark.slow
def test_compare_at_scale_tiny_fake_run_writes_every_table_and_resumes(tmp_path):
    table = tmp_path / "houses"  # each table writes into OUT/TABLE
    args = ("experiments/compare_at_scale.py", "--table", "houses", "--worlds", "2", "--sizes", "small",
            "--tasks", "make_tea", "--planners", "factorised_efe", "mi_efe", "nearest", "--env", "fake",
            "--executor", "serial", "--timing-worlds", "1", "--out", str(tmp_path))
    _run(*args)
    rows = read_rows(table / "episodes.csv")
    assert len(rows) == 2 * 2 * 3  # worlds x {factorised, joint} x planners
    assert {r["structure"] for r in rows} == {"factorised", "joint"}
    _check_spl(rows)
    text = (table / "houses.md").read_text()
    assert "joint − factorised" in text and "exact MI" in text and "eqs. 10-11" in text
    assert "median ms" in text and (table / "houses_heatmap.png").stat().st_size > 0
    with (table / "houses_paired.csv").open(newline="") as fh:
        paired = list(csv.DictReader(fh))
    assert {r["planner"] for r in paired} == {"factorised_efe", "mi_efe", "nearest"}
    assert all(r["pairs"] == "2" for r in paired)
    before = (table / "episodes.csv").read_bytes()
    _run(*args[:-4], "--timing-worlds", "0", "--out", str(tmp_path))
    assert " 0 new episodes" in (table / "houses.md").read_text()  # nothing ran again
    assert (table / "episodes.csv").read_bytes() == before


@pytest.mark.slow  # whole sweeps or derivations: the full suite (CI) runs it
def test_houses_report_covers_cells_run_by_separate_commands(tmp_path):
    """A second command with another task and fewer worlds joins the first one's report."""
    table = tmp_path / "houses"
    common = ("experiments/compare_at_scale.py", "--table", "houses", "--sizes", "small",
              "--planners", "factorised_efe", "--env", "fake", "--executor", "serial",
              "--timing-worlds", "1", "--out", str(tmp_path))
    _run(*common, "--worlds", "2", "--tasks", "make_tea")
    _run(*common, "--worlds", "1", "--tasks", "make_tea_milk_sugar")
    with (table / "houses_paired.csv").open(newline="") as fh:
        pairs = {r["task"]: r["pairs"] for r in csv.DictReader(fh)}
    assert pairs == {"make_tea": "2", "make_tea_milk_sugar": "1"}
    commands = (table / "commands.txt").read_text().splitlines()
    assert len(commands) == 2 and "make_tea_milk_sugar" in commands[1]
    text = (table / "houses.md").read_text()
    assert commands[0] in text and commands[1] in text
    with (table / "decision_times.csv").open(newline="") as fh:
        times = list(csv.DictReader(fh))
    assert {t["task"] for t in times} == {"make_tea", "make_tea_milk_sugar"}  # merged, not replaced


@pytest.mark.slow  # whole sweeps or derivations: the full suite (CI) runs it
def test_reused_rows_are_the_rows_a_run_would_write(tmp_path):
    """--reuse copies the rows of this run's jobs from another CSV (equal keys, equal rows) and
    runs only the rest: the CSV equals one run of every job, byte for byte."""
    common = ("experiments/compare_at_scale.py", "--table", "houses", "--sizes", "small",
              "--tasks", "make_tea", "--worlds", "2", "--env", "fake", "--executor", "serial",
              "--timing-worlds", "0")
    _run(*common, "--planners", "factorised_efe", "nearest", "--out", str(tmp_path / "all"))
    _run(*common, "--planners", "factorised_efe", "--out", str(tmp_path / "one"))
    proc = _run(*common, "--planners", "factorised_efe", "nearest", "--out", str(tmp_path / "two"),
                "--reuse", str(tmp_path / "one" / "houses" / "episodes.csv"))
    assert "reused 4 rows" in proc.stderr
    assert "for 4 new episodes" in (tmp_path / "two" / "houses" / "houses.md").read_text()
    whole = (tmp_path / "all" / "houses" / "episodes.csv").read_bytes()
    assert (tmp_path / "two" / "houses" / "episodes.csv").read_bytes() == whole
    proc = subprocess.run([sys.executable, *common, "--planners", "nearest", "--out",
                           str(tmp_path / "bad"), "--reuse", str(tmp_path / "one" / "houses" / "houses.md")],
                          capture_output=True, text=True, stdin=subprocess.DEVNULL, cwd=ROOT)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert "key" in proc.stderr
    assert not any((tmp_path / "bad").rglob("*"))  # refused before the table or its seed sets


def test_every_flag_is_checked_before_anything_is_written(tmp_path):
    """One line, exit 2, nothing written, for each bad value (a missing --reuse file used to end
    in a traceback, and --timing-worlds -1 ran the whole table)."""
    import os
    os.mkfifo(tmp_path / "fifo.csv")  # opening it to read would wait for a writer forever
    for bad, word in ((["--reuse", str(tmp_path / "none.csv")], "--reuse"),
                      (["--reuse", str(tmp_path / "fifo.csv")], "not a regular file"),
                      (["--reuse", str(tmp_path)], "--reuse"),
                      (["--timing-worlds", "-1"], "--timing-worlds"),
                      (["--confirmation-worlds", "0", "--confirmation-first-seed", "10000"],
                       "--confirmation-worlds"),
                      (["--confirmation-worlds", "5"], "--confirmation-first-seed"),
                      (["--episode-seeds", "bogus"], "--episode-seeds"),
                      (["--worlds", "0"], "--worlds"),
                      (["--strengths", "1.5", "--table", "detectability"], "--strengths")):
        proc = subprocess.run([sys.executable, "experiments/compare_at_scale.py", *bad, "--out",
                               str(tmp_path / "out")], capture_output=True, text=True,
                              stdin=subprocess.DEVNULL, cwd=ROOT, timeout=120)
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, (bad, proc.stderr)
        assert word in proc.stderr, (bad, proc.stderr)
    assert not any((tmp_path / "out").rglob("*"))  # the folder is made and probed at parse time, empty


@pytest.mark.slow
def test_detectability_table_changes_camera_and_agent_curves(tmp_path):
    table = tmp_path / "detectability"
    _run("experiments/compare_at_scale.py", "--table", "detectability", "--worlds", "2", "--sizes",
         "small", "--half-pixels", "25", "100", "--strengths", "0", "1", "--planners", "nearest",
         "--env", "fake", "--executor", "serial", "--timing-worlds", "0", "--out", str(tmp_path))
    from fg_tea.env.camera import load_camera
    from fg_tea.model.spec import load_model

    model = load_model(table / "models" / "joint_n50_25.toml")
    camera = load_camera(table / "cameras" / "visibility_n50_25.toml")
    assert model.structure == "joint" and camera.curve.params("teabag").half_pixels == 25.0
    assert model.detection_curve.params("teabag").half_pixels == 25.0
    assert camera.curve.params("mug") == load_camera("visibility").curve.params("mug")
    rows = read_rows(table / "episodes.csv")
    assert len(rows) == 2 * 2 * 2 * 2  # worlds x models x n_50 x strengths
    assert sorted({round(r["same_site_teabag_kettle"], 9) for r in rows}) == [0.0, round(2 / 3, 9)]
    _check_spl(rows)
    assert "| small | 25.0 | 0.0 |" in (table / "detectability.md").read_text()


@pytest.mark.slow  # an integration run of a whole sweep: the full suite (CI) runs it
def test_generated_medium_quick_compare_fake_has_spl_and_no_optimal(tmp_path):
    proc = _run("-m", "fg_tea.cli", "compare", "--world", "generated_medium", "--quick", "--worlds", "2",
                "--env", "fake", "--executor", "serial", "--out", str(tmp_path))
    assert "planner optimal left out" in proc.stderr
    rows = read_rows(tmp_path / "episodes.csv")
    assert "optimal" not in {r["planner"] for r in rows}
    _check_spl(rows)
    assert "SPL" in (tmp_path / "summary.md").read_text()


def test_compare_refuses_optimal_on_a_large_world_before_any_work(tmp_path):
    out = tmp_path / "never"
    proc = subprocess.run([sys.executable, "-m", "fg_tea.cli", "compare", "--world", "generated_medium",
                           "--planners", "efe", "optimal", "--worlds", "1", "--out", str(out)],
                          capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "optimal" in lines[0] and "sites exceed the limit of 10" in lines[0]
    assert not out.exists()


def test_run_refuses_optimal_on_a_large_house_before_writing_a_log(tmp_path):
    out = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-m", "fg_tea.cli", "run", "generated_medium", "--planner",
                           "optimal", "--no-video", "--out", str(out)],
                          capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "optimal planner refuses this house (size)" in proc.stderr
    assert not (out / "episode.jsonl").exists()


@pytest.mark.slow
def test_generated_medium_quick_compare_in_the_pybullet_house(tmp_path):
    """The CI command itself: 10 worlds x 2 models x the quick planners that fit (no optimal)."""
    _run("-m", "fg_tea.cli", "compare", "--world", "generated_medium", "--quick", "--out", str(tmp_path),
         timeout=1200)
    rows = read_rows(tmp_path / "episodes.csv")
    assert len(rows) == 10 * 2 * 3 and "optimal" not in {r["planner"] for r in rows}
    _check_spl(rows)


@pytest.mark.slow
def test_a_replicated_run_declares_its_seed_sets_first_and_judges_every_cell(tmp_path):
    """--confirmation-first-seed: seed_sets.json before any episode, a replication section and CSV
    with both sets, the lookahead among the planners, decision times with p95 and CPU; a later run
    with other sets in the same folder is refused in one line (docs/design.md §11.1)."""
    common = ("experiments/compare_at_scale.py", "--table", "houses", "--worlds", "2", "--sizes",
              "small", "--tasks", "make_tea", "--planners", "factorised_efe", "lookahead", "--env",
              "fake", "--executor", "serial", "--timing-worlds", "1", "--out", str(tmp_path))
    _run(*common, "--confirmation-first-seed", "10000")
    table = tmp_path / "houses"
    sets = json.loads((table / "seed_sets.json").read_text())["sets"]
    assert [(s["name"], s["first"], s["count"]) for s in sets] == [("discovery", 0, 2),
                                                                   ("confirmation", 10000, 2)]
    rows = read_rows(table / "episodes.csv")
    assert {r["world_seed"] for r in rows} == {0, 1, 10000, 10001} and len(rows) == 4 * 2 * 2
    text = (table / "houses.md").read_text()
    assert "## Replication: joint − factorised search travel (m)" in text and "| lookahead |" in text
    with (table / "houses_replication.csv").open(newline="") as fh:
        cells = list(csv.DictReader(fh))
    assert {c["planner"] for c in cells} == {"eqs. 10-11", "lookahead"}
    assert all(c["verdict"] in ("established", "not resolved", "no difference") for c in cells)
    assert all(c["discovery_pairs"] == "2" and c["confirmation_pairs"] == "2" for c in cells)
    for c in cells:  # the difference in per cent of the factorised mean on the same worlds
        for s in ("discovery", "confirmation"):
            base = float(c[f"{s}_baseline"])
            for k in ("diff", "low", "high"):
                assert float(c[f"{s}_{k}_pct"]) == pytest.approx(100 * float(c[f"{s}_{k}"]) / base)
    (look,) = [c for c in cells if c["planner"] == "lookahead"]
    factorised = [r["search_distance"] for r in rows if r["planner"] == "lookahead"
                  and r["structure"] == "factorised" and r["world_seed"] >= 10000]
    assert float(look["confirmation_baseline"]) == pytest.approx(sum(factorised) / len(factorised))
    with (table / "decision_times.csv").open(newline="") as fh:
        times = list(csv.DictReader(fh))
    assert times and all(float(t["cpu_p95_ms"]) >= float(t["cpu_median_ms"]) for t in times)
    proc = subprocess.run([sys.executable, *common, "--confirmation-first-seed", "20000"],
                          capture_output=True, text=True, stdin=subprocess.DEVNULL, cwd=ROOT)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert "seed_sets.json" in proc.stderr and "another --out" in proc.stderr
    proc = subprocess.run([sys.executable, *common[:-2], "--out", str(tmp_path / "b"),
                           "--confirmation-first-seed", "1"], capture_output=True, text=True,
                          stdin=subprocess.DEVNULL, cwd=ROOT)
    assert proc.returncode == 2 and "overlap" in proc.stderr
    assert not (tmp_path / "b" / "houses" / "episodes.csv").exists()


def test_independent_episode_seeds_are_their_own_stream():
    """The default episode seeds (independent): the episode seed of world seed w differs between
    world distributions and from w, is the same for every model and planner of one world
    (paired), and is the same number on every call; ``world`` keeps w."""
    from fg_tea.study.seeds import episode_seed
    from fg_tea.study.sweep import plan_sweep

    kw = dict(models=["factorised", "joint"], planners=["efe", "nearest"])
    worlds = ["generated_small", "generated_medium"]
    same = plan_sweep(worlds, 3, kw["models"], kw["planners"], episode_seeds="world")
    assert all(j.seed == j.world_seed for j in same)
    jobs = plan_sweep(worlds, 3, kw["models"], kw["planners"])
    assert [j.key for j in jobs] == [j.key for j in plan_sweep(worlds, 3, kw["models"], kw["planners"],
                                                               episode_seeds="independent")]
    by_world = {}
    for j in jobs:
        by_world.setdefault((j.world, j.world_seed), set()).add(j.seed)
    assert all(len(s) == 1 for s in by_world.values())            # paired within a world
    seeds = {k: next(iter(v)) for k, v in by_world.items()}
    for w in range(3):
        assert seeds[("generated_small", w)] != seeds[("generated_medium", w)]
        assert seeds[("generated_small", w)] == episode_seed("generated_small", w)
        assert seeds[("generated_small", w)] != w
    assert episode_seed("scenarios/worlds/generated_small.json", 1) == episode_seed("generated_small", 1)
    assert len({j.key for j in jobs} & {j.key for j in same}) == 0
    from fg_tea.common.errors import InputError
    with pytest.raises(InputError, match="episode_seeds"):
        plan_sweep(worlds, 1, kw["models"], kw["planners"], episode_seeds="bogus")


def test_a_table_run_with_one_episode_seed_scheme_refuses_the_other(tmp_path):
    """Resuming into a CSV whose episodes ran under the other --episode-seeds scheme would mix two
    sets of detector draws in one table: refused with one line naming the file, before any run."""
    from fg_tea.common.errors import InputError
    from fg_tea.study.seeds import check_episode_seeds
    from fg_tea.study.sweep import plan_sweep

    world = plan_sweep(["correlated"], 2, ["factorised"], ["efe"], env="fake", episode_seeds="world")
    independent = plan_sweep(["correlated"], 2, ["factorised"], ["efe"], env="fake")
    held = [j.key for j in world]
    check_episode_seeds(world, held, tmp_path / "episodes.csv")            # the same scheme resumes
    check_episode_seeds(independent, [], tmp_path / "episodes.csv")        # nothing held yet
    with pytest.raises(InputError, match=r"episodes\.csv.*world seed 0 of correlated ran here with "
                       r"episode seed 0.*other --episode-seeds scheme"):
        check_episode_seeds(independent, held, tmp_path / "episodes.csv")


@pytest.mark.slow
def test_compare_at_scale_refuses_the_other_scheme_and_its_rows(tmp_path):
    """Through the command: a table run with --episode-seeds world, then the default, then the
    default again copying the first table's rows with --reuse."""
    common = [sys.executable, "experiments/compare_at_scale.py", "--table", "houses", "--worlds", "1",
              "--sizes", "small", "--tasks", "make_tea", "--planners", "nearest", "--env", "fake",
              "--workers", "1", "--timing-worlds", "0", "--out", str(tmp_path / "t")]
    first = subprocess.run(common + ["--episode-seeds", "world"], capture_output=True, text=True,
                           stdin=subprocess.DEVNULL, cwd=ROOT)
    assert first.returncode == 0, first.stderr
    commands = (tmp_path / "t" / "houses" / "commands.txt").read_text()
    assert "--episode-seeds world" in commands
    rows = (tmp_path / "t" / "houses" / "episodes.csv").read_bytes()
    second = subprocess.run(common, capture_output=True, text=True, stdin=subprocess.DEVNULL, cwd=ROOT)
    assert second.returncode == 2 and len(second.stderr.strip().splitlines()) == 1, second.stderr
    assert "--episode-seeds" in second.stderr and "episodes.csv" in second.stderr
    assert (tmp_path / "t" / "houses" / "episodes.csv").read_bytes() == rows
    # rows of the other scheme are not copied in with --reuse either
    third = subprocess.run(common[:-1] + [str(tmp_path / "u"), "--reuse",
                                          str(tmp_path / "t" / "houses" / "episodes.csv")],
                           capture_output=True, text=True, stdin=subprocess.DEVNULL, cwd=ROOT)
    assert third.returncode == 2 and "--episode-seeds" in third.stderr, third.stderr
    assert not any((tmp_path / "u").rglob("*"))


@pytest.mark.slow
def test_fg_tea_compare_refuses_the_other_scheme_before_its_report_is_replaced(tmp_path):
    out = tmp_path / "c"
    common = [sys.executable, "-m", "fg_tea.cli", "compare", "--worlds", "1", "--env", "fake",
              "--planners", "nearest", "--executor", "serial", "--pages", "0", "--out", str(out)]
    first = subprocess.run(common + ["--episode-seeds", "world"], capture_output=True, text=True,
                           stdin=subprocess.DEVNULL, cwd=ROOT)
    assert first.returncode == 0, first.stderr
    assert "--episode-seeds world" in (out / "summary.md").read_text()
    files = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    second = subprocess.run(common, capture_output=True, text=True, stdin=subprocess.DEVNULL, cwd=ROOT)
    assert second.returncode == 2 and len(second.stderr.strip().splitlines()) == 1, second.stderr
    assert "--episode-seeds" in second.stderr
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == files


def test_compare_refuses_episode_seeds_with_lifelong(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "fg_tea.cli", "compare", "--lifelong", "2", "--worlds", "1",
                           "--episode-seeds", "independent", "--out", str(tmp_path / "x")],
                          capture_output=True, text=True, stdin=subprocess.DEVNULL, cwd=ROOT)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert "--episode-seeds" in proc.stderr


def _script():
    from experiment_scripts import load_experiment

    return load_experiment("compare_at_scale")


@pytest.mark.parametrize("table", ["houses", "detectability", "related"])
def test_each_unresolved_cell_gets_a_command_that_would_resolve_it(table, monkeypatch):
    """The report's Ray commands: one per cell not established and short of its pairs, each a
    valid command of this script for that cell alone, sized from the discovery set, on fresh
    seeds; established or already large enough cells get none."""
    from fg_tea.study.replication import ESTABLISHED, NOT_RESOLVED, SeedSet

    monkeypatch.chdir(ROOT)
    cas = _script()
    out = "experiments/results/joint_vs_factorised" + ("_related" if table == "related" else "")
    args = cas.parse_args(["--table", table, "--worlds", "200", "--confirmation-first-seed", "10000",
                           "--episode-seeds", "world", "--out", out]
                          + (["--derive-worlds", "500"] if table == "related" else []))
    sets = [SeedSet("discovery", 0, 200), SeedSet("confirmation", 10000, 200)]
    where = {"houses": {"size": "medium", "task": "make_tea"},
             "related": {"size": "small", "related": 3}}.get(
        table, {"size": "small", "half_pixels": 100.0, "strength": 0.75})
    cells = [{**where, "planner": "mi_efe", "verdict": NOT_RESOLVED, "pairs_needed": 924,
              "confirmation": {"pairs": 200}},
             {**where, "planner": "lookahead", "verdict": ESTABLISHED, "pairs_needed": 924,
              "confirmation": {"pairs": 200}},
             {**where, "planner": "factorised_efe", "verdict": NOT_RESOLVED, "pairs_needed": 150,
              "confirmation": {"pairs": 200}}]
    lines = [line.strip() for line in cas.resolve_commands(args, cells, sets) if line.startswith("    ")]
    assert len(lines) == 1
    import shlex
    argv = shlex.split(lines[0])[2:]
    again = cas.parse_args(argv)
    assert again.planners == ["mi_efe"] and again.confirmation_worlds == 924
    assert again.confirmation_first_seed == cas.FRESH_FIRST_SEED and again.executor == "ray"
    assert again.sizes == [where["size"]] and again.episode_seeds == "world"
    cas.check_seed_sets(cas.seed_sets(again))
    # every table copies its discovery rows (generated files match by name and content)
    assert again.reuse == Path(out) / table / "episodes.csv"
    if table == "houses":
        assert again.tasks == ["make_tea"]
    elif table == "related":
        assert again.table == "related" and again.related == [3]
        assert again.derive_worlds == 500
    else:
        assert again.half_pixels == [100.0] and again.strengths == [0.75]


def test_a_report_regenerated_without_episodes_keeps_the_wall_time_of_the_run(tmp_path):
    cas = _script()
    report = tmp_path / "houses.md"
    assert cas.wall_time_line(report, 3.0, 0) == "Wall time: 3 s for 0 new episodes."
    report.write_text("# x\n\nWall time: 920 s for 800 new episodes (1.15 s per episode on this machine).\n")
    line = cas.wall_time_line(report, 1.0, 0)
    assert line.startswith("Wall time: 920 s for 800") and line.endswith(": 0 new episodes.")
    report.write_text(f"# x\n\n{line}\n")      # regenerated twice: said once
    assert cas.wall_time_line(report, 1.0, 0) == line
    assert cas.wall_time_line(report, 10.0, 4) == ("Wall time: 10 s for 4 new episodes (2.50 s per "
                                                   "episode on this machine).")


@pytest.mark.parametrize("bad,word", [
    (["--half-pixels", "0", "--table", "detectability"], "--half-pixels"),
    (["--small-categories", "spoon", "--table", "detectability"], "--small-categories"),
    (["--planners", "lookahaed"], "did you mean 'lookahead'"),
    (["--planners", "lookahead:nodes=-3"], "--planners"),
    (["--confirmation-first-seed", "100", "--worlds", "200"], "overlap"),
    (["--table", "related", "--related", "5"], "--related"),
    (["--table", "related", "--related", "-1"], "--related"),
    (["--table", "related", "--derive-worlds", "0"], "--derive-worlds"),
    (["--table", "related", "--looks", "close"], "--looks")])
def test_more_flags_are_refused_at_parse_time(bad, word, tmp_path, capsys):
    """Refused while parsing, before seed_sets.json is declared or a --reuse row copied (a
    misspelt planner used to be caught only by the sweep, after both): one line, exit 2."""
    from fg_tea.common.errors import InputError

    cas = _script()
    try:
        cas.seed_sets(cas.parse_args([*bad, "--out", str(tmp_path / "out")]))
    except SystemExit as stop:
        err = capsys.readouterr().err.strip().splitlines()
        assert stop.code == 2 and len(err) == 1 and word in err[0], err
    except InputError as exc:  # run_script's one line and exit 2 (tested above for others)
        assert word in str(exc) and "\n" not in str(exc)
    else:
        pytest.fail(f"{bad} was accepted")


def test_a_plugin_planner_passes_the_parse_time_check(tmp_path, monkeypatch):
    """The parse-time check is the sweep's own: a planner in a module of the user's is accepted."""
    from test_planner_plugins import _write_module

    _write_module(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    args = _script().parse_args(["--planners", "mymod:MyPlanner", "--out", str(tmp_path / "out")])
    assert args.planners == ["mymod:MyPlanner"]


def test_resolve_commands_keep_the_table_environment(monkeypatch):
    from fg_tea.study.replication import NOT_RESOLVED, SeedSet

    monkeypatch.chdir(ROOT)
    cas = _script()
    args = cas.parse_args(["--table", "houses", "--env", "fake", "--gtsam-check", "--out",
                           "experiments/results/joint_vs_factorised"])
    sets = [SeedSet("discovery", 0, 20), SeedSet("confirmation", 10000, 20)]
    cell = {"size": "small", "task": "make_tea", "planner": "mi_efe", "verdict": NOT_RESOLVED,
            "pairs_needed": 300, "confirmation": {"pairs": 20}}
    line = [x for x in cas.resolve_commands(args, [cell], sets) if x.startswith("    ")][0]
    again = cas.parse_args(__import__("shlex").split(line)[2:])
    assert again.env == "fake" and again.gtsam_check


@pytest.mark.slow  # two whole sweeps: the full suite (CI) runs it
def test_related_table_relates_exactly_the_first_n_objects_and_pairs_each_cell(tmp_path):
    """The number-of-related-objects axis: world n places exactly the first n of teabag, sugar,
    milk and mug by the kettle; its joint model relates exactly those to the kettle, with weights
    derived from the rule (eq. 55); every cell pairs the same worlds under both beliefs."""
    table = tmp_path / "related"
    command = ("experiments/compare_at_scale.py", "--table", "related", "--worlds", "2", "--sizes",
               "small", "--derive-worlds", "60", "--planners", "nearest", "--env", "fake",
               "--executor", "serial", "--timing-worlds", "0", "--out", str(tmp_path))
    _run(*command, "--related", "0", "3")
    from fg_tea.model.spec import load_model
    from fg_tea.world.distributions import load_world

    for n, related in ((0, set()), (3, {"teabag", "sugar", "milk"})):
        world = load_world(table / "worlds" / f"generated_small_milk_sugar_related_{n}.json")
        assert {r.object for r in world.co_location} == related
        assert all(r.anchor == "kettle" and (r.same_site, r.same_room) == (0.5, 0.25)
                   for r in world.co_location)
        model = load_model(table / "models" / f"joint_related_{n}_small.toml")
        pairs = {r.categories for r in model.relations if r.kind == "co_location"}
        assert pairs == {(o, "kettle") for o in related} and model.structure == "joint"
        assert all(r.same_site > 1 for r in model.relations if r.kind == "co_location")
    rows = read_rows(table / "episodes.csv")
    assert len(rows) == 2 * 2 * 2 and {r["task"] for r in rows} == {"make_tea_milk_sugar"}
    with (table / "related_paired.csv").open(newline="") as fh:
        cells = {(r["size"], r["related"]): r["pairs"] for r in csv.DictReader(fh)}
    assert cells == {("small", "0"): "2", ("small", "3"): "2"}
    assert (table / "related_heatmap.png").stat().st_size > 0
    # the files are written once: a second command derives nothing again and runs nothing
    stamp = (table / "models" / "joint_related_3_small.toml").stat().st_mtime_ns
    _run(*command, "--related", "3")
    assert (table / "models" / "joint_related_3_small.toml").stat().st_mtime_ns == stamp
    assert " 0 new episodes" in (table / "related.md").read_text()
    # another number of derivation worlds in the same folder would pair rows of two models
    proc = subprocess.run([sys.executable, *command[:8], "600", *command[9:], "--related", "3"],
                          capture_output=True, text=True, stdin=subprocess.DEVNULL, cwd=ROOT)
    assert proc.returncode == 2 and "derived from 60 worlds, not 600" in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert (table / "models" / "joint_related_3_small.toml").stat().st_mtime_ns == stamp


@pytest.mark.slow  # whole sweeps or derivations: the full suite (CI) runs it
def test_related_models_are_derived_again_only_when_their_source_changes(tmp_path):
    """The model's second line names its source exactly; "60 worlds" is not "160 worlds"."""
    cas = _script()
    world, model = cas.related_files(tmp_path, "small", 1, 160)
    path = Path(model)
    first = path.read_text()
    assert "160 worlds from seed 1000000" in first.splitlines()[1]
    stamp = path.stat().st_mtime_ns
    assert cas.related_files(tmp_path, "small", 1, 160) == (world, model)
    assert path.stat().st_mtime_ns == stamp                      # same source: left alone
    cas.related_files(tmp_path, "small", 1, 60)
    again = path.read_text()
    assert "60 worlds from seed" in again.splitlines()[1] and again != first
    assert not again.endswith("\n\n") and again.endswith("\n")
    with pytest.raises(InputError, match="--derive-worlds: 3: .*draw more worlds"):
        cas.related_files(tmp_path / "few", "small", 4, 3)
    assert not (tmp_path / "few").exists()                        # refused before writing


def test_related_world_refuses_what_it_cannot_build():
    import json

    from fg_tea.common.resources import resolve_world
    from fg_tea.study.relations import related_world

    base = json.loads(resolve_world("generated_small_milk_sugar").read_text())
    four = related_world(base, 4, "x")
    assert four["placement"]["order"][:5] == ["kettle", "teabag", "sugar", "milk", "mug"]
    assert base["placement"]["co_location"] != four["placement"]["co_location"]  # base untouched
    for bad, count in ((base, 5), (json.loads(resolve_world("generated_small").read_text()), 1)):
        with pytest.raises(ValueError, match="related objects"):
            related_world(bad, count, "x")
