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


def test_no_measured_number_is_typed_by_hand(tmp_path, monkeypatch):
    """Every hand-written decimal, percentage or time is declared not measured
    (docs/tools/given_numbers.txt); a new one fails until it is marked or declared."""
    numbers = _numbers()
    assert numbers.unexplained() == [], "render it with a marker or declare it in given_numbers.txt"
    doc = ("Travel fell by 12.5 m (`0.37` in code), 40 % fewer looks in 3 ms; see §6.2.\n"
           "<!-- n r.csv - x .2f -->1.23<!-- /n --> and ![a b](x_0.9.png)\n## 4.4 Heading\n")
    assert numbers.typed(doc) == ["12.5", "40 %", "3 ms"]
    (tmp_path / "a.md").write_text(doc)
    (tmp_path / "given.txt").write_text("a.md: 12.5 40%  # settings\n")
    monkeypatch.setattr(numbers, "ROOT", tmp_path)
    monkeypatch.setattr(numbers, "GIVEN", tmp_path / "given.txt")
    monkeypatch.setattr(numbers, "documents", lambda: [tmp_path / "a.md"])
    assert numbers.unexplained() == ["a.md: 3ms"]


def test_a_block_keeps_chosen_rows_and_columns_and_a_marker_reads_a_markdown_cell(tmp_path, monkeypatch):
    numbers = _numbers()
    (tmp_path / "r.md").write_text("# R\n\n## house `a`\n\n| p | x |\n|---|---|\n| e | 1 |\n\n"
                                   "## house `b`\n\n### model `f`\n\n| p | x | y |\n|---|---|---|\n"
                                   "| e | 1,401.5 [−2.0, 3] | 9 |\n| l | 2 | 8 |\n| m | 3 | 7 |\n")
    monkeypatch.setattr(numbers, "ROOT", tmp_path)
    numbers._rows.cache_clear()
    kept = numbers.table('r.md "## house `b`" "### model" "p=e|m" "columns=y|p"')
    assert kept == "| y | p |\n|---|---|\n| 9 | e |\n| 7 | m |\n"
    assert numbers.number('"r.md#house `b`#model `f`" p=e x@0 .1f') == "1401.5"
    assert numbers.number('"r.md#house `b`#model `f`" p=e x@1 .2f') == "-2.00"
    assert numbers.number('"r.md#house `a`" p=e x .0f') == "1"
    for bad in ('r.md "## house `b`" "p=z"', 'r.md "## house `b`" "columns=q"', 'r.md "## nothing"'):
        with pytest.raises(numbers.MarkerError):
            numbers.table(bad)
    with pytest.raises(numbers.MarkerError):
        numbers.number('"r.md#house `b`" p=e x@3 .1f')


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


ERRORS = re.compile(r"<!-- errors (?P<folder>\S+) -->\n```text\n(?P<text>.*?)```\n<!-- /errors -->", re.S)


def test_quoted_error_lines_are_what_the_commands_print(tmp_path, monkeypatch, capsys):
    """Each ``<!-- errors FOLDER -->`` block quotes commands (``$ fg-tea ...``), run here in a copy of
    FOLDER, each followed by the one line it prints on standard error; each exits with status 2."""
    import shutil

    from fg_tea.cli.main import main

    blocks = [b for doc in ROOT.joinpath("docs").rglob("*.md") for b in ERRORS.finditer(doc.read_text())]
    assert blocks, "the docs quote no error example"
    for block in blocks:
        work = tmp_path / block.group("folder").replace("/", "_")
        shutil.copytree(ROOT / block.group("folder"), work)
        monkeypatch.chdir(work)
        lines = block.group("text").splitlines()
        for command, expected in zip(lines[::2], lines[1::2]):
            assert command.startswith("$ fg-tea "), command
            try:
                status = main(shlex.split(command[2:])[1:])
            except SystemExit as exc:
                status = exc.code
            printed = capsys.readouterr()
            assert status == 2, (command, printed)
            assert printed.err.splitlines() == [expected], (command, printed.err)
