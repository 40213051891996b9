"""The default episode and video options the video reference frames were rendered with."""

from __future__ import annotations

from pathlib import Path

#: Output frames of the default episode's video kept as references: the README's still (a room
#: glance), a frame of motion with a moving inset, a carried object, and the end. (Frame 40 was
#: one too, until a decision's caption began to say which searches its look serves.)
FRAMES = (360, 600, 1100, 2240)


def default_options(**changes):
    """``fg-tea run``'s video options (the CLI's defaults; docs/design.md §8.6)."""
    from fg_tea.cli.main import build_parser
    from fg_tea.cli.common import video_options

    args = build_parser().parse_args(["run"])
    options = video_options(args)
    from dataclasses import replace

    return replace(options, **changes)


def default_episode(folder: Path) -> list[dict]:
    """The events of ``fg-tea run --no-video`` (default scenario, model and seed)."""
    import contextlib
    import io

    from fg_tea.cli.main import main
    from fg_tea.episode.log import read_log

    with contextlib.redirect_stdout(io.StringIO()):
        status = main(["run", "--no-video", "--out", str(folder)])
    assert status == 0, status
    return read_log(folder / "episode.jsonl")
