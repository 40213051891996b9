"""Numbers that cannot drift: every measured number the README and the docs quote between
``<!-- n ... -->`` / ``<!-- table ... -->`` markers equals its committed result file
(docs/tools/render_numbers.py), and a changed result file without its quoted number fails here."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from docs_tools import load_tool

ROOT = Path(__file__).resolve().parent.parent


def _numbers():
    return load_tool("render_numbers")


def test_every_quoted_number_matches_its_result_file():
    numbers = _numbers()
    assert numbers.stale() == [], "run: python docs/tools/render_numbers.py"


def test_a_changed_result_is_caught_and_a_bad_marker_is_an_error(tmp_path, monkeypatch):
    numbers = _numbers()
    (tmp_path / "r.csv").write_text("model,planner,x\njoint,efe,1.234\nfactorised,efe,2.5\n")
    (tmp_path / "r.md").write_text("# R\n\n## T\n\n| a | b |\n|---|---|\n| 1 | 2 |\n\nafter\n")
    monkeypatch.setattr(numbers, "ROOT", tmp_path)
    numbers._rows.cache_clear()
    doc = ("x is <!-- n r.csv model=joint,planner=efe x .2f -->1.23<!-- /n --> m.\n"
           "<!-- table r.md \"## T\" -->\n| a | b |\n|---|---|\n| 1 | 2 |\n<!-- /table -->\n")
    assert numbers.render(doc) == doc
    assert "-->9.99<" not in numbers.render(doc.replace("-->1.23<", "-->9.99<"))
    assert numbers.render(doc.replace("-->1.23<", "-->9.99<")) == doc
    assert numbers.render(doc.replace("| 1 | 2 |\n<!--", "| 1 | 3 |\n<!--")) == doc
    (tmp_path / "fig.png").write_bytes(b"png one")
    (tmp_path / "docs").mkdir()
    (tmp_path / "README.md").write_text("<!-- figure fig.png docs/f.png -->\n")
    monkeypatch.setattr(numbers, "documents", lambda: [tmp_path / "README.md"])
    assert numbers.stale() and numbers.main([]) == 0 and numbers.stale() == []
    (tmp_path / "fig.png").write_bytes(b"png two")  # the experiment drew it anew
    assert "docs/f.png is not fig.png" in numbers.stale()[0]
    for bad in ("r.csv model=nobody x .2f", "r.csv model=joint y .2f", "nofile.csv - x .2f",
                "r.csv planner=efe x .2f"):
        with pytest.raises(numbers.MarkerError):
            numbers.render(f"<!-- n {bad} -->1<!-- /n -->")


def test_the_readme_is_short_and_quotes_results_through_markers():
    numbers = _numbers()
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 300
    assert len(numbers.INLINE.findall(readme)) >= 5


OUTPUT = re.compile(r"<!-- output (?P<command>[^>]*?) -->\n```text\n(?P<text>.*?)```\n<!-- /output -->", re.S)


@pytest.mark.parametrize("doc", ["README.md"])
def test_quoted_command_output_is_what_the_command_prints(doc, tmp_path, capsys):
    """Each ``<!-- output COMMAND -->`` block quotes lines COMMAND prints (run here, --out aside)."""
    from fg_tea.cli.main import main

    blocks = list(OUTPUT.finditer((ROOT / doc).read_text()))
    assert blocks, f"{doc} quotes no command output"
    for i, block in enumerate(blocks):
        argv = shlex.split(block.group("command"))
        assert argv[0] == "fg-tea"
        main([*argv[1:], "--out", str(tmp_path / f"out{i}")])
        printed = capsys.readouterr().out.splitlines()
        for line in block.group("text").splitlines():
            assert line in printed, (block.group("command"), line, printed)
