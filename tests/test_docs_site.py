"""The documentation site builds in strict mode, with every page, the API and every command.

``mkdocs build --strict`` fails on a broken link, a missing anchor, a page left out of the nav or
a docstring mkdocstrings cannot read (``mkdocs.yml``: ``strict: true`` and ``validation:``). The
build runs in a subprocess into a temporary folder, never into the source tree. It is skipped only
when mkdocs is not installed (it is in the ``test`` and ``docs`` extras).
"""

from __future__ import annotations

import html
import importlib.util
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _nav_pages(nav) -> list[str]:
    """Every markdown file the nav of mkdocs.yml lists, in order."""
    pages: list[str] = []
    for item in nav:
        value = next(iter(item.values())) if isinstance(item, dict) else item
        if isinstance(value, list):
            pages += _nav_pages(value)
        else:
            pages.append(value)
    return pages


def _config() -> dict:
    yaml = pytest.importorskip("yaml", reason="PyYAML comes with mkdocs: pip install -e '.[docs]'")

    class Loader(yaml.SafeLoader):
        pass

    # mkdocs.yml may use mkdocs' own tags (!ENV, !relative); read them as plain values.
    Loader.add_multi_constructor("!", lambda loader, suffix, node: None)
    return yaml.load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"), Loader=Loader)


def _text(path: Path) -> str:
    return html.unescape(re.sub(r"<[^>]+>", " ", path.read_text(encoding="utf-8")))


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    if importlib.util.find_spec("mkdocs") is None:
        pytest.skip("mkdocs is not installed: pip install -e '.[docs]' (it is in the test extra)")
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    # The hooks import fg_tea: build against this checkout, whichever copy is installed.
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    began = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    print(f"mkdocs build --strict: {time.perf_counter() - began:.1f} s")
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stdout}\n{proc.stderr}"
    return out


def test_config_is_strict_and_builds_outside_the_source_tree():
    config = _config()
    assert config["strict"] is True and config["docs_dir"] == "docs"
    assert Path(config["site_dir"]).parts[0] == "runs"            # output, ignored by git
    assert "runs/" in (ROOT / ".gitignore").read_text().split()
    for key in ("not_found", "anchors"):
        assert config["validation"]["links"][key] == "warn"      # strict turns warnings into failures
    hooks = config["hooks"]
    assert "docs/hooks/cli_reference.py" in hooks and all((ROOT / h).is_file() for h in hooks)


def test_every_page_in_the_nav_is_built(site):
    pages = _nav_pages(_config()["nav"])
    for page in pages:
        assert (ROOT / "docs" / page).is_file(), page
        built = site / ("index.html" if page == "index.md" else page.removesuffix(".md") + "/index.html")
        assert built.is_file(), f"{page} was not built"
    # Every page is reachable from the landing page.
    landing = (ROOT / "docs" / "index.md").read_text(encoding="utf-8")
    for page in pages[1:]:
        assert f"]({page})" in landing or f"]({page}#" in landing, f"index.md does not link {page}"


def test_api_page_documents_the_public_api(site):
    import fg_tea

    source = (ROOT / "docs" / "reference" / "api.md").read_text(encoding="utf-8")
    # the members of the first block, ::: fg_tea (the blocks after it document what it returns)
    listed = re.findall(r"^\s+- (\w+)$", source.split("members:", 1)[1].split("\n\n", 1)[0], re.M)
    assert listed == [n for n in fg_tea.__all__ if n != "__version__"], \
        "docs/reference/api.md's members must be fg_tea.__all__ (without __version__), in order"
    built = (site / "reference" / "api" / "index.html").read_text(encoding="utf-8")
    for name in listed:
        assert f'id="fg_tea.{name}"' in built, f"the API page does not document {name}"
    text = _text(site / "reference" / "api" / "index.html")
    assert "Agent" in text and "load_scenario" in text


def test_cli_page_lists_every_command_with_its_help(site):
    from fg_tea.cli import build_parser
    from fg_tea.cli.common import COMMANDS

    build_parser()
    names = set(COMMANDS)
    assert {"run", "render", "preview", "compare", "beliefs", "validate", "learn", "house", "list"} <= names
    built = site / "reference" / "cli" / "index.html"
    text = _text(built)
    assert "<!-- fg-tea commands -->" not in built.read_text(encoding="utf-8")
    for name in names:
        assert f"fg-tea {name}" in text and f"usage: fg-tea {name}" in text, name
    # The hook fills the page in memory: the committed page still holds only the placeholder.
    assert "usage: fg-tea" not in (ROOT / "docs" / "reference" / "cli.md").read_text(encoding="utf-8")


def test_log_format_page_shows_design_section_9(site):
    from fg_tea.episode.log import EVENT_KINDS

    text = _text(site / "log-format" / "index.html")
    for kind in EVENT_KINDS:
        assert kind in text, kind


def test_getting_started_python_examples_are_the_readme_ones():
    """A test runs the README's examples as they stand (tests/test_public_api.py); the site's
    copies must be the same code."""
    def blocks(text: str, heading: str) -> list[str]:
        return re.findall(r"```python\n(.*?)```", text[text.index(heading):], re.S)[:2]

    readme = blocks((ROOT / "README.md").read_text(encoding="utf-8"), "## Python API")
    page = blocks((ROOT / "docs" / "getting-started.md").read_text(encoding="utf-8"), "## The Python API")
    assert len(readme) == 2 and page == readme
