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


def test_every_plot_is_made_by_its_command_and_counts_what_its_alt_text_says():
    """A plot's alt text names what the command draws: the counts in it match its scenario."""
    pictures = _pictures()
    words = {"sites": "numbered sites", "room vantages": "room vantages"}
    numerals = {9: "nine", 27: "27"}
    for picture, (command, _, claims) in pictures.PLOTS.items():
        assert (ROOT / picture).is_file(), picture
        name = Path(picture).name
        shown = [p.read_text() for p in (ROOT / "README.md", *(ROOT / "docs").rglob("*.md"))
                 if name in p.read_text()]
        assert shown, f"{picture} is shown nowhere"
        if claims is None:
            continue
        have = pictures.counts(claims[0])
        assert have == claims[1], (picture, have)
        for text in shown:
            alt = text.split(name)[0].rsplit("![", 1)[-1]
            for what, n in have.items():
                assert f"{numerals.get(n, n)} {words[what]}" in alt, (picture, what, alt)


@pytest.mark.slow
def test_every_plot_command_still_writes_its_picture(tmp_path):
    pictures = _pictures()
    for picture in pictures.PLOTS:
        assert pictures.plot(picture, tmp_path / Path(picture).stem).stat().st_size > 1000
