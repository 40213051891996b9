"""The `fg-tea` command line: a thin wrapper over the package's public API.

Every input fault (scenario, model or task file; bad option) is printed as one line naming the
file, the field and what is wrong, and the command exits with status 2.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path
from typing import Any, Callable, NoReturn, Sequence

from fg_tea.common.errors import InputError
from fg_tea.common.files import atomic_path, atomic_write_text
from fg_tea.common.options import DeprecatedAlias
from fg_tea.common.resources import DEFAULT_MODEL, DEFAULT_SCENARIO

COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {}


def _command(name: str):
    def register(fn):
        COMMANDS[name] = fn
        return fn
    return register


class _Parser(argparse.ArgumentParser):
    """argparse that reports usage faults in one line with exit status 2, and keeps the notes on
    deprecated option names for :func:`main` to write after the command (one line each)."""

    defer_notes = True  # DeprecatedAlias leaves its notes on the namespace for main()

    def error(self, message: str) -> NoReturn:  # noqa: D401 - argparse API
        sys.stderr.write(f"fg-tea: error: {message}\n")
        raise SystemExit(2)



def _integer(lo: int, hi: int | None = None):
    """An argparse type: an integer in [lo, hi]."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text[:40]!r}") from None
        if value < lo or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(
                f"expected an integer {'from ' + str(lo) + ' to ' + str(hi) if hi is not None else 'of at least ' + str(lo)}, "
                f"got {value}")
        return value
    return parse


def _number(lo: float, hi: float, lo_open: bool = False, hi_open: bool = False):
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
    return parse


#: Seeds are fed to numpy's generator and PyBullet; 2^32 - 1 keeps every consumer in range.
MAX_SEED = 2 ** 32 - 1


def _format_table(rows: list[list[str]], header: list[str]) -> str:
    widths = [max(len(str(r[i])) for r in rows + [header]) for i in range(len(header))]
    fmt = "  ".join(f"{{:{'<' if i == 0 else '>'}{w}}}" for i, w in enumerate(widths))
    lines = [fmt.format(*header), "  ".join("-" * w for w in widths)]
    lines += [fmt.format(*r) for r in rows]
    return "\n".join(lines)


@_command("beliefs")
def cmd_beliefs(args: argparse.Namespace) -> int:
    """Print the prior marginals of every object and task state (eq. 2, eq. 21)."""
    from fg_tea.beliefs.engine import BeliefEngine, entropy
    from fg_tea.model.spec import load_model
    from fg_tea.world.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    model = load_model(args.model)
    try:
        belief = BeliefEngine(scenario, model, backend=args.solver)
    except ValueError as exc:
        raise InputError(scenario.source or "<scenario>", "$.objects",
                         f"with model {model.name!r}: {exc}") from None
    locations = belief.locations()
    header = ["site (room)"] + [f"q(L[{o}])" for o in belief.objects]
    rows = [[f"{s.name} ({s.room})"] + [f"{locations[o][i]:.4f}" for o in belief.objects]
            for i, s in enumerate(scenario.sites)]
    rows.append(["entropy (nats)"] + [f"{entropy(locations[o]):.4f}" for o in belief.objects])
    print(f"scenario {scenario.name} · model {model.name} ({model.structure}) · backend {belief.backend}")
    print(_format_table(rows, header))
    print()
    print(_format_table([[s, f"{p:.4f}"] for s, p in sorted(belief.states().items())],
                        ["task state", "q(true)"]))
    print()
    print("most probable arrangement (gtsam max-product): " +
          ", ".join(f"{o} on {s}" for o, s in belief.map_estimate().items()))
    print(f"agreement with gtsam: max |difference| = {belief.check_against_gtsam():.2e}")
    return 0


def file_kind(path: Path, data: object | None) -> str:
    """Which kind of input file this is: ``model``, ``scenario``, ``task`` or ``world``.

    TOML files are models. A JSON file is recognised by its content: a world distribution has
    ``placement`` or ``base_scenario``, a task has ``actions``, a scenario has ``schema_version``
    or ``house``; otherwise a file under a ``tasks`` folder is a task, else a scenario.
    """
    if path.suffix == ".toml":
        return "model"
    if isinstance(data, dict):
        if "placement" in data or "base_scenario" in data:
            return "world"
        if "actions" in data or "declares_states" in data:
            return "task"
        if "schema_version" in data or "house" in data:
            return "scenario"
    if "tasks" in path.parts:
        return "task"
    if "worlds" in path.parts:
        return "world"
    return "scenario"


def check_scenario(scenario, model) -> None:
    """Every check a run makes before its first step, without a simulator.

    Builds the occupancy grid and :class:`~fg_tea.world.navigation.Navigator` (vantage points on
    free floor and reachable from the start) and the exact belief (state and joint-size limits).

    Raises:
        InputError: naming the scenario file (or the model's, for a joint too large).
    """
    from fg_tea.beliefs.engine import BeliefEngine
    from fg_tea.episode.runner import env_config_for
    from fg_tea.world.navigation import Navigator

    Navigator(scenario, env_config_for(model))
    try:
        BeliefEngine(scenario, model)
    except ValueError as exc:
        raise InputError(scenario.source or "<scenario>", "$.objects",
                         f"with model {model.name!r}: {exc}") from None


