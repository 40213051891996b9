"""``fg-tea run``, ``render`` and ``preview``: one episode, its video, and a still of the house (docs/design.md §8-§9).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from fg_tea.cli.common import (
    CAMERA_HELP,
    EXIT_STATUS,
    HELD,
    MAX_SEED,
    MODEL_HELP,
    Failed,
    Progress,
    add_solver_argument,
    add_video_options,
    check_out_dir,
    check_out_file,
    check_scenario,
    command,
    failure_rates,
    frames_progress,
    integer,
    number,
    out_path,
    planner_name,
    planner_size_fault,
    plugin_planner,
    remove_outputs,
    safe_name,
    summary,
    video_options,
)
from fg_tea.common.errors import InputError, PlannerFault
from fg_tea.common.files import (
    atomic_write_text,
    write_png,
)
from fg_tea.common.resources import DEFAULT_MODEL, DEFAULT_SCENARIO

#: What `fg-tea run`'s exit status says (its --help epilog; docs/reference/cli.md shows it).
RUN_EXIT_STATUS = ("Exit status: 0 when the task is complete; 1 when the episode ended without "
                   "completing it: the frame limit (--max-frames) was reached, an object was not "
                   "found, or an action could not be carried out (the summary and the log's "
                   "episode_end say which; the log, timings and video are written all the same), "
                   "or a built-in planner failed (a fault of fg_tea, in one line); " + EXIT_STATUS + ".")
#: Every file `fg-tea run` writes into its output folder (stale ones are removed first).
RUN_OUTPUTS = ("episode.jsonl", "episode.mp4", "timings.json")


def default_run_folder(scenario, model, seed: int) -> Path:
    """``runs/SCENARIO-MODEL-seedN``. A model file that is not the bundled model of its name (a
    copy that kept ``name = "factorised"``) adds its file stem, or ``local`` when the stem is the
    name too, so that its runs never overwrite the bundled model's (docs/guide/commands.md)."""
    from fg_tea.common.resources import KINDS, bundled

    label = model.name
    files = {p.name[: -len(suffix)]: p for folder, suffix, _ in (KINDS["models"], KINDS["ablations"])
             for p in bundled(folder, suffix)}
    if model.name in files and model.source:
        own = Path(model.source)
        if not own.exists() or own.resolve() != files[model.name].resolve():
            stem = own.stem if own.suffix else safe_name(str(model.source))
            label = f"{model.name}-{stem if stem != model.name else 'local'}"
    return Path("runs") / safe_name(f"{scenario.name}-{label}-seed{seed}")


@command("run")
def cmd_run(args: argparse.Namespace) -> int:
    """Run one episode in the PyBullet house (or the fake house, ``--env fake``); write its log,
    and its video unless --no-video."""
    import json
    import time

    from fg_tea.episode.log import EventLog
    from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
    from fg_tea.model.spec import load_model
    from fg_tea.world.scenario import load_scenario

    t0 = time.perf_counter()
    scenario = load_scenario(args.scenario)
    model = load_model(args.model)
    options = None if args.no_video else video_options(args)
    if args.preparation_site is not None and args.preparation_site not in scenario.site_names:
        raise InputError(scenario.source, "$.sites", f"--preparation-site {args.preparation_site!r} "
                         "is not a site of this scenario")
    rates = failure_rates(args.failure_rate)
    pixels = {} if args.min_visible_pixels is None else {"min_visible_pixels": args.min_visible_pixels}
    steps = {"movement_step": args.movement_step, "turn_step_deg": args.turn_step}
    env_config = env_config_for(model, args.camera, failure_rates=rates, **pixels, **steps)
    from fg_tea.tasks.load import load_task

    check_scenario(scenario, model)
    graph = load_task(args.task, model, scenario, args.preparation_site)
    fault = planner_size_fault(args.planner, scenario, graph, model)
    if fault is not None:  # refused before any log is written
        raise InputError(scenario.source or scenario.name, f"--planner {args.planner}", fault)
    out = Path(args.out) if args.out else default_run_folder(scenario, model, args.seed)
    check_out_dir(out)
    remove_outputs(out, RUN_OUTPUTS)
    config = RunConfig(seed=args.seed, planner=args.planner, task=args.task,
                       preparation_site=args.preparation_site, max_frames=args.max_frames,
                       solver=args.solver)
    env = _environment(args.env, scenario, env_config)
    log_path = out / "episode.jsonl"
    progress = Progress(args.max_frames)
    t1 = time.perf_counter()
    try:
        with EventLog(log_path) as log:
            runner = EpisodeRunner(scenario, model, env, config, log, render=options)
            runner.run(progress)
    except PlannerFault as failed:  # the log is closed by an episode_end that says why
        if not plugin_planner(args.planner):  # fg_tea's own planner: not the user's input
            raise Failed(f"{failed} (the log {log_path} ends there)") from None
        raise InputError("<command line>", f"--planner {args.planner}",
                         f"{failed.what} (the log {log_path} ends there)") from None
    finally:
        progress.close()
        env.close()
    t2 = time.perf_counter()
    print(summary(runner.events))
    print(f"log: {log_path}")
    timings = {"load_s": t1 - t0, "episode_s": t2 - t1}
    if options is not None:
        from fg_tea.render.video import render_video

        result = render_video(runner.events, out / "episode.mp4", options, frames_progress())
        timings["video_s"] = time.perf_counter() - t2
        timings["video_frames"] = result["frames"]
        print(f"video: {result['path']} ({result['frames']} video frames: {HELD}; "
              f"{result['frames'] / max(timings['video_s'], 1e-9):.1f} frames/s rendered)")
    atomic_write_text(out / "timings.json", json.dumps(timings, indent=2) + "\n")
    return 0 if runner.reason == "complete" else 1


