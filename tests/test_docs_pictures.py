"""The documentation's pictures come from named commands and show what their captions say."""

from __future__ import annotations

from pathlib import Path

import pytest
from docs_tools import load_tool

ROOT = Path(__file__).resolve().parent.parent


def _pictures():
    return load_tool("pictures")


def test_every_picture_is_shown_with_the_frame_it_is():
    pictures = _pictures()
    for picture, (_, frame, _) in pictures.PICTURES.items():
        assert (ROOT / picture).is_file()
        name = Path(picture).name
        shown = [p for p in (ROOT / "README.md", *(ROOT / "docs").rglob("*.md")) if name in p.read_text()]
        assert shown and all(f"frame {frame} of" in p.read_text() for p in shown), picture


@pytest.mark.slow
def test_every_picture_still_shows_what_its_caption_says(tmp_path):
    pictures = _pictures()
    for picture, (_, _, promised) in pictures.PICTURES.items():
        png, caption = pictures.make(picture, tmp_path)
        assert png.stat().st_size > 0 and promised in caption, (picture, caption)