@_command("validate")
def cmd_validate(args: argparse.Namespace) -> int:
    """Check scenario (.json), model (.toml), task and world files; print one line per file.

    Each file gets every check a run would make: a scenario is also laid out on the occupancy
    grid with the navigator and given an exact belief under ``--model``; a task is checked
    against ``--scenario`` (itself given the scenario checks) and ``--model``; a world distribution's base scenario is checked and
    one world is drawn.
    """
    from fg_tea.common.inputs import read_json
    from fg_tea.model.spec import load_model, parse_model
    from fg_tea.world.scenario import load_scenario, parse_scenario

    for path in [p for name in args.files for p in _validate_targets(name)]:
        data = None if path.suffix == ".toml" else read_json(path)
        kind = file_kind(path, data)
        if kind == "model":
            load_model(path)
        elif kind == "task":
            from fg_tea.tasks.load import parse_task

            scenario = load_scenario(args.scenario or _scenario_for_task(data))
            model = load_model(args.model)
            check_scenario(scenario, model)  # as `run` does before loading its task
            parse_task(data, model, scenario, file=path)
        elif kind == "world":
            from fg_tea.world.distributions import parse_world

            world = parse_world(data, path)
            check_scenario(world.base if world.base is not None else world.house(0),
                           load_model(args.model))
            try:  # a sample moves objects and truths only: the checks above still hold for it
                world.sample(0)
            except ValueError as exc:
                raise InputError(path, "$.placement", f"drawing world 0 failed: {exc}") from None
        else:
            scenario = parse_scenario(data, path)
            check_scenario(scenario, load_model(args.model))
        print(f"{path}: ok ({kind})")
    return 0


def _scenario_for_task(data: object) -> str:
    """The bundled scenario a task file is checked against when none is named: the default
    apartment, or the first bundled scenario holding every object the task's actions name."""
    from fg_tea.common.resources import bundled
    from fg_tea.world.scenario import load_scenario

    names = set()
    if isinstance(data, dict) and isinstance(data.get("actions"), list):
        for action in data["actions"]:
            if isinstance(action, dict):
                names |= {v for k, v in action.items() if k in ("object", "destination")
                          and isinstance(v, str)}
    for candidate in [DEFAULT_SCENARIO] + [p.stem for p in bundled("scenarios", ".json")]:
        try:
            if names <= set(load_scenario(candidate).object_names):
                return candidate
        except InputError:
            continue
    return DEFAULT_SCENARIO


# ------------------------------------------------------------------------------ episodes
def _video_options(args: argparse.Namespace):
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


def _failure_rates(pairs: list[str]) -> dict[str, float]:
    from fg_tea.world.interface import VERBS

    actions = [v for v in VERBS if v not in OBSERVING_VERBS]
    rates = {}
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
        rates[verb.upper()] = rate
    return rates


def safe_name(name: str) -> str:
    """`name` as one file name that stays inside its folder (no separators, no leading dots)."""
    import re

    cleaned = re.sub(r"[^A-Za-z0-9._#+=-]+", "_", name).lstrip(".")[:120]
    return cleaned or "unnamed"


def _check_out_dir(path: Path, flag: str = "--out") -> Path:
    """Create the output folder `path` (and parents), or fail with one line saying why not."""
    if path.exists() and not path.is_dir():
        raise InputError("<command line>", flag, f"{path} exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError("<command line>", flag, f"cannot create folder {path}: "
                         f"{exc.strerror or exc}") from None
    import tempfile

    try:  # the only sure test of writability (root, read-only mounts, /proc)
        with tempfile.NamedTemporaryFile(dir=path, prefix=".fg-tea-probe-"):
            pass
    except OSError as exc:
        raise InputError("<command line>", flag, f"cannot write into folder {path}: "
                         f"{exc.strerror or exc}") from None
    return path


def _check_out_file(path: Path, flag: str = "--out") -> Path:
    """Check that the output file `path` can be written (atomically, beside itself)."""
    if path.is_dir():
        raise InputError("<command line>", flag, f"{path} is a folder; name a file")
    if path.exists() and not path.is_file():
        raise InputError("<command line>", flag, f"{path} is not a regular file (a device or FIFO)")
    _check_out_dir(path.parent if str(path.parent) else Path("."), flag)
    return path


def _remove_outputs(out: Path, names: Sequence[str]) -> None:
    """Remove the files a previous run of the same kind left in `out`, so no mix remains."""
    for name in names:
        target = out / name
        if target.is_dir() and not target.is_symlink():
            raise InputError("<command line>", "--out", f"{target} is a folder; it would be "
                             "overwritten by this run's file")
        try:
            target.unlink(missing_ok=True)
        except OSError as exc:
            raise InputError("<command line>", "--out", f"cannot replace {target}: "
                             f"{exc.strerror or exc}") from None


class _Progress:
    """A one-line progress display on a terminal; silent otherwise."""

    def __init__(self, max_frames: int, stream=None) -> None:
        self.stream = stream or sys.stderr
        self.max_frames = max_frames
        self.tty = self.stream.isatty()

    def __call__(self, runner) -> None:
        if not self.tty:
            return
        frame = runner.state.frame
        width = 24
        done = min(int(width * frame / max(self.max_frames, 1) * 10), width)  # a tenth of the cap fills it
        active = [n for n in runner.graph if runner.graph.status(n) == "active"]
        finished = sum(runner.graph.is_finished(n) for n in runner.graph)
        self.stream.write(f"\r[{'#' * done}{'.' * (width - done)}] frame {frame:6d} · "
                          f"{finished}/{len(runner.graph)} actions · {(active or ['-'])[0]:<22}")
        self.stream.flush()

    def close(self) -> None:
        if self.tty:
            self.stream.write("\n")


def _frames_progress(stream=None):
    """Report video rendering: a live line on a terminal, a line per 25 % otherwise."""
    import time

    stream = stream or sys.stderr
    start, last_quarter = time.perf_counter(), [-1]

    def report(done: int, total: int) -> None:
        rate = done / max(time.perf_counter() - start, 1e-9)
        line = f"rendering video: {done}/{total} frames ({rate:.1f} frames/s)"
        if stream.isatty():
            stream.write("\r" + line + ("\n" if done >= total else ""))
        elif done * 4 // max(total, 1) > last_quarter[0]:
            last_quarter[0] = done * 4 // max(total, 1)
            stream.write(line + "\n")
        stream.flush()

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
                at = e.get("found_at", {}).get(obj, e["site"])
                glance = e.get("viewpoint_kind") == "room"
                sites[obj] = f"{at} (from the {e['site']} glance)" if glance else at
    for obj, n in sorted(m["inspections_until_resolved"].items(), key=lambda kv: kv[1] or 10 ** 9):
        found.append(f"the {obj} on {sites[obj]} after {n} inspection{'s' * (n != 1)}"
                     if n is not None else f"never the {obj}")
    skipped = ", ".join(m["skipped_actions"]) or "none"
    end = "The task is complete" if m["success"] else f"The episode ended without finishing ({m['reason']})"
    return (f"Found {', '.join(found)} ({m['inspections']} inspections, {m['repeated_sites']} "
            f"repeated, {m['total_distance']:.1f} m travelled, {m['state_readings']} state readings, "
            f"{m['failures']} failed actions). Skipped actions: {skipped}. {end}: "
            f"{m['actions_complete']} of {m['actions_total']} actions complete and "
            f"{m['actions_skipped']} skipped, in {m['frames']} frames.")


