"""``compare_at_scale.py --reuse`` across output folders (fg_tea.study.reuse).

The detectability and related tables name their generated model, camera and world files in each
row's key by a path under ``--out``; a row must still stand for the same job run into another
folder when those files have the same name and bytes, never when their content differs, and
every row not copied is counted under its reason on stderr.
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import pytest

from experiment_scripts import load_experiment
from fg_tea.common.errors import InputError
from fg_tea.study import reuse
from fg_tea.study.seeds import check_episode_seeds

ROOT = Path(__file__).resolve().parent.parent
#: The smallest detectability table: 1 world x 2 models x 1 n_50 x 1 strength, fake house.
TINY = ["--table", "detectability", "--worlds", "1", "--sizes", "small", "--half-pixels", "25",
        "--strengths", "1", "--planners", "nearest", "--env", "fake", "--executor", "serial",
        "--timing-worlds", "0"]


@pytest.fixture(scope="module")
def cas():
    return load_experiment("compare_at_scale")


def _jobs(cas, argv: list[str]) -> list:
    """The jobs a command plans (its files written under its --out), every seed set; none run."""
    args = cas.parse_args(argv)
    out = Path(args.out) / args.table
    return [j for s in (cas.seed_sets(args) or [None])
            for j in cas.plan(args if s is None else argparse.Namespace(
                **{**vars(args), "first_seed": s.first, "worlds": s.count}), out)[0]]


def test_a_table_run_into_another_out_reuses_every_row_and_runs_none(cas, tmp_path, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    assert cas.main(TINY + ["--out", str(a)]) == 0
    capsys.readouterr()
    assert cas.main(TINY + ["--out", str(b), "--reuse", str(a / "detectability" / "episodes.csv")]) == 0
    err = capsys.readouterr().err
    assert "reused 2 rows" in err and "2 of its 2 rows are jobs of this run" in err, err
    assert "run now" not in err and "not copied" not in err, err
    assert "for 0 new episodes" in (b / "detectability" / "detectability.md").read_text()
    # the copied rows are the rows the new folder's jobs would write: only their paths differ
    whole = (a / "detectability" / "episodes.csv").read_text().replace(str(a), str(b))
    assert (b / "detectability" / "episodes.csv").read_text() == whole
    assert str(a) not in whole


def test_a_row_whose_model_content_differs_is_run_again_and_the_reason_printed(cas, tmp_path, capsys):
    a, c = tmp_path / "a", tmp_path / "c"
    assert cas.main(TINY + ["--out", str(a)]) == 0
    joint = a / "detectability" / "models" / "joint_n50_25.toml"
    joint.write_text(joint.read_text() + "\n# edited after the run\n")
    capsys.readouterr()
    assert cas.main(TINY + ["--out", str(c), "--reuse", str(a / "detectability" / "episodes.csv")]) == 0
    err = capsys.readouterr().err
    assert "reused 1 rows" in err, err
    line = next(x for x in err.splitlines() if "not copied" in x)
    assert line.startswith("reuse: 1 of 2 rows of ") and "model files' content differs" in line, err
    assert str(joint) in line and str(c / "detectability" / "models" / "joint_n50_25.toml") in line
    assert "reuse: 1 of this run's 2 jobs are in neither" in err and "they run now" in err
    assert "for 1 new episodes" in (c / "detectability" / "detectability.md").read_text()


def test_a_moved_table_folder_is_matched_beside_its_csv_and_missing_files_are_named(cas, tmp_path, capsys):
    a = tmp_path / "a"
    assert cas.main(TINY + ["--out", str(a)]) == 0
    moved = tmp_path / "moved"
    shutil.move(a / "detectability", moved)          # the keys' paths are gone
    jobs = _jobs(cas, TINY + ["--out", str(tmp_path / "new")])
    found = reuse.match(moved / "episodes.csv", jobs)
    assert set(found.rows) == {j.key for j in jobs} and not found.reasons
    shutil.rmtree(moved / "cameras")                 # nothing left to check the camera against
    found = reuse.match(moved / "episodes.csv", jobs)
    assert not found.rows
    (line,) = reuse.reason_lines(found)
    assert "2 of 2 rows" in line and "camera files are found neither" in line
    assert str(a / "detectability" / "cameras" / "visibility_n50_25.toml") in line


def test_a_file_beside_the_csv_that_differs_from_the_one_its_key_names_matches_nothing(cas, tmp_path):
    a = tmp_path / "a"
    assert cas.main(TINY + ["--out", str(a)]) == 0
    copy = tmp_path / "copy"
    shutil.copytree(a / "detectability", copy)
    model = copy / "models" / "factorised_n50_25.toml"
    model.write_text(model.read_text() + "# changed\n")
    found = reuse.match(copy / "episodes.csv", _jobs(cas, TINY + ["--out", str(tmp_path / "new")]))
    assert len(found.rows) == 1
    assert [(kind, part, n) for (kind, part), (n, _, _) in found.reasons.items()] == [("ambiguous", "model", 1)]


def _committed_rows(path: Path) -> dict[str, dict]:
    import csv

    with path.open(newline="", encoding="utf-8") as fh:
        return {r["key"]: r for r in csv.DictReader(fh)}


@pytest.mark.slow
def test_the_committed_detectability_table_is_reusable_for_its_own_jobs(cas, tmp_path, monkeypatch, capsys):
    """Its recorded command, planned into another --out (files written, nothing run): every
    committed row stands for one of the jobs, and is the committed row but for key and model_ref."""
    monkeypatch.chdir(ROOT)
    table = ROOT / "experiments/results/joint_vs_factorised/detectability"
    command = (table / "commands.txt").read_text().split()
    argv = command[command.index("--table"):command.index("--out")] + ["--out", str(tmp_path)]
    jobs = _jobs(cas, argv)
    found = reuse.match(table / "episodes.csv", jobs)
    assert found.total == len(jobs) == len(found.rows) == 7200 and not found.reasons
    committed = _committed_rows(table / "episodes.csv")
    for job in jobs[::997]:
        row = found.rows[job.key]
        old = committed[row["key"].replace(str(tmp_path), "experiments/results/joint_vs_factorised")]
        assert {k: v for k, v in row.items() if k not in ("key", "model_ref")} == \
            {k: v for k, v in old.items() if k not in ("key", "model_ref")}
        assert row["model_ref"] == job.model and row["key"] == job.key
    # docs/results.md's recipe: one cell on a fresh confirmation set copies its discovery rows
    recipe = _jobs(cas, ["--table", "detectability", "--worlds", "200", "--confirmation-first-seed",
                         "30000", "--sizes", "small", "--half-pixels", "100", "--strengths", "1",
                         "--planners", "factorised_efe", "--episode-seeds", "world",
                         "--out", str(tmp_path / "recipe")])
    found = reuse.match(table / "episodes.csv", recipe)
    assert len(found.rows) == 400
    reuse.copy_rows(found, recipe, tmp_path / "recipe" / "episodes.csv", resume=True)
    err = capsys.readouterr().err
    assert "reused 400 rows" in err and "3600 of 7200 rows" in err and "world seed not this run's" in err
    assert "reuse: 400 of this run's 800 jobs are in neither" in err
    # the same jobs under the other episode-seed scheme: refused, as a table's own CSV refuses them
    other = _jobs(cas, argv[:-2] + ["--episode-seeds", "independent", "--out", str(tmp_path)])
    found = reuse.match(table / "episodes.csv", other)
    assert not found.rows
    with pytest.raises(InputError, match="other --episode-seeds scheme"):
        check_episode_seeds(other, found.keys, table / "episodes.csv")


def test_the_committed_related_table_is_reusable_for_its_own_jobs(cas, tmp_path, monkeypatch):
    """The related table's world files are written again and its derived models kept (their
    source line, which names the world file's digest and the derivation, matches, so they are
    not derived again: that takes minutes); every planned job finds its committed row."""
    monkeypatch.chdir(ROOT)
    table = ROOT / "experiments/results/joint_vs_factorised_related_world_seeds/related"
    out = tmp_path / "related"
    out.mkdir()
    for name in ("joint_related_2_small.toml",):
        (out / "models").mkdir(exist_ok=True)
        shutil.copy(table / "models" / name, out / "models" / name)
    jobs = _jobs(cas, ["--table", "related", "--related", "2", "--worlds", "200",
                       "--confirmation-first-seed", "10000", "--sizes", "small", "--planners",
                       "factorised_efe", "--episode-seeds", "world", "--out", str(tmp_path)])
    assert (out / "models" / "joint_related_2_small.toml").read_bytes() == \
        (table / "models" / "joint_related_2_small.toml").read_bytes()
    found = reuse.match(table / "episodes.csv", jobs)
    assert len(jobs) == len(found.rows) == 800
    assert {kind for kind, _ in found.reasons} == {"differ"}      # the medium houses' rows
    assert found.reasons[("differ", "world")][0] == 800
