"""What every fg-tea command shares: the command registry, argparse types, output checks, progress.

Commands register with :func:`command`; :mod:`fg_tea.cli.main` builds the parser and dispatches.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any, Callable, NoReturn, Sequence

from fg_tea.common.errors import InputError
from fg_tea.common.files import (  # noqa: F401 - the commands import them from here
    check_out_dir,
    check_out_file,
    check_output_file,
)
from fg_tea.common.options import DeprecatedAlias
from fg_tea.world.interface import logged_viewpoint

COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {}


def command(name: str):
    def register(fn):
        COMMANDS[name] = fn
        return fn
    return register


class Parser(argparse.ArgumentParser):
    """argparse that reports usage faults in one line with exit status 2, and keeps the notes on
    deprecated option names for :func:`main` to write after the command (one line each)."""

    defer_notes = True  # DeprecatedAlias leaves its notes on the namespace for main()

    def error(self, message: str) -> NoReturn:  # noqa: D401 - argparse API
        from fg_tea.common.options import with_suggestions

        sys.stderr.write(f"fg-tea: error: {with_suggestions(self, message)}\n")
        raise SystemExit(2)


class Failed(Exception):
    """A command that ran and failed for a reason that is not the user's input (a fault of
    fg_tea's own, a job of a sweep): :func:`fg_tea.cli.main.main` prints its message in one line
    and exits with status 1 (see :data:`EXIT_STATUS`)."""


#: The exit statuses every command shares (the --help epilogs of run and compare end with it).
EXIT_STATUS = ("2 for bad input, in one line: a file, field or option at fault, or a fault of a "
               "plug-in planner (it raised or exited, or its decision broke the Planner contract)")


def plugin_planner(name: str) -> bool:
    """Whether `name` names a plug-in planner (an entry point, ``module:attribute`` or a name
    registered in this process), whose faults are the user's input, not fg_tea's."""
    from fg_tea.planning import is_family_spec, planner_names

    return name not in planner_names() and not is_family_spec(name)


def out_path(text: str) -> str:
    """An argparse type for ``--out``: a path, never an empty string (which would otherwise mean
    the current folder to some commands and the default to others)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a path, got an empty string (without --out, a "
                                         "command with a default output uses it)")
    return text


def integer(lo: int, hi: int | None = None):
    """An argparse type: an integer in [lo, hi]."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text[:40]!r}") from None
        if value < lo or (hi is not None and value > hi):
            span = f"from {lo} to {hi}" if hi is not None else f"of at least {lo}"
            raise argparse.ArgumentTypeError(f"expected an integer {span}, got {value}")
        return value
    parse.bounds = (lo, hi)  # type: ignore[attr-defined]  # read by the flag-range tests
    return parse


def number(lo: float, hi: float, lo_open: bool = False, hi_open: bool = False):
    """An argparse type: a finite number in the interval between lo and hi."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text[:40]!r}") from None
        inside = math.isfinite(value) and (lo < value if lo_open else lo <= value) and \
            (value < hi if hi_open else value <= hi)
        if not inside:
            raise argparse.ArgumentTypeError(
                f"expected a number in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}, "
                f"got {text[:40]}")
        return value
    parse.bounds = (lo, hi, lo_open, hi_open)  # type: ignore[attr-defined]  # the flag-range tests
    return parse


#: Seeds are fed to numpy's generator and PyBullet; 2^32 - 1 keeps every consumer in range.
MAX_SEED = 2 ** 32 - 1


def format_table(rows: list[list[str]], header: list[str]) -> str:
    widths = [max(len(str(r[i])) for r in rows + [header]) for i in range(len(header))]
    fmt = "  ".join(f"{{:{'<' if i == 0 else '>'}{w}}}" for i, w in enumerate(widths))
    lines = [fmt.format(*header), "  ".join("-" * w for w in widths)]
    lines += [fmt.format(*r) for r in rows]
    return "\n".join(lines)


def check_scenario(scenario, model) -> None:
    """Every check a run makes before its first step, without a simulator.

    Builds the occupancy grid and :class:`~fg_tea.world.navigation.Navigator` (vantage points on
    free floor and reachable from the start) and the exact belief (state and joint-size limits).

    Raises:
        InputError: naming the scenario file (or the model's, for a joint too large).
    """
    from fg_tea.beliefs.engine import BeliefEngine
    from fg_tea.env.base import EnvConfig
    from fg_tea.world.navigation import Navigator

    Navigator(scenario, EnvConfig())
    try:
        BeliefEngine(scenario, model)
    except InputError:  # names its own file and field: a model program's factor, its budget
        raise
    except ValueError as exc:
        raise InputError(scenario.source or "<scenario>", "$.objects",
                         f"with model {model.name!r}: {exc}") from None