def planner_size_fault(planner: str, scenario, graph, model=None) -> str | None:
    """Why `planner` cannot plan in this house for this task graph (too large), or None.

    The Bayes-optimal planner has a size limit (docs/design.md §6.5): its first decision plans
    over every site for every object the task searches for. The lookahead planner has one for
    correlated beliefs only (§6.6: it holds their exact joint), so it is checked when `model` is
    given; POUCT and POMCP hold the table of truths for every model (§6.7).
    """
    objects = {graph.action(n).object for n in graph.search_nodes()}
    if planner == "optimal":
        from fg_tea.planning.optimal import size_fault

        fault = size_fault(len(scenario.sites), len(objects))
        return None if fault is None else (f"the Bayes-optimal planner refuses this house: {fault}; "
                                           "use another planner")
    if model is not None and (planner == "lookahead" or planner.startswith("lookahead:")):
        from fg_tea.beliefs.engine import BeliefEngine
        from fg_tea.planning.lookahead import size_fault as lookahead_fault

        fault = lookahead_fault(len(scenario.sites), len(objects),
                                BeliefEngine(scenario, model).correlated)
        return None if fault is None else (f"the lookahead planner refuses this house: {fault}; "
                                           "use a factorised model or another planner")
    kind, _, budget = planner.partition(":")
    if kind in ("pouct", "pomcp") and budget.isdigit():
        from fg_tea.planning.lookahead import MAX_TRUTHS

        n, k = len(objects), len(scenario.sites)
        if k ** n > MAX_TRUTHS:  # the peers hold the table of truths for every model (§6.7)
            return (f"the {kind} planner refuses this house: {n} objects over {k} sites give "
                    f"{k ** n:,} truths, more than the limit of {MAX_TRUTHS:,}; use another planner")
    return None


#: Every file `fg-tea run` writes into its output folder (stale ones are removed first).
RUN_OUTPUTS = ("episode.jsonl", "episode.mp4", "timings.json")
#: Files `compare` writes besides episodes.csv (fg_tea.study.analysis.comparison_report).
COMPARE_REPORT_OUTPUTS = ("summary.md", "summary.csv", "paired.csv", "ratio_to_optimal.png",
                          "travel_inspections.png", "entropy.png")


@_command("run")
def cmd_run(args: argparse.Namespace) -> int:
    """Run one episode in the PyBullet house; write its log, and its video unless --no-video."""
    import json
    import time

    from fg_tea.env.house import PyBulletHouse
    from fg_tea.episode.log import EventLog
    from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
    from fg_tea.model.spec import load_model
    from fg_tea.world.scenario import load_scenario

    t0 = time.perf_counter()
    scenario = load_scenario(args.scenario)
    model = load_model(args.model)
    options = None if args.no_video else _video_options(args)
    if args.preparation_site is not None and args.preparation_site not in scenario.site_names:
        raise InputError(scenario.source, "$.sites", f"--preparation-site {args.preparation_site!r} "
                         "is not a site of this scenario")
    rates = _failure_rates(args.failure_rate)
    from fg_tea.tasks.load import load_task

    check_scenario(scenario, model)
    graph = load_task(args.task, model, scenario, args.preparation_site)
    fault = planner_size_fault(args.planner, scenario, graph, model)
    if fault is not None:  # refused before any log is written
        raise InputError(scenario.source or scenario.name, f"--planner {args.planner}", fault)
    out = Path(args.out) if args.out else \
        Path("runs") / safe_name(f"{scenario.name}-{model.name}-seed{args.seed}")
    _check_out_dir(out)
    _remove_outputs(out, RUN_OUTPUTS)
    config = RunConfig(seed=args.seed, planner=args.planner, task=args.task,
                       preparation_site=args.preparation_site, max_frames=args.max_frames,
                       belief_backend=args.solver)
    env = PyBulletHouse(scenario, env_config_for(model, failure_rates=rates,
                                                 min_visible_pixels=args.min_visible_pixels
                                                 if args.min_visible_pixels is not None
                                                 else model.min_visible_pixels))
    log_path = out / "episode.jsonl"
    progress = _Progress(args.max_frames)
    t1 = time.perf_counter()
    try:
        with EventLog(log_path) as log:
            runner = EpisodeRunner(scenario, model, env, config, log, render=options)
            runner.run(progress)
    finally:
        progress.close()
        env.close()
    t2 = time.perf_counter()
    print(summary(runner.events))
    print(f"log: {log_path}")
    timings = {"load_s": t1 - t0, "episode_s": t2 - t1}
    if options is not None:
        from fg_tea.render.video import render_video

        result = render_video(runner.events, out / "episode.mp4", options, _frames_progress())
        timings["video_s"] = time.perf_counter() - t2
        timings["video_frames"] = result["frames"]
        print(f"video: {result['path']} ({result['frames']} frames, "
              f"{result['frames'] / max(timings['video_s'], 1e-9):.1f} frames/s rendered)")
    atomic_write_text(out / "timings.json", json.dumps(timings, indent=2) + "\n")
    return 0 if runner.reason == "complete" else 1


