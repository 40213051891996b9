"""Every shell command in the README and the docs runs (docs that stay true).

Each page's ```bash blocks run in order, with ``bash -e``, in a fresh folder of their own: a
block that fails fails the test, naming the page and the block. Files a page asks the reader to
write come from the page itself (a ```python block whose first line is ``# NAME.py``) or, for a
file the page says to copy, from the bundled one it names (``SETUP``). A block preceded by
``<!-- not run: REASON -->`` is not run (installs, and Ray clusters); its ``fg-tea`` commands are
still parsed, so a renamed flag fails here too. Sizes are the ones the docs give (``--quick``,
``--worlds 2``, ``--no-video``).
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
FENCE = re.compile(r"^(?P<indent>[ \t]*)```(?P<lang>\w*)\n(?P<body>.*?)^(?P=indent)```", re.M | re.S)
NOT_RUN = re.compile(r"<!-- not run: [^>]+ -->")
#: Files a page tells the reader to copy from the bundled ones, by page.
SETUP = {"docs/how-to/new-house.md": {"my_house.json": "scenarios/default_apartment.json"},
         "docs/how-to/new-task.md": {"my_task.json": "scenarios/tasks/make_tea.json"}}
PAGES = ["README.md", *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*.md"))]


def blocks(page: str) -> list[tuple[str, str, bool]]:
    """(language, body, runs) of each fenced block of `page`, in order."""
    text = (ROOT / page).read_text(encoding="utf-8")
    out = []
    for m in FENCE.finditer(text):
        body = "\n".join(line[len(m.group("indent")):] for line in m.group("body").splitlines())
        before = "\n".join(text[:m.start()].splitlines()[-2:])
        out.append((m.group("lang"), body, not NOT_RUN.search(before)))
    return out


def fg_tea_commands(script: str) -> list[list[str]]:
    """The ``fg-tea`` commands of a shell block, as argument lists (loops and && chains split)."""
    commands = []
    for line in script.replace("\\\n", " ").splitlines():  # continued lines are one command
        for part in re.split(r"&&|;|\bdo\b|\bdone\b", line.split(" #")[0]):
            words = shlex.split(part, comments=True) if part.strip().startswith("fg-tea") else []
            if words and words[0] == "fg-tea":
                commands.append(words[1:])
    return commands


@pytest.mark.parametrize("page", [p for p in PAGES if any(lang == "bash" for lang, _, _ in blocks(p))])
def test_every_fg_tea_command_in_the_docs_parses(page):
    """Flags and values of every documented command are ones the parser accepts (fast)."""
    from fg_tea.cli.main import build_parser

    for lang, body, _ in blocks(page):
        if lang != "bash":
            continue
        for argv in fg_tea_commands(body):
            if any("$" in a or "*" in a or re.fullmatch(r"(?!lookahead|pouct|pomcp)\w+:[A-Za-z_]\w*", a)
                   for a in argv):
                continue  # a shell variable, a glob or the page's own plug-in: checked when it runs
            try:
                build_parser().parse_args(argv)
            except SystemExit as exc:
                pytest.fail(f"{page}: fg-tea {shlex.join(argv)} does not parse (exit {exc.code})")


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if any(lang == "bash" and runs
                                                          for lang, _, runs in blocks(p))])
def test_every_shell_block_in_the_docs_runs(page, tmp_path):
    work = tmp_path / "work"
    work.mkdir()
    for name, source in SETUP.get(page, {}).items():
        shutil.copy2(ROOT / source, work / name)
    env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    for lang, body, runs in blocks(page):
        if lang == "python" and body.startswith("# ") and body.split("\n", 1)[0].endswith(".py"):
            (work / body.split("\n", 1)[0][2:].strip()).write_text(body)
        if lang != "bash" or not runs:
            continue
        done = subprocess.run(["bash", "-e", "-c", body], cwd=work, env=env, capture_output=True,
                              text=True, timeout=900, stdin=subprocess.DEVNULL)
        assert done.returncode == 0, f"{page}: block failed:\n{body}\n{done.stderr[-2000:]}"
