"""What ``fg-tea run`` does when given no options: its video options and its episode.

The video benchmarks and the video's reference frames start from these (docs/design.md §8.6), so
a change to a default of ``fg-tea run`` moves them all together.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any


def default_options(**changes: Any):
    """``fg-tea run``'s video options (the command's defaults), with `changes` applied."""
    from dataclasses import replace

    from fg_tea.cli.common import video_options
    from fg_tea.cli.main import build_parser

    options = video_options(build_parser().parse_args(["run"]))
    return replace(options, **changes)


def default_episode(folder: Path) -> list[dict]:
    """The events of ``fg-tea run --no-video`` (default scenario, model and seed), run in `folder`.

    Raises:
        RuntimeError: the run did not finish with status 0.
    """
    import contextlib
    import io

    from fg_tea.cli.main import main
    from fg_tea.episode.log import read_log

    with contextlib.redirect_stdout(io.StringIO()):
        status = main(["run", "--no-video", "--out", str(folder)])
    if status != 0:
        raise RuntimeError(f"fg-tea run --no-video ended with status {status}")
    return read_log(Path(folder) / "episode.jsonl")
