"""MkDocs hook: the log-format page shows docs/design.md §9 itself, not a copy that could drift.

``docs/log-format.md`` holds the placeholder line ``<!-- docs/design.md §9 -->``; at build time
:func:`on_page_markdown` replaces it with the text of design §9 ("The log": the event table,
stepping, provenance, viewpoint fields, metrics, determinism), its headings moved one level down.
Nothing is written to the source tree. Registered under ``hooks:`` in ``mkdocs.yml``.
"""

from __future__ import annotations

import re
from pathlib import Path

PLACEHOLDER = "<!-- docs/design.md §9 -->"
PAGE = "log-format.md"


def design_section(docs_dir: str | Path, number: int) -> str:
    """The body of ``## N. ...`` in design.md, up to the next ``## `` heading, without its title."""
    text = (Path(docs_dir) / "design.md").read_text(encoding="utf-8")
    match = re.search(rf"^## {number}\. [^\n]*\n(.*?)(?=^## |\Z)", text, re.S | re.M)
    if match is None:
        raise ValueError(f"docs/design.md has no section '## {number}.'")
    body = match.group(1).strip().removesuffix("---").strip()
    return re.sub(r"^(#{3,5}) ", r"#\1 ", body, flags=re.M)


def on_page_markdown(markdown_text: str, page, config, files):  # noqa: ARG001 - MkDocs hook API
    if page.file.src_uri != PAGE:
        return markdown_text
    if PLACEHOLDER not in markdown_text:
        raise ValueError(f"{PAGE} lost its placeholder line {PLACEHOLDER!r}")
    return markdown_text.replace(PLACEHOLDER, design_section(config["docs_dir"], 9))