@_command("render")
def cmd_render(args: argparse.Namespace) -> int:
    """Re-render the video of a logged episode, without re-running the agent."""
    from fg_tea.episode.log import read_log
    from fg_tea.render.video import render_video

    path = Path(args.log)
    events = read_log(path)
    if not any(e.get("event") == "episode_start" for e in events):
        raise InputError(path, "$", "not an fg_tea episode log (no episode_start event)")
    out = _check_out_file(Path(args.out) if args.out else path.with_suffix(".mp4"))
    options = _video_options(args)
    try:
        from fg_tea.render.video import plan_frames

        plan_frames(events, options)
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
        raise InputError(path, "$", f"not a complete fg_tea episode log ({type(exc).__name__}: "
                         f"{str(exc)[:80]})") from None
    result = render_video(events, out, options, _frames_progress())
    print(f"video: {result['path']} ({result['frames']} frames)")
    return 0


@_command("preview")
def cmd_preview(args: argparse.Namespace) -> int:
    """Write a PNG of the chase camera with the first-person inset at the start pose, and a
    top-down floor plan of the house beside it (``<out stem>_plan.png``)."""
    import cv2

    from fg_tea.env.house import PyBulletHouse
    from fg_tea.episode.runner import env_config_for
    from fg_tea.model.spec import load_model
    from fg_tea.render.floorplan import MiniMap, write_floor_plan
    from fg_tea.render.overlay import OverlayState
    from fg_tea.render.video import _compose
    from fg_tea.world.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    options = _video_options(args)
    model = load_model(args.model)
    check_scenario(scenario, model)
    out = _check_out_file(Path(args.out) if args.out else Path(f"{safe_name(scenario.name)}-preview.png"))
    plan_out = _check_out_file(out.with_name(f"{out.stem}_plan.png"))
    config = env_config_for(model)
    house = PyBulletHouse(scenario, config)
    try:
        pose = house.reset(args.seed)
        overlay = OverlayState(phase="preview", caption=f"{scenario.name}: start pose "
                               f"({pose.x:.2f}, {pose.y:.2f}, {pose.yaw_deg:.0f} deg)")
        frame = _compose(house, options, (pose, house.placements(), None), overlay,
                         MiniMap(scenario, config.ego_hfov_deg), {s.name: s.position for s in scenario.sites})
    finally:
        house.close()
    with atomic_path(out, ".png") as tmp:
        cv2.imwrite(str(tmp), frame[:, :, ::-1])
    write_floor_plan(scenario, plan_out)
    print(f"preview: {out}")
    print(f"floor plan: {plan_out}")
    return 0


def _add_video_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("video (defaults: docs/design.md §8.6)")
    g.add_argument("--view", choices=("multi", "first", "third"), default="multi",
                   help="chase view with first-person inset, or either alone (default: %(default)s)")
    g.add_argument("--width", type=_integer(64, 7680), default=960, help="output width in pixels (default: %(default)s)")
    g.add_argument("--height", type=_integer(64, 4320), default=540, help="output height in pixels (default: %(default)s)")
    g.add_argument("--fps", type=_integer(1, 240), default=30, help="output frame rate (default: %(default)s)")
    g.add_argument("--scene-scale", type=_number(0.1, 1.0), default=2 / 3,
                   help="render the 3D views at this fraction of the output size (default: 0.667)")
    g.add_argument("--inset-scale", type=_number(0.05, 0.6), default=0.3, help="inset width / frame width")
    g.add_argument("--third-person-distance", type=_number(0.0, 50.0), default=3.2, help="metres behind the agent")
    g.add_argument("--third-person-height", type=_number(-50.0, 50.0), default=2.2, help="camera height, metres")
    g.add_argument("--third-person-pitch", type=_number(-90.0, 90.0), default=-22.0, help="camera pitch, degrees")
    g.add_argument("--third-person-hfov", type=_number(1.0, 179.0), default=78.0, help="horizontal field of view, degrees")
    g.add_argument("--hold", type=_number(0.0, 60.0), default=0.8, help="seconds to hold decision frames")
    g.add_argument("--wall-cutaway", type=_number(0.0, 100.0), default=1.0,
                   help="chase view: draw walls up to this height in metres (default: %(default)s)")
    g.add_argument("--full-walls", action="store_true", help="chase view: draw walls at full height")
    g.add_argument("--frame-stride", type=_integer(1, 10_000), default=1,
                   help="render every n-th frame of motion, for quick drafts (default: %(default)s)")
    g.add_argument("--workers", type=_integer(0, 1024), default=0, help="rendering processes (0: one per core)")
    g.add_argument("--no-overlays", action="store_true", help="camera images only")


def _planner_name(text: str) -> str:
    """An argparse type: a built-in planner, an entry-point planner or ``module:attribute``."""
    from fg_tea.planning.plugins import PlannerSpecError, check

    try:
        check(text)
    except PlannerSpecError as exc:
        raise argparse.ArgumentTypeError(exc.fault) from None
    return text