# ------------------------------------------------------------------------------ episodes
def video_options(args: argparse.Namespace):
    from fg_tea.render.video import VideoOptions

    if args.view == "multi":  # the first-person inset must fit in the frame (see _compose)
        iw = int(args.width * args.inset_scale) // 2 * 2
        ih = int(iw * 3 / 4) // 2 * 2
        if iw < 16 or ih + 6 > args.height or iw + 6 > args.width:
            raise InputError("<command line>", "--inset-scale",
                             f"an inset of {args.inset_scale:g} x {args.width} px ({iw}x{ih}) does "
                             f"not fit a {args.width}x{args.height} frame")
    try:
        return VideoOptions(width=args.width, height=args.height, fps=args.fps, view=args.view,
                            inset_scale=args.inset_scale, chase_distance=args.third_person_distance,
                            chase_height=args.third_person_height,
                            chase_pitch_deg=args.third_person_pitch,
                            chase_hfov_deg=args.third_person_hfov, hold_seconds=args.hold,
                            workers=args.workers, overlays=not args.no_overlays,
                            scene_scale=args.scene_scale, frame_stride=args.frame_stride,
                            wall_cutaway=None if args.full_walls else args.wall_cutaway)
    except ValueError as exc:
        raise InputError("<command line>", "video options", str(exc)) from None


#: Verbs that observe rather than act: the environment never executes them, so no failure rate.
OBSERVING_VERBS = ("SEARCH", "INSPECT")


def failure_rates(pairs: list[str]) -> dict[str, float]:
    from fg_tea.world.interface import VERBS

    actions = [v for v in VERBS if v not in OBSERVING_VERBS]
    rates: dict[str, float] = {}
    for pair in pairs:
        verb, _, value = pair.partition("=")
        try:
            rate = float(value)
        except ValueError:
            rate = -1.0
        if verb.upper() in OBSERVING_VERBS:
            raise InputError("<command line>", "--failure-rate",
                             f"{verb.upper()} observes and cannot fail; failure rates apply to the "
                             f"actions {', '.join(actions)} (got {pair!r})")
        if verb.upper() not in VERBS or not 0.0 <= rate <= 1.0:
            raise InputError("<command line>", "--failure-rate",
                             f"expected VERB=P with VERB in {', '.join(actions)} and P in [0, 1], got {pair!r}")
        if verb.upper() in rates:
            raise InputError("<command line>", "--failure-rate",
                             f"{verb.upper()} is given twice ({verb.upper()}={rates[verb.upper()]:g} and "
                             f"{pair!r}); give each verb once")
        rates[verb.upper()] = rate
    return rates


def safe_name(name: str) -> str:
    """`name` as one file name that stays inside its folder (no separators, no leading dots)."""
    import re

    cleaned = re.sub(r"[^A-Za-z0-9._#+=-]+", "_", name).lstrip(".")[:120]
    return cleaned or "unnamed"


def remove_outputs(out: Path, names: Sequence[str]) -> None:
    """Remove the files a previous run of the same kind left in `out`, so no mix remains."""
    for name in names:
        target = out / name
        if target.is_dir() and not target.is_symlink():
            raise InputError("<command line>", "--out", f"{target} is a folder; it would be "
                             "overwritten by this run's file")
        check_output_file(target)  # a device, FIFO or socket is refused, never removed
        try:
            target.unlink(missing_ok=True)
        except OSError as exc:
            raise InputError("<command line>", "--out", f"cannot replace {target}: "
                             f"{exc.strerror or exc}") from None


