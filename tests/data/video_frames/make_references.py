"""Write the reference frames of tests/test_video_speed.py (run once, from the repository root).

The frames were written by the renderer as it was before the video was made cheaper (commit
4aafc1c), from the default episode (``fg-tea run --no-video``'s log) with ``fg-tea run``'s video
options; the test renders the same frames with today's code and asks for PSNR >= 40 dB. To write
them again, run this with that commit's package first on the path::

    mkdir /tmp/old && git archive 4aafc1c | tar -x -C /tmp/old
    PYTHONPATH=/tmp/old python tests/data/video_frames/make_references.py
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))  # tests/

from video_reference import FRAMES, default_episode, default_options  # noqa: E402


def main() -> None:
    from fg_tea.render.video import render_still

    with tempfile.TemporaryDirectory() as tmp:
        events = default_episode(Path(tmp))
        for n in FRAMES:
            render_still(events, HERE / f"frame{n:04d}.png", n, default_options())
            print(HERE / f"frame{n:04d}.png")


if __name__ == "__main__":
    main()