def _look_from(house, scenario, viewpoint: str):
    """Walk the house's agent to `viewpoint` and look as an inspection does; return the pose it
    looked from and a caption with the pixels of each object in view (printed too)."""
    result = house.inspect_viewpoint(viewpoint, scenario.object_names)
    if not result.reachable:
        raise InputError(scenario.source or scenario.name, "--site", f"{viewpoint!r} cannot be reached "
                         "from the start pose")
    pose = house.agent_pose()
    pixels = ", ".join(f"{name} {n:,} px{' (seen)' if result.detections.get(name) else ''}"
                       for name, n in result.pixel_counts.items() if n) or "no object in view"
    print(f"view from {viewpoint} ({result.kind}, sites {', '.join(result.sites)}): {pixels}")
    return pose, f"{scenario.name}: view from {viewpoint} ({pose.x:.2f}, {pose.y:.2f}, " \
                 f"{pose.yaw_deg:.0f} deg): {pixels}"


def _environment(kind: str, scenario, config):
    """The house an episode runs in: PyBullet's, or the fake house (no simulator; docs/design.md
    §9: the same motion, geodesic distances and seeded detections, without images)."""
    if kind == "fake":
        from fg_tea.env.fake import FakeHouse

        return FakeHouse(scenario, config)
    from fg_tea.env.house import PyBulletHouse

    return PyBulletHouse(scenario, config)


@command("render")
def cmd_render(args: argparse.Namespace) -> int:
    """Re-render the video of a logged episode, without re-running the agent."""
    from fg_tea.episode.log import read_log
    from fg_tea.render.video import render_video

    path = Path(args.log)
    events = read_log(path)
    if not any(e.get("event") == "episode_start" for e in events):
        raise InputError(path, "$", "not an fg_tea episode log (no episode_start event)")
    suffix = ".png" if args.still is not None else ".mp4"
    out = check_out_file(Path(args.out) if args.out else path.with_suffix(suffix))
    options = video_options(args)
    try:
        from fg_tea.render.video import plan_frames

        plan = plan_frames(events, options)
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
        raise InputError(path, "$", f"not a complete fg_tea episode log ({type(exc).__name__}: "
                         f"{str(exc)[:80]})") from None
    if args.still is not None:
        from fg_tea.render.video import render_still

        if args.still >= plan.output_frames:
            raise InputError("<command line>", "--still", f"frame {args.still} is not in the video "
                             f"(frames 0 to {plan.output_frames - 1})")
        result = render_still(events, out, args.still, options)
        print(f"still: {result['path']} (frame {result['frame']} of {result['frames']}: "
              f"{result['caption']})")
        return 0
    result = render_video(events, out, options, frames_progress())
    print(f"video: {result['path']} ({result['frames']} video frames: {HELD})")
    return 0


@command("preview")
def cmd_preview(args: argparse.Namespace) -> int:
    """Write a PNG of the chase camera with the first-person inset at the start pose, or with
    ``--site NAME`` at the pose the agent looks from at that site or room vantage (with the pixels
    of each object it sees), and a top-down floor plan of the house beside it
    (``<out stem>_plan.png``)."""
    from fg_tea.env.house import PyBulletHouse
    from fg_tea.episode.runner import env_config_for
    from fg_tea.model.spec import load_model
    from fg_tea.render.floorplan import MiniMap, write_floor_plan
    from fg_tea.render.overlay import OverlayState
    from fg_tea.render.compose import compose_frame
    from fg_tea.world.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    options = video_options(args)
    model = load_model(args.model)
    check_scenario(scenario, model)
    views = [v.name for v in scenario.viewpoints]
    if args.site is not None and args.site not in views:
        raise InputError("<command line>", "--site", f"{args.site!r} is not a site or room vantage of "
                         f"{scenario.name} (known: {', '.join(views)})")
    stem = f"{scenario.name}-preview" + (f"-{args.site}" if args.site else "")
    out = check_out_file(Path(args.out) if args.out else Path("runs") / f"{safe_name(stem)}.png")
    plan_out = check_out_file(out.with_name(f"{out.stem}_plan.png"))
    config = env_config_for(model, args.camera)
    house = PyBulletHouse(scenario, config)
    try:
        pose = house.reset(args.seed)
        caption = f"{scenario.name}: start pose ({pose.x:.2f}, {pose.y:.2f}, {pose.yaw_deg:.0f} deg)"
        if args.site is not None:
            pose, caption = _look_from(house, scenario, args.site)
        sequence = None
        if args.search:
            from fg_tea.cli.search_preview import search_sequence

            sequence = search_sequence(scenario, model, house, args.planner, args.task, args.seed, args.looks)
            pose = house.reset(args.seed)  # the picture shows the start (or --site) pose
            if args.site is not None:
                pose, caption = _look_from(house, scenario, args.site)
        overlay = OverlayState(phase="preview", caption=caption)
        frame = compose_frame(house, options, (pose, house.placements(), None), overlay,
                              MiniMap(scenario, config.ego_hfov_deg), {s.name: s.position for s in scenario.sites})
    finally:
        house.close()
    write_png(out, frame)
    write_floor_plan(scenario, plan_out)
    if sequence is not None:
        from fg_tea.cli.search_preview import describe

        print(describe(*sequence, args.planner))
    print(f"preview: {out}")
    print(f"floor plan: {plan_out}")
    return 0


