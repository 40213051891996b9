"""``fg-tea explore``: an episode, or two of the same world, as one HTML page (docs/design.md §9.2).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from fg_tea.cli.common import command, out_path
from fg_tea.common.errors import InputError
from fg_tea.common.files import check_out_file


def video_duration(path: Path) -> float | None:
    """Length (s) of the video at `path`, or None when it cannot be read as one."""
    import av

    try:
        with av.open(str(path)) as container:
            stream = container.streams.video[0]
            if stream.duration is not None and stream.time_base is not None:
                return float(stream.duration * stream.time_base)
            return float(container.duration) / 1e6 if container.duration else None
    except (av.error.FFmpegError, IndexError, OSError):
        return None


def check_video(video: Path, flag: str = "--video") -> float:
    """The video's length; one line naming the fault when it is missing or not a video."""
    if not video.is_file():
        raise InputError(video, flag, "no such video file" if not video.exists() else "not a regular file")
    duration = video_duration(video)
    if duration is None:
        raise InputError(video, flag, "not a video that can be read (MP4 from fg-tea run or render)")
    return duration


@command("explore")
def cmd_explore(args: argparse.Namespace) -> int:
    """Write one self-contained HTML page that steps through one episode, or two side by side."""
    from fg_tea.render.explore import check_log_size, page_data, read_episode, same_world, write_page

    if len(args.logs) > 2:
        raise InputError("<command line>", "LOG", f"one or two logs, got {len(args.logs)}")
    first = Path(args.logs[0])
    out = Path(args.out) if args.out is not None else first.with_suffix(".html") if len(args.logs) == 1 \
        else first.parent / f"{first.stem}-vs-{Path(args.logs[1]).parent.name or Path(args.logs[1]).stem}.html"
    if args.label is not None and len(args.label) != len(args.logs):
        raise InputError("<command line>", "--label", f"one label per log: {len(args.logs)} logs, "
                                                      f"{len(args.label)} labels")
    check_out_file(out)
    for given, flag in [(name, "LOG") for name in args.logs] + ([(args.video, "--video")] if args.video else []):
        if Path(given).exists() and out.exists() and os.path.samefile(given, out):
            raise InputError("<command line>", "--out", f"{out} is the input {flag} itself: name another file")
    for name in args.logs:
        check_log_size(name)
    logs = [(name, read_episode(name)) for name in args.logs]
    if len(logs) == 2 and (why := same_world(logs[0][1], logs[1][1])):
        raise InputError(args.logs[1], "episode_start", f"not an episode of the same world as "
                                                        f"{args.logs[0]}: {why}")
    video = None
    duration = None
    if args.video:
        duration = check_video(Path(args.video))
        video = Path(os.path.relpath(Path(args.video).resolve(), out.resolve().parent)).as_posix()
    data = page_data(logs, video, args.label or ())
    if video is not None and data["video"]["times"] and duration is not None \
            and data["video"]["times"][-1] > duration + 0.5:
        data["video"]["note"] = (f"the video ({duration:.1f} s) is shorter than the log's events "
                                 f"({data['video']['times'][-1]:.1f} s): it was rendered with other "
                                 "options, so its frames do not line up with the steps")
    start = logs[0][1][0]
    labels = " vs ".join(ep["label"] for ep in data["episodes"])
    title = f"{labels} · {start.get('scenario')} · seed {start.get('seed')}"
    write_page(out, data, title)
    size = out.stat().st_size
    divergence = data.get("divergence")
    where = ""
    if len(logs) == 2:
        where = (f"; choices differ first at decision {divergence['decision'] + 1}" if divergence
                 else "; the same choices at every decision")
    counts = [len(ep["steps"]) for ep in data["episodes"]]
    # The counts the page shows: its slider's positions, and each episode's steps.
    steps = (f"{counts[0]} steps" if len(counts) == 1 else
             f"{len(data.get('pairs') or [])} slider positions: A {counts[0]} steps, B {counts[1]} steps")
    print(f"Wrote {out} ({size / 1e6:.2f} MB, {steps}{where}); open it in a browser (no server needed).")
    return 0


def add_parser(sub) -> None:
    p = sub.add_parser("explore", help="an episode (or two of the same world) as an interactive HTML page",
                       description="Write one self-contained HTML page (data, script and styles "
                       "inlined; it opens from disk, no server, no network) that steps through an "
                       "episode event by event: the floor plan shaded by an object's location "
                       "belief, the candidate table of each decision with every term, the task "
                       "graph, hidden states and entropies over time, and the video frame of each "
                       "step when --video is given. With two logs of the same world (factorised "
                       "and joint, or two planners) the page shows both side by side and marks the "
                       "first decision where their choices differ. Logs over 64 MB are refused (a page "
                       "about twice its log's size is more than a browser opens well).")
    p.add_argument("logs", nargs="+", metavar="LOG",
                   help="episode log (episode.jsonl); a second of the same world to compare")
    p.add_argument("--video", default=None, metavar="MP4",
                   help="the episode's video (of the first log), shown at each step's time; the page "
                   "links to it by a path relative to the page")
    p.add_argument("--out", default=None, type=out_path, metavar="HTML",
                   help="the page to write (default: beside the first log, LOG.html, or "
                   "LOG-vs-FOLDER.html for two)")
    p.add_argument("--label", nargs="+", default=None, metavar="TEXT",
                   help="names of the episodes on the page (default: model · planner)")