class Progress:
    """``fg-tea run``'s progress bar on a terminal; silent otherwise (the summary follows).

    The bar fills with the task's finished actions (complete or skipped), so it is full exactly
    when the task is done; the frame count is shown against the frame limit beside it. The action
    named is the one being carried out, or just carried out: the last one the executor activated
    (a search included; each step of an episode works on one action), else ``-``. Drawn by
    :func:`fg_tea.common.progress.progress`, as every long run's progress is.
    """

    WIDTH = 24

    def __init__(self, max_frames: int, stream=None) -> None:
        from fg_tea.common.progress import is_terminal

        self.stream = stream or sys.stderr
        self.max_frames = max_frames
        self.tty = is_terminal(self.stream)
        self.bar: Any = None

    @staticmethod
    def active_action(runner) -> str:
        """The action being carried out or just carried out, or ``-`` before the first."""
        for event in reversed(runner.events):
            if event.get("event") == "activate":
                return str(event.get("action", "-"))
        return "-"

    def status(self, runner) -> str:
        """What the bar says after its count: the frame against the limit, and the action."""
        return f"frame {runner.state.frame:,}/{self.max_frames:,} · {self.active_action(runner)}"

    def __call__(self, runner) -> None:
        if not self.tty:
            return
        from fg_tea.common.progress import progress

        finished, total = runner.agent.progress()
        if self.bar is None:
            self.bar = progress(total, "episode", "actions", stream=self.stream, bar=True,
                                status=self.status(runner))
        self.bar.set_postfix_str(self.status(runner), refresh=False)
        if finished > self.bar.n:
            self.bar.update(finished - self.bar.n)
        else:
            self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def frames_progress(stream=None):
    """Report video rendering as ``report(done, total)`` (:func:`fg_tea.common.progress.progress`:
    redrawn on a terminal, a line every 10 s elsewhere)."""
    from fg_tea.common.progress import progress

    shown: list = []

    def report(done: int, total: int) -> None:
        if not shown:
            shown.append(progress(total, "rendering video", "frames", stream=stream))
        shown[0].update(done - shown[0].n)
        if done >= total:
            shown[0].close()

    return report


def summary(events: list[dict]) -> str:
    """A one-paragraph account of an episode, from its log."""
    from fg_tea.episode.metrics import score

    m = score(events)
    found = []
    sites = {}
    for e in events:
        if e.get("event") == "observation":
            for obj in e.get("resolved", []):
                at = e.get("found_at", {}).get(obj, logged_viewpoint(e))
                glance = e.get("viewpoint_kind") == "room"
                sites[obj] = f"{at} (from the {logged_viewpoint(e)} glance)" if glance else at
    for obj, n in sorted(m["inspections_until_resolved"].items(), key=lambda kv: kv[1] or 10 ** 9):
        found.append(f"the {obj} on {sites[obj]} after {n} inspection{'s' * (n != 1)}"
                     if n is not None else f"never the {obj}")
    skipped = ", ".join(m["skipped_actions"]) or "none"
    end = "The task is complete" if m["success"] else f"The episode ended without finishing ({m['reason']})"
    def count(n: int, what: str) -> str:
        return f"{n} {what}{'' if n == 1 else 's'}"

    # "simulation frames": the video holds each decision and observation for reading, so it
    # has more frames than this (its own line says so).
    return (f"Found {', '.join(found)} ({count(m['inspections'], 'inspection')}, {m['repeated_sites']} "
            f"repeated, {m['total_distance']:.1f} m travelled, {count(m['state_readings'], 'state reading')}, "
            f"{count(m['failures'], 'failed action')}). Skipped actions: {skipped}. {end}: "
            f"{m['actions_complete']} of {m['actions_total']} actions complete and "
            f"{m['actions_skipped']} skipped, in {count(m['frames'], 'simulation frame')}.")


#: After a video's frame count: why it is more than the episode's simulation frames.
HELD = "the episode's motion, with each decision, observation and action held a moment for reading"


def planner_size_fault(planner: str, scenario, graph, model) -> str | None:
    """Why `planner` refuses this house for this task graph, or None (before any episode).

    Asks the planner itself (:meth:`fg_tea.planning.Planner.check`, the one place a limit is
    decided: docs/design.md §6.5-§6.7) with the prior belief and the objects the task searches for.
    """
    import numpy as np

    from fg_tea.beliefs.engine import BeliefEngine
    from fg_tea.common.errors import PlannerRefused
    from fg_tea.planning import make_planner

    from fg_tea.planning.base import call_planner

    objects = [graph.action(n).object for n in graph.search_nodes()]
    built = make_planner(planner, model, rng=np.random.default_rng(0))
    try:
        call_planner(planner, built.check, BeliefEngine(scenario, model), list(dict.fromkeys(objects)))
    except PlannerRefused as exc:
        reason = str(exc).removeprefix(f"{exc.planner} planner: ")
        return f"the {exc.planner} planner refuses this house ({exc.kind}): {reason}"
    except (Exception, SystemExit) as exc:  # a plug-in's own check() failed: the user's input
        if not plugin_planner(planner):
            raise
        first = (str(exc).splitlines() or [""])[0]
        what = (f"called exit({exc.code!r})" if isinstance(exc, SystemExit)
                else f"raised {type(exc).__name__}" + (f": {first}" if first else ""))
        raise InputError("<command line>", f"--planner {planner}", f"its check() {what}") from None
    return None