def add_parser(sub) -> None:
    from fg_tea.common.planner_names import planner_help

    p = sub.add_parser("run", help="run a make-tea episode in the PyBullet house (log + video)",
                       epilog=RUN_EXIT_STATUS)
    p.add_argument("--env", choices=("pybullet", "fake"), default="pybullet",
                   help="the PyBullet house, or the fake house: no simulator, the same motion, "
                   "distances and seeded detections without images (default: %(default)s)")
    p.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO,
                   help="scenario file or bundled name (default: %(default)s)")
    p.add_argument("--model", default=DEFAULT_MODEL, help=MODEL_HELP)
    p.add_argument("--seed", type=integer(0, MAX_SEED), default=0, help="episode seed (default: %(default)s)")
    p.add_argument("--out", type=out_path,
                   help="output folder (default: runs/SCENARIO-MODEL-seedN; a model file that is not the "
                   "bundled model of its name adds its file stem: runs/SCENARIO-MODEL-STEM-seedN)")
    p.add_argument("--no-video", action="store_true", help="headless: write the log only")
    p.add_argument("--max-frames", type=integer(1, 10_000_000), default=50_000,
                   help="frame limit (default: %(default)s)")
    p.add_argument("--planner", default="efe", type=planner_name,
                   help=f"search planner: {planner_help()}; "
                   "a name registered in the fg_tea.planners entry-point group, or "
                   "module:attribute for a planner of your own (default: %(default)s)")
    p.add_argument("--task", default="make_tea", help="task file or bundled name (default: %(default)s)")
    p.add_argument("--preparation-site", help="site where the tea is made (default: the scenario's)")
    add_solver_argument(p)
    p.add_argument("--camera", default=None, help=CAMERA_HELP)
    p.add_argument("--min-visible-pixels", type=integer(1, 10_000_000), default=None,
                   help="the threshold camera's detection threshold (default: the camera's, 25)")
    p.add_argument("--failure-rate", action="append", default=[], metavar="VERB=P",
                   help="inject seeded failures, e.g. FILL=0.3 (repeatable)")
    p.add_argument("--movement-step", type=number(0.001, 1.0), default=0.018, metavar="M",
                   help="how far the agent moves in one frame, metres (default: %(default)s)")
    p.add_argument("--turn-step", type=number(0.1, 90.0), default=2.5, metavar="DEG",
                   help="how far the agent turns in one frame, degrees (default: %(default)s)")
    add_video_options(p)

    p = sub.add_parser("render", help="re-render the video of a logged episode")
    p.add_argument("log", help="an episode.jsonl written by fg-tea run")
    p.add_argument("--out", type=out_path, help="output MP4, or PNG with --still (default: the log's name with .mp4 "
                   "or .png)")
    p.add_argument("--still", type=integer(0, 10_000_000), default=None, metavar="FRAME",
                   help="write only this frame of the video (0-based) as a PNG, for pictures")
    add_video_options(p)

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
    p.add_argument("--camera", default=None, help=CAMERA_HELP)
    p.add_argument("--seed", type=integer(0, MAX_SEED), default=0,
                   help="seed of the start pose and world (default: %(default)s)")
    p.add_argument("--search", action="store_true",
                   help="also print the looks --planner would make for --task if no look found anything "
                   "(the agent walks the house; its beliefs and planner as in an episode, never the truth)")
    p.add_argument("--planner", default="efe", type=planner_name, help="the planner of --search (default: %(default)s)")
    p.add_argument("--task", default="make_tea", help="the task of --search (default: %(default)s)")
    p.add_argument("--looks", type=integer(1, 1000), default=12, help="at most this many looks with --search "
                   "(default: %(default)s)")
    p.add_argument("--site", default=None, metavar="NAME",
                   help="render the view from this site's or room vantage's inspection pose (the agent "
                   "walks there from the start pose and looks, as in an episode) and print each "
                   "object's visible pixels (default: the start pose)")
    p.add_argument("--out", type=out_path, help="output PNG (default: runs/SCENARIO-preview.png, or "
                   "runs/SCENARIO-preview-SITE.png with --site; the floor plan goes beside it, "
                   "OUT's stem + _plan.png)")
    add_video_options(p)
