"""What a newcomer tripped on: the Gymnasium id after ``import fg_tea``, where ``fg-tea preview``
writes, one name per concept (solver), a misspelt required key, the summary's counts."""

from __future__ import annotations

import inspect
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import fg_tea as fg
from fg_tea.cli.main import main


def _python(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("order", ["fg_tea first", "gymnasium first"])
def test_gymnasium_make_takes_the_plain_id_after_import_fg_tea(order):
    pytest.importorskip("gymnasium")
    imports = "import fg_tea\nimport gymnasium\n" if order == "fg_tea first" else \
        "import gymnasium\nimport fg_tea\n"
    out = _python(imports + "env = gymnasium.make('fg_tea/TeaMaking-v0', scenario='milk_sugar_apartment')\n"
                  "obs, info = env.reset(seed=1)\nprint(type(env.unwrapped).__name__, info['seed'])\n")
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["TeaEnv", "1"]


def test_import_fg_tea_still_loads_neither_numpy_nor_gymnasium():
    out = _python("import sys, fg_tea\nprint(sorted(m for m in ('numpy', 'gymnasium') if m in sys.modules))")
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_preview_writes_under_runs_by_default(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["preview", "--width", "160", "--height", "90"]) == 0
    written = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*.png"))
    assert written == ["runs/default_apartment-preview.png", "runs/default_apartment-preview_plan.png"]
    assert "runs/default_apartment-preview.png" in capsys.readouterr().out


def test_run_config_calls_it_solver_and_the_old_name_still_works_with_a_warning():
    assert fg.RunConfig(solver="gtsam").solver == "gtsam"
    assert "solver" in inspect.signature(fg.RunConfig).parameters
    with pytest.warns(DeprecationWarning, match="solver"):
        old = fg.RunConfig(seed=2, belief_backend="gtsam")
    assert old == fg.RunConfig(seed=2, solver="gtsam")
    with pytest.warns(DeprecationWarning, match="solver"):
        assert old.belief_backend == "gtsam"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fg.RunConfig(seed=2, solver="numpy")  # the new name warns about nothing


def test_the_beliefs_command_prints_the_word_of_its_flag(capsys):
    assert main(["beliefs", "--solver", "numpy"]) == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert "solver numpy" in header and "backend" not in header


def test_fg_compare_defaults_to_the_environment_of_fg_tea_compare():
    from fg_tea.cli.main import build_parser

    cli = build_parser().parse_args(["compare"])
    assert inspect.signature(fg.compare).parameters["env"].default == cli.env == "pybullet"


def _model_with(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "typo.toml"
    path.write_text(text)
    return path


def test_a_misspelt_required_key_names_the_typo_without_extends(tmp_path, capsys):
    from fg_tea.common.resources import resolve_model

    bundled = Path(resolve_model("factorised")).read_text()
    assert 'structure = "factorised"' in bundled
    path = _model_with(tmp_path, bundled.replace('structure = "factorised"', 'strcture = "factorised"', 1))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("$.beliefs.strcture: unknown field; did you mean 'structure'?"), err


def test_a_misspelt_required_key_names_the_typo_with_extends(tmp_path, capsys):
    path = _model_with(tmp_path, 'extends = "factorised"\nname = "x"\n[beliefs]\nstrcture = "joint"\n')
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("$.beliefs.strcture: unknown field; did you mean 'structure'?"), err


def test_the_summary_says_simulation_frames_and_counts_in_the_singular(tmp_path, capsys):
    from fg_tea.cli.common import summary
    from fg_tea.episode.run import run_episode

    s, m = fg.load_scenario("default_apartment"), fg.load_model("factorised")
    text = summary(run_episode(s, m, env="fake", seed=0).events)
    assert "1 state reading," in text and "1 state readings" not in text
    assert text.endswith(" simulation frames.") and " 1 inspections" not in text


def test_the_video_line_says_why_it_has_more_frames(tmp_path, capsys):
    from fg_tea.episode.run import run_episode

    s, m = fg.load_scenario("default_apartment"), fg.load_model("factorised")
    run_episode(s, m, env="fake", seed=0, log=tmp_path / "episode.jsonl")
    assert main(["render", str(tmp_path / "episode.jsonl"), "--width", "64", "--height", "64",
                 "--frame-stride", "100"]) == 0
    line = capsys.readouterr().out.splitlines()[-1]
    assert line.startswith("video: ") and " video frames: the episode's motion, with each decision" in line
    assert "held a moment for reading" in line


def _run_folder(tmp_path, monkeypatch, model: str) -> str:
    from fg_tea.cli.run import default_run_folder

    monkeypatch.chdir(tmp_path)
    return default_run_folder(fg.load_scenario("default_apartment"), fg.load_model(model), 0).as_posix()


def test_a_copied_model_keeping_a_bundled_name_gets_its_own_run_folder(tmp_path, monkeypatch):
    from fg_tea.common.resources import resolve_model

    text = Path(resolve_model("factorised")).read_text()
    (tmp_path / "my_model.toml").write_text(text)
    (tmp_path / "same").mkdir()
    (tmp_path / "same" / "factorised.toml").write_text(text)
    assert _run_folder(tmp_path, monkeypatch, "factorised") == "runs/default_apartment-factorised-seed0"
    assert _run_folder(tmp_path, monkeypatch, "no_epistemic") == "runs/default_apartment-no_epistemic-seed0"
    assert _run_folder(tmp_path, monkeypatch, "my_model.toml") == \
        "runs/default_apartment-factorised-my_model-seed0"
    assert _run_folder(tmp_path, monkeypatch, "same/factorised.toml") == \
        "runs/default_apartment-factorised-local-seed0"


def test_the_readme_common_errors_link_goes_to_the_errors(tmp_path):
    import re

    root = Path(__file__).parents[1]
    readme = (root / "README.md").read_text()
    links = re.findall(r"\[common errors\]\(([^)#]+)(#[^)]*)?\)", readme)
    assert links, "the README links no 'common errors'"
    for page, anchor in links:
        text = (root / page).read_text()
        assert "<!-- errors " in text and "fg-tea: error:" in text
        if anchor:
            assert f"## {anchor[1:].replace('-', ' ').capitalize()}" in text


def test_the_commands_table_names_camera():
    text = (Path(__file__).parents[1] / "docs" / "guide" / "commands.md").read_text()
    table = [line for line in text.splitlines() if line.startswith("| `fg-tea run ") or
             line.startswith("| `fg-tea preview ")]
    assert len(table) == 2 and all("--camera CAMERA" in line for line in table)


def test_the_video_says_when_a_search_serves_several_objects():
    from fg_tea.episode.run import run_episode
    from fg_tea.render.video import VideoOptions, plan_frames

    s, m = fg.load_scenario("default_apartment"), fg.load_model("factorised")
    events = run_episode(s, m, env="fake", seed=0).events
    decisions = [e for e in events if e["event"] == "decision"]
    several = next(e for e in decisions if len(e["objects"]) > 1)
    captions = [o.caption for o in plan_frames(events, VideoOptions()).overlays if o.phase == "SEARCH"]
    assert f"serves {', '.join(several['objects'])}; plan: look for the {several['object']}" in " | ".join(captions)


def test_a_look_update_has_a_site_labelled_form():
    s, m = fg.load_scenario("default_apartment"), fg.load_model("factorised")
    from fg_tea.beliefs.engine import BeliefEngine

    update = BeliefEngine(s, m).observe_site("sideboard", {"mug": True, "kettle": False})
    labelled = update.after_by_site()
    assert list(labelled["mug"]) == list(s.site_names)
    assert labelled["mug"]["sideboard"] == pytest.approx(float(update.after["mug"][s.site_names.index("sideboard")]))
    assert labelled["mug"]["sideboard"] > 0.9
    assert update.before_by_site()["kettle"]["kitchen_counter"] == pytest.approx(
        float(update.before["kettle"][s.site_names.index("kitchen_counter")]))


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_the_api_reference_documents_the_objects_it_hands_back(tmp_path):
    import importlib.util

    if importlib.util.find_spec("mkdocs") is None:
        pytest.skip("mkdocs is not installed: pip install -e '.[docs]'")
    root = Path(__file__).parents[1]
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                          cwd=root, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    page = (tmp_path / "site" / "reference" / "api" / "index.html").read_text(encoding="utf-8")
    for name in ["beliefs.engine.BeliefEngine", "beliefs.engine.BeliefEngine.location_map",
                 "beliefs.engine.BeliefEngine.entropy", "beliefs.engine.BeliefEngine.joint",
                 "world.scenario.Scenario", "model.spec.Model", "world.distributions.WorldDistribution",
                 "beliefs.updates.LookUpdate", "beliefs.updates.LookUpdate.after_by_site",
                 "beliefs.updates.StateUpdate"]:
        assert f'id="fg_tea.{name}"' in page, name
    # the package's docstring: its groups of names are lists, not one run-on paragraph
    assert "<li><code>load_scenario</code>" in page and "<li><code>Agent</code>" in page
