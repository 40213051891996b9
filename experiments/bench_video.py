"""What does the video cost? CPU of ``fg-tea run`` against ``fg-tea run --no-video``, one run.

Runs the README's first command, ``fg-tea run`` (the default episode and its video), and the
same episode without video, each as a separate process, and measures the CPU each takes (user
+ system, the rendering workers included: they are the command's children and are waited for).
The headless episode is repeated (median); both are measured in one run so they share the
machine's load. Target: the run with video costs at most 30 times the CPU of the run without.
About a minute of wall time on 2 idle cores.

    python experiments/bench_video.py [--repeats 3] [--workers 0] [--out FILE]
    python experiments/bench_video.py --quick      # a small draft video: a smoke run, not the target

Writes a Markdown summary with the command that made it (default:
runs/experiments/bench_video/bench_video.md; the committed one is made with
--out experiments/results/video/bench_video.md).
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from fg_tea.common.files import atomic_write_text, out_file
from fg_tea.common.options import experiment_parser
from fg_tea.common.tables import table_lines

ROOT = Path(__file__).resolve().parents[1]
TARGET = 30.0


def measure(args: list[str]) -> tuple[float, float]:
    """(CPU s, wall s) of ``fg-tea ARGS`` in a child process, its own children included."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "fg_tea.cli", *args], capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"fg-tea {' '.join(args)} failed ({proc.returncode}): {proc.stderr.strip()[-400:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall


DEFAULT_OUT = Path("runs") / "experiments" / "bench_video" / "bench_video.md"


def build_parser():
    parser = experiment_parser(__doc__, __file__, "§9")
    parser.add_argument("--repeats", type=int, default=3, help="headless runs (median reported)")
    parser.add_argument("--workers", type=int, default=0, help="rendering processes (0: one per core)")
    parser.add_argument("--quick", action="store_true", help="small draft video (smoke run)")
    parser.add_argument("--out", type=out_file, default=DEFAULT_OUT,
                        help="summary file (committed: experiments/results/video/bench_video.md)")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    video = ["--workers", str(args.workers)]
    if args.quick:
        video += ["--width", "192", "--height", "108", "--frame-stride", "40", "--hold", "0.1"]
    out = args.out
    with tempfile.TemporaryDirectory() as tmp:
        headless = []
        for r in range(args.repeats):
            print(f"headless episode {r + 1}/{args.repeats}", file=sys.stderr, flush=True)
            headless.append(measure(["run", "--no-video", "--out", str(Path(tmp) / f"h{r}")]))
        print("episode with video", file=sys.stderr, flush=True)
        with_video = measure(["run", "--out", str(Path(tmp) / "v"), *video])
        frames = (Path(tmp) / "v" / "timings.json").read_text()
    base = statistics.median(c for c, _ in headless)
    ratio = with_video[0] / base
    import json

    timings = json.loads(frames)
    command = "python experiments/bench_video.py " + " ".join(argv if argv is not None else sys.argv[1:])
    lines = [
        "## The video's cost: `fg-tea run` against `fg-tea run --no-video`",
        "",
        f"Made by `{command.strip()}` on {os.cpu_count()} cores"
        f"{' (quick: a small draft video, not the target)' if args.quick else ''}. CPU = user + system "
        "of the command and its rendering workers.",
        "",
        *table_lines(["run", "command", "CPU s", "wall s", "ratio"], [
            ["headless", f"`fg-tea run --no-video` (median of {args.repeats})", f"{base:.2f}",
             f"{statistics.median(w for _, w in headless):.2f}", 1],
            ["video", f"`fg-tea run {' '.join(video)}` ({timings.get('video_frames', '?')} output frames)",
             f"{with_video[0]:.2f}", f"{with_video[1]:.2f}", f"{ratio:.1f}"]], align="left"),
        "",
        f"**Ratio: {ratio:.1f}x** the CPU of the episode without video (target <= {TARGET:.0f}x: "
        f"{'met' if ratio <= TARGET else 'NOT met'}).",
        "",
    ]
    text = "\n".join(lines)
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