def add_video_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("video (defaults: docs/design.md §8.6)")
    g.add_argument("--view", choices=("multi", "first", "third"), default="multi",
                   help="chase view with first-person inset, or either alone (default: %(default)s)")
    g.add_argument("--width", type=integer(64, 7680), default=960, help="output width in pixels (default: %(default)s)")
    g.add_argument("--height", type=integer(64, 4320), default=540,
                   help="output height in pixels (default: %(default)s)")
    g.add_argument("--fps", type=integer(1, 240), default=30, help="output frame rate (default: %(default)s)")
    g.add_argument("--scene-scale", type=number(0.1, 1.0), default=2 / 3,
                   help="render the 3D views at this fraction of the output size (default: 0.667)")
    g.add_argument("--inset-scale", type=number(0.05, 0.6), default=0.3, help="inset width / frame width")
    g.add_argument("--third-person-distance", type=number(0.0, 50.0), default=3.2, help="metres behind the agent")
    g.add_argument("--third-person-height", type=number(-50.0, 50.0), default=2.2, help="camera height, metres")
    g.add_argument("--third-person-pitch", type=number(-90.0, 90.0), default=-22.0, help="camera pitch, degrees")
    g.add_argument("--third-person-hfov", type=number(1.0, 179.0), default=78.0,
                   help="horizontal field of view, degrees")
    g.add_argument("--hold", type=number(0.0, 60.0), default=0.8, help="seconds to hold decision frames")
    g.add_argument("--wall-cutaway", type=number(0.0, 100.0), default=1.0,
                   help="chase view: draw walls up to this height in metres (default: %(default)s)")
    g.add_argument("--full-walls", action="store_true", help="chase view: draw walls at full height")
    g.add_argument("--frame-stride", type=integer(1, 10_000), default=1,
                   help="a quick draft about N times shorter and cheaper: every N-th frame of "
                   "motion, pauses N times shorter (default: %(default)s)")
    g.add_argument("--workers", type=integer(0, 1024), default=0, help="rendering processes (0: one per core)")
    g.add_argument("--no-overlays", action="store_true", help="camera images only")


def planner_name(text: str) -> str:
    """An argparse type: a built-in planner, an entry-point planner or ``module:attribute``."""
    from fg_tea.planning import check_planner as check
    from fg_tea.planning.plugins import PlannerSpecError

    try:
        check(text)
    except PlannerSpecError as exc:
        raise argparse.ArgumentTypeError(exc.fault) from None
    return text


# ------------------------------------------------------------------------------ bundled names
MODEL_HELP = ("model file (.toml), bundled model or ablation name, or a model program (a .py file, "
              "module:attr or an fg_tea.models entry point; docs/how-to/model-as-program.md; "
              "importing and building it are limited to FG_TEA_MODEL_SECONDS seconds each, "
              "default 60) (default: %(default)s)")
CAMERA_HELP = ("camera file, or bundled camera name (visibility, threshold, no_site_association): "
               "what the camera reports (docs/design.md §1.3); default: the bundled camera of the "
               "detector the model assumes")


#: The exact belief solvers (``BeliefEngine(backend=)``, ``Agent(solver=)``, ``--solver``).
SOLVERS = ("numpy", "gtsam", "compiled")


def add_solver_argument(p: argparse.ArgumentParser) -> None:
    """``--solver`` (the exact belief backend), with ``--backend`` as its deprecated alias."""
    p.add_argument("--solver", choices=SOLVERS, default="numpy",
                   help="exact belief solver: closed forms and dense tables (numpy), gtsam's "
                   "discrete elimination, or the location block as a compiled program (compiled) "
                   "(default: %(default)s)")
    p.add_argument("--backend", dest="solver", choices=SOLVERS, action=DeprecatedAlias,
                   new="--solver")
