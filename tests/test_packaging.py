"""Does fg_tea install and run as a user gets it: from a wheel, in a fresh virtual environment,
from a directory outside the checkout? And does mypy pass on the package?

The slow test builds the sdist and, from it, the wheel (``python -m build``, so the wheel is built
from what the sdist carries), installs the wheel into a fresh ``python -m venv`` and runs
``fg-tea list``, ``fg-tea run --no-video``, ``fg-tea validate`` on every bundled file and
``fg-tea compare --quick --env fake --worlds 2`` from a temporary directory. The venv sees the
test environment's site-packages through a ``.pth`` file (whether the tests run in a venv or in
the system Python), so the dependencies (gtsam, pybullet, ...) come from there instead of a
second download; the package itself is installed into the venv
with ``--ignore-installed --no-deps`` and the test checks that it is the venv's copy that runs.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tarfile
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
BUNDLE = {"scenarios": "fg_tea/_bundle/scenarios", "models": "fg_tea/_bundle/models",
          "cameras": "fg_tea/_bundle/cameras"}


def _repo_data_files() -> list[str]:
    """Every file under scenarios/, models/ and cameras/, relative to the repository root."""
    return sorted(str(p.relative_to(ROOT)) for top in BUNDLE for p in (ROOT / top).rglob("*")
                  if p.is_file() and "__pycache__" not in p.parts)


def test_the_package_list_names_every_code_package_and_data_folder():
    from setuptools import find_packages

    listed = set(PYPROJECT["tool"]["setuptools"]["packages"])
    code = set(find_packages(where=str(ROOT), include=["fg_tea", "fg_tea.*"]))
    assert code <= listed, f"add {sorted(code - listed)} to [tool.setuptools] packages"
    folders = {p.parent for p in map(Path, _repo_data_files())}
    for folder in folders:
        top, *rest = folder.parts
        package = ".".join(["fg_tea._bundle", top, *rest])
        assert package in listed, f"{folder}/ is not shipped: add {package} to the package list"
        assert package in PYPROJECT["tool"]["setuptools"]["package-data"], package


def test_license_and_typing_marker_exist():
    assert "MIT License" in (ROOT / "LICENSE").read_text()
    assert (ROOT / "fg_tea" / "py.typed").is_file()
    manifest = (ROOT / "MANIFEST.in").read_text()
    assert "graft tests" in manifest and "graft scenarios" in manifest


def test_mypy_passes_on_the_package():
    pytest.importorskip("mypy", reason="mypy is in the test extra: pip install -e '.[test]'")
    proc = subprocess.run([sys.executable, "-m", "mypy", "--no-error-summary", "fg_tea"], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]


def _test_site_dirs() -> list[str]:
    """The site-packages folders of the interpreter running the tests: a venv's own, or the system
    Python's (and the user site where it is on), whichever holds the dependencies."""
    import site

    dirs = list(site.getsitepackages())
    if site.ENABLE_USER_SITE and os.path.isdir(site.getusersitepackages()):
        dirs.append(site.getusersitepackages())
    return [d for d in dirs if os.path.isdir(d)]


def _see_the_test_environment(python: Path, cwd: Path, env: dict) -> None:
    """Let a fresh venv import exactly the test environment's dependencies, downloading nothing.

    A ``.pth`` file in the venv lists the test interpreter's site-packages folders. Folders added
    this way are plain ``sys.path`` entries: their own ``.pth`` files are not run, so an editable
    install of fg_tea there (a ``.pth`` import hook) does not leak in, and the venv's own
    site-packages, where the wheel goes, comes first.
    """
    purelib = _run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                   cwd=cwd, env=env).stdout.strip()
    Path(purelib, "fg_tea_test_environment.pth").write_text("\n".join(_test_site_dirs()) + "\n")


def _run(argv, cwd: Path, env: dict, timeout: float = 600) -> subprocess.CompletedProcess:
    proc = subprocess.run([str(a) for a in argv], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)
    assert proc.returncode == 0, f"{argv}: status {proc.returncode}\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc


@pytest.mark.slow
def test_a_wheel_installs_into_a_fresh_venv_and_every_command_runs_outside_the_checkout(tmp_path):
    pytest.importorskip("build", reason="build is in the test extra: pip install -e '.[test]'")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    dist = tmp_path / "dist"
    _run([sys.executable, "-m", "build", "--outdir", dist, ROOT], cwd=tmp_path, env=env)
    sdist, = dist.glob("fg_tea-*.tar.gz")
    wheel, = dist.glob("fg_tea-*.whl")

    # The sdist carries what the tests import and read, and the licence.
    with tarfile.open(sdist) as tar:
        names = {n.split("/", 1)[1] for n in tar.getnames() if "/" in n}
    for needed in ["LICENSE", "tests/houses.py", "tests/test_packaging.py", "fg_tea/py.typed",
                   *_repo_data_files()]:
        assert needed in names, f"the sdist lacks {needed}"

    # The wheel carries every bundled file as package data.
    with zipfile.ZipFile(wheel) as whl:
        names = set(whl.namelist())
    for rel in _repo_data_files():
        top, rest = rel.split("/", 1)
        assert f"{BUNDLE[top]}/{rest}" in names, f"the wheel lacks {rel}"
    assert "fg_tea/py.typed" in names
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)

    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", venv], cwd=tmp_path, env=env)
    bindir = venv / ("Scripts" if os.name == "nt" else "bin")
    python, fg_tea = bindir / "python", bindir / "fg-tea"
    _see_the_test_environment(python, cwd=tmp_path, env=env)
    _run([python, "-m", "pip", "install", "--quiet", "--no-deps", "--ignore-installed",
          "--disable-pip-version-check", wheel], cwd=tmp_path, env=env)

    elsewhere = tmp_path / "elsewhere"  # a directory outside the checkout
    elsewhere.mkdir()
    where = _run([python, "-c", "import fg_tea; print(fg_tea.__file__)"], cwd=elsewhere, env=env)
    assert Path(where.stdout.strip()).is_relative_to(venv), where.stdout

    listing = _run([fg_tea, "list"], cwd=elsewhere, env=env).stdout
    for name in ["default_apartment", "factorised", "no_epistemic", "make_tea", "correlated"]:
        assert name in listing
    paths = _run([fg_tea, "list", "--paths"], cwd=elsewhere, env=env).stdout.split()
    assert len(paths) == len(_repo_data_files())
    assert all(Path(p).is_relative_to(venv) for p in paths), paths

    checked = _run([fg_tea, "validate", *paths], cwd=elsewhere, env=env).stdout.splitlines()
    assert len(checked) == len(paths) and all(line.endswith(")") and ": ok (" in line
                                              for line in checked), checked

    run = _run([fg_tea, "run", "--no-video", "--model", "no_epistemic"], cwd=elsewhere, env=env)
    assert "The task is complete" in run.stdout
    assert (elsewhere / "runs" / "default_apartment-no_epistemic-seed0" / "episode.jsonl").is_file()

    compare = _run([fg_tea, "compare", "--quick", "--env", "fake", "--worlds", "2", "--executor",
                    "serial"], cwd=elsewhere, env=env)
    csv = elsewhere / "runs" / "compare-correlated" / "episodes.csv"
    assert csv.is_file(), compare.stdout
    rows = csv.read_text().splitlines()
    assert len(rows) == 1 + 2 * 2 * 4  # header + 2 worlds x 2 models x 4 quick planners
    shutil.rmtree(venv, ignore_errors=True)