def _add_run_parsers(sub) -> None:
    p = sub.add_parser("run", help="run a make-tea episode in the PyBullet house (log + video)")
    p.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO,
                   help="scenario file or bundled name (default: %(default)s)")
    p.add_argument("--model", default=DEFAULT_MODEL, help=MODEL_HELP)
    p.add_argument("--seed", type=_integer(0, MAX_SEED), default=0, help="episode seed (default: %(default)s)")
    p.add_argument("--out", help="output folder (default: runs/SCENARIO-MODEL-seedN)")
    p.add_argument("--no-video", action="store_true", help="headless: write the log only")
    p.add_argument("--max-frames", type=_integer(1, 10_000_000), default=50_000, help="frame limit (default: %(default)s)")
    p.add_argument("--planner", default="efe", type=_planner_name,
                   help="search planner: efe, factorised_efe, mi_efe, nearest, greedy, random, optimal, "
                   "lookahead (or lookahead:depth=2,width=3,...), pouct:N and pomcp:N (with the [peers] "
                   "extra), "
                   "a name registered in the fg_tea.planners entry-point group, or "
                   "module:attribute for a planner of your own (default: %(default)s)")
    p.add_argument("--task", default="make_tea", help="task file or bundled name (default: %(default)s)")
    p.add_argument("--preparation-site", help="site where the tea is made (default: the scenario's)")
    _add_solver_argument(p)
    p.add_argument("--min-visible-pixels", type=_integer(1, 10_000_000), default=None,
                   help="detection threshold (default: the model's, 25)")
    p.add_argument("--failure-rate", action="append", default=[], metavar="VERB=P",
                   help="inject seeded failures, e.g. FILL=0.3 (repeatable)")
    _add_video_options(p)

    p = sub.add_parser("render", help="re-render the video of a logged episode")
    p.add_argument("log", help="an episode.jsonl written by fg-tea run")
    p.add_argument("--out", help="output MP4 (default: the log's name with .mp4)")
    _add_video_options(p)

    p = sub.add_parser("preview", help="write a PNG of the cameras at the start pose and a PNG of the "
                       "floor plan (sites, vantages, room vantages, true object sites)",
                       description="Write two PNGs: the chase camera with the first-person inset at "
                       "the start pose (OUT), and a top-down floor plan beside it (OUT's stem + "
                       "'_plan.png'): walls and doorways, furniture, every site numbered and named, "
                       "where the agent stands to look at each site (its number), room vantages, "
                       "room names, the start pose and, in red, each object's true site (for "
                       "checking a house; the agent never sees it).")
    p.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO,
                   help="scenario file or bundled name (default: %(default)s)")
    p.add_argument("--model", default=DEFAULT_MODEL, help=MODEL_HELP)
    p.add_argument("--seed", type=_integer(0, MAX_SEED), default=0,
                   help="seed of the start pose and world (default: %(default)s)")
    p.add_argument("--out", help="output PNG (default: SCENARIO-preview.png; the floor plan goes to "
                   "SCENARIO-preview_plan.png)")
    _add_video_options(p)


# ------------------------------------------------------------ compare (docs/design.md §11)
#: Planners of the full comparison, and of --quick.
COMPARE_PLANNERS = ("efe", "factorised_efe", "nearest", "greedy", "random", "optimal")
COMPARE_QUICK_PLANNERS = ("efe", "greedy", "nearest", "optimal")


@_command("compare")
def cmd_compare(args: argparse.Namespace) -> int:
    """Models x planners over N sampled worlds, paired; write episodes.csv, summary.md and plots."""
    import os
    import shlex

    from fg_tea.study.analysis import comparison_report
    from fg_tea.study.sweep import SweepError, plan_sweep, run_sweep

    if args.workers < 0:
        raise InputError("<command line>", "--workers", f"expected 0 (every core) or more, got {args.workers}")
    if args.lifelong is not None:
        return _compare_lifelong(args)
    if args.forgetting is not None:
        raise InputError("<command line>", "--forgetting", "applies only with --lifelong K")
    n_worlds = args.worlds if args.worlds is not None else (10 if args.quick else 200)
    planners = args.planners or list(COMPARE_QUICK_PLANNERS if args.quick else COMPARE_PLANNERS)
    out = Path(args.out) if args.out else Path("runs") / safe_name(f"compare-{Path(args.world).stem}")
    from fg_tea.model.spec import load_model
    from fg_tea.study.sweep import check_jobs, model_path, world_path
    from fg_tea.tasks.load import load_task
    from fg_tea.world.distributions import load_world

    check_jobs(plan_sweep([args.world], 1, args.models, planners, first_seed=args.first_seed,
                          env=args.env))  # unknown worlds, models and planners are named first
    world = load_world(world_path(args.world))
    base = world.base if world.base is not None else world.house(args.first_seed)
    if "optimal" in planners:  # the Bayes-optimal DP's size limit, checked before any episode
        graph = load_task("make_tea", load_model(model_path(args.models[0])), base)
        fault = planner_size_fault("optimal", base, graph)
        if fault is not None and args.planners:
            where = "its houses" if world.generate is not None else "its house"
            raise InputError(world.source or args.world, "--planners optimal",
                             f"{fault} ({where}: {base.name}, world seed {args.first_seed})")
        if fault is not None:
            planners = [p for p in planners if p != "optimal"]
            sys.stderr.write(f"compare: planner optimal left out of the default planners: "
                             f"{fault.split(': ', 1)[-1].split('; ')[0]} in {base.name}\n")
    _check_out_dir(out)
    jobs = plan_sweep([args.world], n_worlds, args.models, planners, first_seed=args.first_seed,
                      env=args.env)
    if args.env == "pybullet":  # the house checks each episode would make, once, before any starts
        check_jobs(jobs)
        for ref in args.models:
            check_scenario(base, load_model(model_path(ref)))
    csv_path = out / "episodes.csv"
    # The report is rebuilt from this sweep's rows: no summary or plot of an earlier sweep with
    # other planners or models stays beside it (episodes.csv is the resumable record).
    _remove_outputs(out, COMPARE_REPORT_OUTPUTS)
    try:
        rows = run_sweep(jobs, csv_path, args.executor, workers=args.workers or None,
                         address=args.address, resume=args.resume, label="compare")
    except SweepError as exc:
        sys.stderr.write(f"fg-tea: error: {exc} (finished episodes are in {csv_path}; "
                         "run again to resume)\n")
        return 1
    shown = os.path.relpath(out) if not os.path.relpath(out).startswith("..") else str(out)
    command = shlex.join(["fg-tea", "compare", "--world", args.world, "--worlds", str(n_worlds),
                          "--models", *args.models, "--planners", *planners, "--first-seed",
                          str(args.first_seed), "--env", args.env, "--out", shown])
    files = comparison_report(rows, out, title=f"Factorised vs joint beliefs on `{args.world}` worlds",
                              command=command)
    print(f"episodes: {csv_path} ({len(rows)} rows)")
    print("wrote: " + ", ".join(str(files[name]) for name in sorted(files)))
    return 0


