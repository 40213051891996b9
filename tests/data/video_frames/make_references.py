"""Write the reference frames of tests/test_video_speed.py (run once, from the repository root).

The frames were written by the renderer as it was before the video was made cheaper (commit
4aafc1c), from the default episode (``fg-tea run --no-video``'s log) with ``fg-tea run``'s video
options; the test renders the same frames with today's code and asks for PSNR >= 40 dB. To write
them again, run this with that commit's package first on the path::

    mkdir /tmp/old && git archive 4aafc1c | tar -x -C /tmp/old
    PYTHONPATH=/tmp/old python tests/data/video_frames/make_references.py

tests/data/video_frames_be13560 holds the same frames rendered by the code of commit be13560,
before the video's cost was cut again (tests/test_video_cost.py asks PSNR >= 40 dB of them; they
were identical when written). It was written the same way, the folder given::

    mkdir /tmp/be13560 && git archive be13560 | tar -x -C /tmp/be13560
    PYTHONPATH=/tmp/be13560 python tests/data/video_frames/make_references.py tests/data/video_frames_be13560
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

    folder = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        events = default_episode(Path(tmp))
        for n in FRAMES:
            render_still(events, folder / f"frame{n:04d}.png", n, default_options())
            print(folder / f"frame{n:04d}.png")


if __name__ == "__main__":
    main()
