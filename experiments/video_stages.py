"""Where does a frame of ``fg-tea run``'s video spend its CPU? Milliseconds per rendered frame by stage.

Runs the default episode headless (as ``fg-tea run --no-video``), then renders and encodes the
rendered frames [start, start + frames) of its video (default: all of them) with ``fg-tea run``'s
video options in this process, piece by piece as a worker does, and counts the CPU time
(``time.process_time``) spent in each stage:

* the chase view and the first-person inset: PyBullet's TinyRenderer (``getCameraImage``: the
  objects' and the drone's windows, :mod:`fg_tea.render.windows`), and the render-only views'
  own work around it (the walls and furniture painted, :mod:`fg_tea.render.boxes`; the windows
  laid over them; the floor's fill);
* scaling the views up to the frame (``cv2.resize``), the overlays, and encoding (colour
  conversion and x264);
* the rest (composition, camera matrices, reused images' copies): what is left of the total.

No profiler runs (its overhead would be counted); the counters wrap the functions named.

    python experiments/video_stages.py [--frames N] [--start 0] [--out FILE]

It writes runs/experiments/video_stages/stages.md unless --out names another file (the committed
one: experiments/results/video/stages.md).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator

from fg_tea.cli.defaults import default_episode, default_options
from fg_tea.common.files import atomic_write_text, out_file
from fg_tea.common.options import experiment_parser
from fg_tea.common.tables import table_lines

DEFAULT_OUT = Path("runs") / "experiments" / "video_stages" / "stages.md"


class Counters:
    """CPU seconds per stage; a stage entered inside another is counted in both."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self.calls: dict[str, int] = {}
        self.inside: list[str] = []

    def wrap(self, owner, name: str, stage: str | Callable[["Counters"], str]) -> Callable[[], None]:
        """Count calls of ``owner.name`` under `stage` (or the stage it names when called);
        returns what undoes it."""
        original = getattr(owner, name)

        def counted(*args, **kwargs):
            key = stage if isinstance(stage, str) else stage(self)
            self.inside.append(key)
            start = time.process_time()
            try:
                return original(*args, **kwargs)
            finally:
                self.seconds[key] = self.seconds.get(key, 0.0) + time.process_time() - start
                self.calls[key] = self.calls.get(key, 0) + 1
                self.inside.pop()

        setattr(owner, name, counted)
        return lambda: setattr(owner, name, original)


@contextmanager
def counting(renderer, counters: Counters) -> Iterator[None]:
    import cv2

    from fg_tea.env.pybullet_quiet import pybullet
    from fg_tea.render import compose, encoder

    views = renderer.views.views  # the SceneViews under the reuse of repeated scenes

    def tiny(c: Counters) -> str:
        return "TinyRenderer, inset" if "inset total" in c.inside else "TinyRenderer, chase"

    undo = [counters.wrap(views, "chase", "chase total"), counters.wrap(views, "ego", "inset total"),
            counters.wrap(pybullet, "getCameraImage", tiny),
            counters.wrap(cv2, "resize", lambda c: "resize in the overlays" if "overlays" in c.inside
                          else "scaling up (cv2.resize)"),
            counters.wrap(compose, "draw_overlays", "overlays"),
            counters.wrap(encoder.Mp4Writer, "write", "encoding (colour conversion, x264)")]
    try:
        yield
    finally:
        for u in reversed(undo):
            u()


def build_parser() -> argparse.ArgumentParser:
    parser = experiment_parser(__doc__, __file__, "§9")
    parser.add_argument("--frames", type=int, default=0, help="rendered frames to measure (0: all)")
    parser.add_argument("--start", type=int, default=0, help="first rendered frame")
    parser.add_argument("--out", type=out_file, default=DEFAULT_OUT,
                        help="the summary (committed: experiments/results/video/stages.md)")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from fg_tea.render import video
    from fg_tea.render.frames import FrameRenderer, pieces

    counters = Counters()
    with tempfile.TemporaryDirectory() as tmp:
        events = default_episode(Path(tmp))
        options = default_options(workers=1)
        plan = video.plan_frames(events, options)
        hi = len(plan.frames) if args.frames <= 0 else min(len(plan.frames), args.start + args.frames)
        renderer = FrameRenderer(plan, options)
        try:
            with counting(renderer, counters):
                start = time.process_time()
                for k, (lo, top) in enumerate(pieces(len(plan.frames))):
                    lo, top = max(lo, args.start), min(top, hi)
                    if lo < top:
                        renderer.encode(lo, top, Path(tmp) / f"piece{k}.mp4")
                total = time.process_time() - start
            reused, rendered = renderer.views.reused, renderer.views.rendered
        finally:
            renderer.close()
    frames = max(hi - args.start, 1)
    s = counters.seconds
    rows = [("TinyRenderer, chase (objects' windows)", s.get("TinyRenderer, chase", 0.0)),
            ("chase: walls and furniture painted, windows laid, floor filled",
             s.get("chase total", 0.0) - s.get("TinyRenderer, chase", 0.0)),
            ("TinyRenderer, inset (objects' windows)", s.get("TinyRenderer, inset", 0.0)),
            ("inset: walls and furniture painted, windows laid, floor filled",
             s.get("inset total", 0.0) - s.get("TinyRenderer, inset", 0.0))]
    rows += [(k, s.get(k, 0.0)) for k in ("scaling up (cv2.resize)", "overlays", "encoding (colour conversion, x264)")]
    rows.append(("the rest (composition, cameras, reused images' copies)", total - sum(v for _, v in rows)))
    command = "python experiments/video_stages.py " + " ".join(argv if argv is not None else sys.argv[1:])
    lines = ["## CPU per rendered frame of the default video, by stage", "",
             f"Made by `{command.strip()}`: rendered frames {args.start} to {hi - 1} of {len(plan.frames)} "
             f"({options.width}x{options.height}, scene scale {options.scene_scale:.3f}), one process; "
             f"camera images rendered {rendered}, reused {reused}.", ""]
    lines += table_lines(["stage", "CPU ms per rendered frame", "share"],
                         [[name, f"{1000 * v / frames:.2f}", f"{100 * v / total:.0f}%"] for name, v in rows]
                         + [["total", f"{1000 * total / frames:.2f}", "100%"]], align="left")
    lines += [""]
    text = "\n".join(lines)
    atomic_write_text(args.out, text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