def _compare_lifelong(args: argparse.Namespace) -> int:
    """``compare --lifelong K``: K consecutive episodes per household, episode k with the model
    learned from that household's episodes before k, beside the hand-set model (and, for joint
    models, learned co-location weights), on the same placements (docs/design.md §12)."""
    import os
    import shlex

    from fg_tea.model.spec import load_model
    from fg_tea.study.households import (
        SEED_STRIDE,
        HouseholdSpec,
        relation_pairs,
        run_lifelong,
        write_outputs,
    )
    from fg_tea.study.sweep import check_jobs, model_path, plan_sweep, world_path
    from fg_tea.world.distributions import load_world

    k = args.lifelong
    households = args.worlds if args.worlds is not None else (10 if args.quick else 30)
    if households < 1:
        raise InputError("<command line>", "--worlds", f"expected at least 1 household, got {households}")
    if (args.first_seed + households) * SEED_STRIDE > MAX_SEED:
        raise InputError("<command line>", "--first-seed", "households x 1000 exceed the largest seed")
    if args.forgetting is not None and not 0.0 < args.forgetting <= 1.0:
        raise InputError("<command line>", "--forgetting", f"expected a value in (0, 1], got {args.forgetting}")
    planners = args.planners or ["efe"]
    if len(planners) != 1:
        raise InputError("<command line>", "--planners", "--lifelong runs one planner; name one")
    if args.executor == "ray":
        raise InputError("<command line>", "--executor", "--lifelong runs serial or process; not ray")
    check_jobs(plan_sweep([args.world], 1, args.models, planners, first_seed=args.first_seed,
                          env=args.env))  # unknown worlds, models, planners named first
    world = load_world(world_path(args.world))
    models = [load_model(model_path(m)) for m in args.models]
    base = world.base if world.base is not None else world.house(args.first_seed)
    if planners[0] == "optimal":  # the Bayes-optimal DP's size limit, before any episode
        from fg_tea.tasks.load import load_task

        fault = planner_size_fault("optimal", base, load_task("make_tea", models[0], base))
        if fault is not None:
            raise InputError(world.source or args.world, "--planners optimal", f"{fault} ({base.name})")
    if args.env == "pybullet":
        for m in models:
            check_scenario(base, m)
    out = Path(args.out) if args.out else Path("runs") / safe_name(f"compare-lifelong-{Path(args.world).stem}")
    _check_out_dir(out)
    from fg_tea.study.households import OUTPUTS

    _remove_outputs(out, OUTPUTS)
    pairs = relation_pairs(models)
    specs = [HouseholdSpec(str(world_path(args.world)), False, str(model_path(ref)), h, k, args.env,
                           planners[0], (args.forgetting,), None, "mug", pairs)
             for ref in args.models for h in range(args.first_seed, args.first_seed + households)]
    workers = 1 if args.executor == "serial" else (args.workers or os.cpu_count() or 1)
    rows = run_lifelong(specs, workers)
    shown = os.path.relpath(out) if not os.path.relpath(out).startswith("..") else str(out)
    command = shlex.join(["fg-tea", "compare", "--lifelong", str(k), "--world", args.world,
                          "--worlds", str(households), "--models", *args.models, "--planners",
                          *planners, "--first-seed", str(args.first_seed), "--env", args.env,
                          *(["--forgetting", str(args.forgetting)] if args.forgetting is not None else []),
                          "--out", shown])
    files = write_outputs(rows, out, f"Lifelong learning on `{args.world}`: {households} households "
                          f"x {k} episodes, {args.env} house", command)
    print(f"episodes: {files['episodes']} ({len(rows)} rows)")
    print("wrote: " + ", ".join(str(files[n]) for n in ("curves", "summary", "plot")))
    return 0


def _add_compare_parser(sub) -> None:
    from fg_tea.study.sweep import add_execution_arguments

    p = sub.add_parser("compare", help="compare models and planners over many sampled worlds (paired)",
                       description="Run every model with every planner on the same N sampled worlds "
                       "(headless), then write OUT/episodes.csv (one row per episode), OUT/summary.md "
                       "(means, 95% CIs, paired differences, ratio to the Bayes-optimal planner, "
                       "ablations when other models are given) and PNG plots. Episodes already in "
                       "OUT/episodes.csv are not run again (--no-resume starts afresh).")
    p.add_argument("--worlds", type=int, default=None, help="number of worlds (default: 200; 10 with --quick)")
    p.add_argument("--world", default="correlated",
                   help="world distribution, bundled name or JSON file (default: %(default)s)")
    p.add_argument("--first-seed", type=_integer(0, MAX_SEED), default=0, help="first world seed (default: %(default)s)")
    p.add_argument("--models", nargs="+", default=["factorised", "joint"],
                   help="models: bundled names, bundled ablations or files (default: factorised joint)")
    p.add_argument("--planners", nargs="+", type=_planner_name, default=None,
                   help="planners: built-in names, names registered in the fg_tea.planners "
                   "entry-point group, or module:attribute for planners of your own "
                   f"(default: {' '.join(COMPARE_PLANNERS)}; "
                   f"with --quick: {' '.join(COMPARE_QUICK_PLANNERS)})")
    add_execution_arguments(p, "episodes.csv")
    p.add_argument("--out", help="output folder (default: runs/compare-WORLD)")
    p.add_argument("--quick", action="store_true",
                   help=f"10 worlds and planners {' '.join(COMPARE_QUICK_PLANNERS)} (CI size)")
    p.add_argument("--lifelong", type=_integer(1, 1000), default=None, metavar="K",
                   help="lifelong learning curves (docs/design.md §12): K consecutive episodes per "
                   "household (--worlds households, default 30; 10 with --quick), episode k with "
                   "the model learned from the household's episodes before k, beside the hand-set "
                   "model on the same placements; one planner (default efe); episodes are run afresh "
                   "(--resume does not apply)")
    p.add_argument("--forgetting", type=float, default=None, metavar="GAMMA",
                   help="with --lifelong: forgetting factor gamma in (0, 1] of the learned arms "
                   "(default 1: never forget)")
