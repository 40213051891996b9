"""Profile the video of ``fg-tea run`` on a slice of its frames (cProfile, one process).

Runs the default episode headless (as ``fg-tea run --no-video``), then renders and encodes the
rendered frames [start, start + frames) of its video with ``fg-tea run``'s video options in this
process, under cProfile, and writes the top functions by cumulative and by own time.

    python experiments/profile_video.py [--frames 200] [--start 0] [--out FILE]

It writes runs/experiments/profile_video/profile.txt unless --out names another file.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

from fg_tea.cli.defaults import default_episode, default_options
from fg_tea.common.files import atomic_write_text, out_file
from fg_tea.common.options import experiment_parser


def _relative(line: str) -> str:
    """A profile line without this machine's paths (the checkout and the interpreter's)."""
    import re
    import sysconfig

    for prefix, short in ((sysconfig.get_paths()["purelib"], "site-packages"),
                          (sysconfig.get_paths()["stdlib"], "stdlib")):
        line = line.replace(prefix, short)
    line = line.replace(str(ROOT) + "/", "")
    return re.sub(r"(?<![\w.])/\S*/(lib/python[\d.]+/)", r"\1", line)


def _render_range(video, plan, options, lo: int, hi: int, path: Path) -> None:
    """Render and encode rendered frames [lo, hi) in this process, as a worker does."""
    if hasattr(video, "_render_segment"):  # the renderer before it was made cheaper
        video._render_segment((plan, options, lo, hi, str(path), 0, None))
        return
    from fg_tea.render.frames import FrameRenderer

    renderer = FrameRenderer(plan, options)
    try:
        renderer.encode(lo, hi, path)
    finally:
        renderer.close()


DEFAULT_OUT = Path("runs") / "experiments" / "profile_video" / "profile.txt"


def build_parser() -> argparse.ArgumentParser:
    parser = experiment_parser(__doc__, __file__, "§9")
    parser.add_argument("--frames", type=int, default=200, help="rendered frames to profile")
    parser.add_argument("--start", type=int, default=0, help="first rendered frame")
    parser.add_argument("--top", type=int, default=25, help="functions listed")
    parser.add_argument("--out", type=out_file, default=DEFAULT_OUT,
                        help="the summary (committed: experiments/results/video/profile_after.txt)")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from fg_tea.render import video

    with tempfile.TemporaryDirectory() as tmp:
        events = default_episode(Path(tmp))
        options = default_options(workers=1)
        plan = video.plan_frames(events, options)
        hi = min(len(plan.frames), args.start + args.frames)
        out_frames = sum(f.repeat for f in plan.frames[args.start:hi])
        profile = cProfile.Profile()
        t, c = time.perf_counter(), time.process_time()
        profile.enable()
        _render_range(video, plan, options, args.start, hi, Path(tmp) / "seg.mp4")
        profile.disable()
        wall, cpu = time.perf_counter() - t, time.process_time() - c
    text = io.StringIO()
    command = "python experiments/profile_video.py " + " ".join(argv if argv is not None else sys.argv[1:])
    text.write(f"# {command.strip()}\n# rendered frames {args.start}..{hi} of {len(plan.frames)} "
               f"({out_frames} output frames), {options.width}x{options.height}, scene_scale "
               f"{options.scene_scale:.3f}, one process\n# {cpu:.2f} s CPU, {wall:.2f} s wall: "
               f"{1000 * cpu / max(hi - args.start, 1):.1f} ms CPU per rendered frame, "
               f"{1000 * cpu / max(out_frames, 1):.1f} ms per output frame\n\n")
    for key in ("cumulative", "tottime"):
        stats = pstats.Stats(profile, stream=text)
        stats.sort_stats(key).print_stats(args.top)
    summary = text.getvalue()
    summary = "\n".join(_relative(line.rstrip()) for line in summary.splitlines()) + "\n"
    atomic_write_text(args.out, summary)
    print(summary)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
