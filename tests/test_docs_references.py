"""Does the documentation cite only what a user has?

The README, ``docs/``, the package, the experiments, the model and scenario files and the tests
must cite ``docs/design.md`` (its sections and equations) for the design, never a document that is
not in the repository (the original blueprint, an architecture or performance note, a style
guide), a tracker's issue number, or a section number of such a document. Every markdown link and
every backticked repository path (``fg_tea/...``, ``docs/...``, ``experiments/...``) must exist.
Markdown links resolve against the linking file's folder, so the documentation site's nested
pages (``docs/how-to/...``) are checked as they are (mkdocs.yml builds them).

The checker is a pair of plain functions, so the same functions are also run on a planted bad
tree, which shows that the test can fail.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: What is scanned: top-level files and folders of the source tree.
SCANNED = ("README.md", "mkdocs.yml", "docs", "fg_tea", "experiments", "models", "scenarios", "tests",
           "pyproject.toml", ".ci")
#: Text files only; results tables (.csv) and images are data.
SUFFIXES = {".md", ".py", ".toml", ".json", ".txt", ".cfg", ".yml", ".yaml", ".rst", ""}
#: Never scanned: outputs, caches, and this file (which spells the patterns out).
SKIPPED_DIRS = {"__pycache__", ".pytest_cache", ".hypothesis", "runs", "build", "dist", ".git"}
THIS_FILE = Path(__file__).resolve()

#: Citations of things a user does not have. Each: (label, regex, case-insensitive).
FORBIDDEN = (
    ("the blueprint", r"blue" r"print"),
    ("ARCHITECTURE.md", r"architecture\.md"),
    ("PERFORMANCE_NOTES.md", r"performance_notes"),
    ("STYLE.md", r"\bstyle\.md"),
    ("shared/", r"(?<![\w-])shared/"),
    ("a local absolute path", r"/work/|/root/|/home/\w"),
    ("an issue number", r"\bissues?\s*#?\d+"),
    ("a table number", r"\btable\s+\d+"),
    ("a listing number", r"\blisting\s+\d+"),
    ("a numbered section of another document", r"\bsec(?:tion|tions|\.)\s*\d+"),
)
#: The model-file value ``positive_update = "blueprint"`` is a name, not a citation.
ALLOWED_VALUE = re.compile(r"""(["'])blue""" r"""print\1""", re.IGNORECASE)
#: docs/design.md is fg_tea's own account and may say that fg_tea began from a blueprint (its
#: introduction and §10 "Departures"); it may still not point at a file a user lacks.
WORD_ALLOWED_IN = {"docs/design.md": ("the blueprint",)}

LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
BACKTICKED = re.compile(r"`{1,2}([^`\s]+?)`{1,2}")
#: A placeholder (NAME, FILE, SCENARIO) or a pattern, not a path.
PLACEHOLDER = re.compile(r"[*?<>{}$~|]|(?:^|/)[^/]*[A-Z]{2,}")


def scanned_files(root: Path) -> list[Path]:
    """Every text file under the scanned entries of `root`, sorted, without outputs or caches."""
    files = []
    for name in SCANNED:
        top = root / name
        if top.is_file():
            files.append(top)
        elif top.is_dir():
            for path in top.rglob("*"):
                rel = path.relative_to(root)
                if (path.is_file() and path.suffix in SUFFIXES and path.resolve() != THIS_FILE
                        and not SKIPPED_DIRS.intersection(rel.parts)
                        and not any(p.endswith(".egg-info") for p in rel.parts)):
                    files.append(path)
    return sorted(files)


def forbidden_citations(root: Path, files: list[Path]) -> list[str]:
    """``file:line: what -- text`` for every citation of something a user does not have."""
    found = []
    for path in files:
        rel = path.relative_to(root).as_posix()
        allowed = WORD_ALLOWED_IN.get(rel, ())
        for number, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            text = ALLOWED_VALUE.sub("", line)
            for label, pattern in FORBIDDEN:
                if label not in allowed and re.search(pattern, text, re.IGNORECASE):
                    found.append(f"{rel}:{number}: {label} -- {line.strip()[:120]}")
    return found


def _top_level(root: Path) -> set[str]:
    return {p.name for p in root.iterdir() if p.name not in SKIPPED_DIRS and not p.name.endswith(".egg-info")}


def missing_paths(root: Path, files: list[Path]) -> list[str]:
    """``file:line: target`` for every markdown link or backticked repository path that does not exist.

    Markdown links resolve against the linking file's folder (as on a code host); backticked paths
    resolve against the repository root and are checked when their first component is a top-level
    entry of the repository (``fg_tea/...``, ``docs/...``; not ``runs/...``, which is output).
    """
    tops = _top_level(root)
    found = []
    for path in files:
        rel = path.relative_to(root).as_posix()
        for number, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            if path.suffix == ".md":
                for target in LINK.findall(line):
                    if re.match(r"[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
                        continue                                   # URL, mailto: or an anchor
                    target = target.split("#", 1)[0]
                    if target and not (path.parent / target).exists():
                        found.append(f"{rel}:{number}: link {target}")
            for token in BACKTICKED.findall(line):
                token = re.sub(r":\d+$", "", token.rstrip(".,;:)"))
                first = token.split("/", 1)[0]
                if "/" not in token or first not in tops or PLACEHOLDER.search(token.split("/", 1)[1]):
                    continue
                if not (root / token).exists():
                    found.append(f"{rel}:{number}: path {token}")
    return found


@pytest.fixture(scope="module")
def files() -> list[Path]:
    if not (ROOT / "docs" / "design.md").is_file():
        pytest.skip("not a full source tree (docs/design.md is absent)")
    return scanned_files(ROOT)


def test_scan_covers_the_documentation_and_the_package(files):
    names = {p.relative_to(ROOT).as_posix() for p in files}
    for expected in ("README.md", "docs/design.md", "fg_tea/__init__.py", "fg_tea/cli/main.py",
                     "experiments/ablations.py", "models/factorised.toml", "tests/test_episode.py"):
        assert expected in names
    # The documentation site's pages, in nested folders too (mkdocs.yml, tests/test_docs_site.py).
    for folder in ("concepts", "how-to", "reference"):
        pages = [n for n in names if n.startswith(f"docs/{folder}/") and n.endswith(".md")]
        if (ROOT / "docs" / folder).is_dir():
            assert pages, folder
    site_pages = {p.relative_to(ROOT).as_posix() for p in (ROOT / "docs").rglob("*.md")}
    assert site_pages <= names


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_no_citation_of_a_document_or_issue_the_user_does_not_have(files):
    found = forbidden_citations(ROOT, files)
    assert not found, ("cite docs/design.md §N or eq. (N) instead of:\n" + "\n".join(found))


def test_every_link_and_backticked_repository_path_exists(files):
    found = missing_paths(ROOT, files)
    assert not found, "references to files that are not in the repository:\n" + "\n".join(found)


def test_the_checker_finds_planted_faults(tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "design.md").write_text("# design\n\n## 10. Departures from the original blue"
                                                 "print\n")
    (tmp_path / "fg_tea").mkdir()
    (tmp_path / "fg_tea" / "mod.py").write_text(
        '"""See ARCHITECTURE' '.md and the blue' 'print\'s Table' ' 3 (section' ' 15.4, issue' ' 7)."""\n'
        'positive_update = "blue' 'print"  # a model value, not a citation\n'
        "# `fg_tea/mod.py` exists; `fg_tea/gone.py` does not; `runs/out.csv` is output; "
        "`scenarios/tasks/NAME.json` is a placeholder\n")
    (tmp_path / "README.md").write_text(
        "[design](docs/design.md#10-departures) [gone](docs/gone.md) [web](https://example.org)\n"
        "![plot](docs/missing.png) see PERFORMANCE" "_NOTES.md and /work" "/shared/x\n")
    (tmp_path / "docs" / "how-to").mkdir()
    (tmp_path / "docs" / "how-to" / "page.md").write_text(
        "[design](../design.md#9-the-log) [gone](../gone.md) [beside](gone.md)\n")
    files = scanned_files(tmp_path)
    forbidden = forbidden_citations(tmp_path, files)
    labels = {f.split(": ", 1)[1].split(" -- ")[0] for f in forbidden}
    assert labels == {"ARCHITECTURE.md", "the blueprint", "a table number", "an issue number",
                      "a numbered section of another document", "PERFORMANCE_NOTES.md", "shared/",
                      "a local absolute path"}, forbidden
    assert not any(f.startswith("fg_tea/mod.py:2:") for f in forbidden)     # the quoted value
    assert not any(f.startswith("docs/design.md") for f in forbidden)       # its own §10
    missing = missing_paths(tmp_path, files)
    assert sorted(missing) == ["README.md:1: link docs/gone.md", "README.md:2: link docs/missing.png",
                               "docs/how-to/page.md:1: link ../gone.md", "docs/how-to/page.md:1: link gone.md",
                               "fg_tea/mod.py:3: path fg_tea/gone.py"], missing