# ------------------------------------------------------------------------------ end compare


# ------------------------------------------------------------------------------ house generator
@_command("house")
def cmd_house(args: argparse.Namespace) -> int:
    """Generate a house scenario (rooms, furniture sites, room vantages, priors, objects)."""
    from fg_tea.world.housegen import check_arguments, write_house

    objects = [o.strip() for o in args.objects.split(",") if o.strip()]
    try:
        objects = list(check_arguments(args.rooms, args.seed, objects))
    except ValueError as exc:
        field, _, fault = str(exc).partition(": ")
        raise InputError("<command line>", f"--{field}", fault) from None
    out = Path(args.out)
    if out.is_dir() or not out.name:
        raise InputError(out, "$", "is a folder; expected a scenario file name")
    try:
        doc = write_house(out, args.rooms, args.seed, objects, args.name)
    except OSError as exc:
        raise InputError(out, "$", f"cannot write the scenario: {exc.strerror or exc}") from None
    print(f"house: {out} ({args.rooms} rooms, {len(doc['sites'])} sites, "
          f"{len(doc['room_vantages'])} room vantages, objects {', '.join(objects)})")
    return 0


def _add_house_parser(sub) -> None:
    p = sub.add_parser("house", help="generate a house scenario JSON from a seed",
                       description="Write a schema-2 scenario of a generated house: N rectangular "
                       "rooms joined by doorways (the first a kitchen), furniture along the walls "
                       "whose tops are semantic sites, room vantages, affordance priors by room and "
                       "furniture type, and objects placed from those priors. Same arguments, same "
                       "bytes.")
    p.add_argument("--rooms", type=int, required=True, help="number of rooms, 3 to 10")
    p.add_argument("--seed", type=int, default=0, help="non-negative seed (default: %(default)s)")
    p.add_argument("--out", required=True, help="output scenario JSON")
    p.add_argument("--objects", default="mug,kettle,teabag",
                   help="comma-separated objects among mug, kettle, teabag, milk, sugar "
                   "(default: %(default)s)")
    p.add_argument("--name", help="scenario name (default: generated_<rooms>r_seed<seed>)")
# ------------------------------------------------------------------------------ end house generator


# ------------------------------------------------------------------------------ learning
@_command("learn")
def cmd_learn(args: argparse.Namespace) -> int:
    """Write a model that extends a base model and holds the counts learned from logs
    (docs/design.md §12)."""
    from fg_tea.study.learn import learn_files, summary

    out, learning = learn_files(args.logs, args.base, args.out, name=args.name,
                                forgetting=args.forgetting, prior_strength=args.prior_strength)
    info = summary(learning)
    where = _shares(info["sites"]) or "no objects found"
    together = _shares({pair: {k.replace("_", " "): v for k, v in shares.items()}
                        for pair, shares in info["co_location"].items() if shares})
    print(f"learned: {out} ({len(args.logs)} new log(s), {info['sources']} in all; found at: {where}"
          + (f"; kept together: {together}" if together else "") + ")")
    return 0


def _shares(groups: dict[str, dict[str, float]]) -> str:
    """``group: key share, ...; group: ...`` with shares to two decimals."""
    return "; ".join(f"{g}: " + ", ".join(f"{k} {v:.2f}" for k, v in shares.items())
                     for g, shares in groups.items())


def _add_learn_parser(sub) -> None:
    p = sub.add_parser("learn", help="learn site priors, co-location, detector and sensor reliability from logs",
                       description="Count, from episode logs and only from what the agent observed, "
                       "where it found each object, which objects it found together (same site, same "
                       "room, apart), the looks that saw or missed an object at the site where it "
                       "stood, and state readings that other readings settled; write "
                       "a model file that extends --base and holds the counts (docs/design.md §12). "
                       "Learning from A then B (with the first result as --base) equals learning "
                       "from A and B at once.")
    p.add_argument("logs", nargs="*", metavar="LOG", help="episode.jsonl logs, counted in this order")
    p.add_argument("--base", default=DEFAULT_MODEL, help=MODEL_HELP.replace("model file", "base model file"))
    p.add_argument("--out", required=True, help="the learned model file to write (.toml)")
    p.add_argument("--name", default=None, help="the learned model's name (default: <base>_learned)")
    p.add_argument("--forgetting", type=float, default=None,
                   help="forgetting factor gamma in (0, 1]: held counts are multiplied by it before "
                   "each new log (default: the base's, else 1 = never forget)")
    p.add_argument("--prior-strength", type=float, default=None,
                   help="pseudo-count mass S of the declared location prior (default: the base's, "
                   "else 5)")
# ------------------------------------------------------------------------------ end learning


# ------------------------------------------------------------------------------ bundled names
MODEL_HELP = "model file, or bundled model or ablation name (default: %(default)s)"


def _add_solver_argument(p: argparse.ArgumentParser) -> None:
    """``--solver`` (the exact belief backend), with ``--backend`` as its deprecated alias."""
    p.add_argument("--solver", choices=("numpy", "gtsam"), default="numpy",
                   help="exact belief solver: closed forms and dense tables (numpy) or gtsam's "
                   "discrete elimination (default: %(default)s)")
    p.add_argument("--backend", dest="solver", choices=("numpy", "gtsam"), action=DeprecatedAlias,
                   new="--solver")


@_command("list")
def cmd_list(args: argparse.Namespace) -> int:
    """Print the bundled scenarios, models, ablations, tasks and world distributions."""
    from fg_tea.common.resources import KINDS, bundled, describe

    kinds = args.kind or list(KINDS)
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        raise InputError("<command line>", "list", f"unknown kind {unknown[0]!r}; expected one of "
                         f"{', '.join(KINDS)}")
    if args.paths:
        for kind in kinds:
            folder, suffix, _ = KINDS[kind]
            for path in bundled(folder, suffix):
                print(path)
        return 0
    for i, kind in enumerate(kinds):
        folder, suffix, what = KINDS[kind]
        files = bundled(folder, suffix)
        width = max((len(p.name) - len(suffix) for p in files), default=0)
        print(("\n" if i else "") + f"{kind} ({what}):")
        for path in files:
            description = describe(path)
            if not description and path.suffix == ".toml":  # a model may inherit its description
                from fg_tea.model.spec import load_model

                try:
                    description = load_model(path).description
                except InputError:
                    description = ""
            line = f"  {path.name[: -len(suffix)]:<{width}}  {_first_sentence(description)}".rstrip()
            print(line)
    return 0


def _first_sentence(text: str, limit: int = 100) -> str:
    """The first sentence of `text`, cut to `limit` characters with an ellipsis."""
    import re

    first = re.split(r"\.\s+(?=[A-Z])", text)[0]
    return first if len(first) <= limit else first[: limit - 3].rstrip() + "..."


def _add_list_parser(sub: Any) -> None:
    from fg_tea.common.resources import KINDS  # noqa: F811 - for the help text

    p = sub.add_parser("list", help="list the bundled scenarios, models, ablations, tasks and worlds",
                       description="Print every bundled file by kind, with its one-line description. "
                       "Every command accepts these names in place of a path.")
    p.add_argument("kind", nargs="*", metavar="KIND",  # checked in cmd_list: argparse rejects
                   help=f"kinds to list, among {', '.join(KINDS)} (default: all)")  # an empty list
    p.add_argument("--paths", action="store_true",
                   help="print the path of every bundled file instead, one per line (to copy or "
                   "pass to validate)")


def _validate_targets(name: str) -> list[Path]:
    """The files `name` stands for in ``fg-tea validate``: itself when it exists or looks like a
    path, else every bundled file of that name (a scenario and a world may share one)."""
    from fg_tea.common.resources import KINDS, bundled

    path = Path(name)
    try:
        exists = path.exists()
    except (OSError, ValueError):
        exists = False
    if exists or path.suffix or len(path.parts) != 1:
        return [path]
    found = [p for folder, suffix, _ in KINDS.values() for p in bundled(folder, suffix)
             if p.name == f"{name}{suffix}"]
    return found or [path]


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="fg-tea", description="A tea-making drone that reasons with exact beliefs.")
    from fg_tea._version import __version__

    parser.add_argument("--version", action="version", version=f"fg-tea {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser, metavar="COMMAND",
                                help="what to do (fg-tea COMMAND --help for its options)")

    p = sub.add_parser("beliefs", help="print the prior location and task-state beliefs of a scenario")
    p.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO,
                   help="scenario file or bundled name (default: %(default)s)")
    p.add_argument("--model", default=DEFAULT_MODEL, help=MODEL_HELP)
    _add_solver_argument(p)

    p = sub.add_parser("validate", help="check scenario, model, task and world files",
                       description="Check each file with every check a run makes before its first "
                       "step; print one line per file. The kind is recognised by content. A bundled "
                       "name (see fg-tea list) checks every bundled file of that name.")
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="scenario (.json), model (.toml), task or world file, or a bundled name")
    p.add_argument("--scenario", default=None,
                   help="scenario to check task files against (default: the default apartment, or "
                   "the first bundled scenario holding every object the task names)")
    p.add_argument("--model", default=DEFAULT_MODEL,
                   help="model to check scenario, task and world files against (default: %(default)s)")

    _add_list_parser(sub)

    _add_run_parsers(sub)
    _add_compare_parser(sub)  # docs/design.md §11
    _add_house_parser(sub)
    _add_learn_parser(sub)  # docs/design.md §12
    return parser


#: BLAS thread variables the command line sets to 1 unless the user set them (see main).
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def single_threaded_blas_defaults(environ=os.environ) -> list[str]:
    """Default the BLAS thread counts to 1, keeping any value the user set; returns the names set.

    The planner's matrix products are small (docs/design.md §6.2), and on a shared machine a
    multi-threaded BLAS mostly waits for busy cores: the joint gain's products were measured 40-70
    times slower under load with the default thread count. Only effective before numpy is
    imported, so :func:`main` calls it first; child processes (sweep workers) inherit it.
    """
    chosen = [v for v in BLAS_THREAD_VARIABLES if v not in environ]
    for v in chosen:
        environ[v] = "1"
    return chosen


def main(argv: Sequence[str] | None = None) -> int:
    single_threaded_blas_defaults()
    parser = build_parser()
    args = parser.parse_args(argv)
    notes = list(getattr(args, DeprecatedAlias.NOTES, []))  # written after the command, or
    if hasattr(args, DeprecatedAlias.NOTES):                 # folded into its one error line
        delattr(args, DeprecatedAlias.NOTES)
    try:
        status = COMMANDS[args.command](args)
        sys.stdout.flush()
        for note in notes:
            _error(note, prefix="fg-tea: note: ")
        return status
    except InputError as exc:
        _error(str(exc) + "".join(f" (note: {n})" for n in notes))
        return 2
    except BrokenPipeError:
        # The reader of our output went away (``fg-tea ... | head``): end quietly.
        _silence_stdout()
        return 141
    except OSError as exc:  # disk full, permissions, a vanished folder: one line, not a traceback
        where = exc.filename if exc.filename is not None else "<output>"
        _error(f"{where}: {exc.strerror or exc}")
        return 2
    except KeyboardInterrupt:
        _error("interrupted", prefix="fg-tea: ")
        return 130


def _error(message: str, prefix: str = "fg-tea: error: ") -> None:
    """Write one line to stderr; any character the terminal cannot show is escaped."""
    text = (prefix + message).replace("\n", " ").replace("\r", " ")
    try:
        sys.stderr.write(text.encode("utf-8", "backslashreplace").decode("utf-8") + "\n")
        sys.stderr.flush()
    except (OSError, ValueError):
        pass


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's exit flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass


if __name__ == "__main__":
    raise SystemExit(main())
