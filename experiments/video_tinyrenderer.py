"""What does PyBullet's TinyRenderer spend its time on in the video's views, and what avoids it?

Runs the default episode headless (as ``fg-tea run --no-video``), then renders the chase view
(640x360) and the first-person inset (216x162) of every n-th rendered frame of its video, as
``fg-tea run`` renders them, and measures CPU milliseconds per image (``time.process_time``):

1. an empty scene, by image size: what every call costs per pixel;
2. the chase copy (walls as 1 m box pieces) drawn by TinyRenderer alone, its time against the
   pixels the scene covers;
3. every body out of the chase camera's view (its bounds outside a plane of the view volume)
   moved out of the scene: time and pixels against the same images with them;
4. the walls as box bodies in pieces of several lengths, and as one mesh;
5. one small window (40x30) of the chase copy: what a call costs beyond its pixels;
6. the views as the video draws them (walls and furniture painted, objects in windows:
   :mod:`fg_tea.render.boxes`) against TinyRenderer alone, with the pixels that differ.

    python experiments/video_tinyrenderer.py [--every 29] [--out FILE]

It writes runs/experiments/video_tinyrenderer/tinyrenderer.md unless --out names another file
(the committed one: experiments/results/video/tinyrenderer.md).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from fg_tea.cli.defaults import default_episode, default_options
from fg_tea.common.files import atomic_write_text, out_file
from fg_tea.common.options import experiment_parser
from fg_tea.common.tables import table_lines

DEFAULT_OUT = Path("runs") / "experiments" / "video_tinyrenderer" / "tinyrenderer.md"
CHASE, INSET = (640, 360), (216, 162)


def build_parser() -> argparse.ArgumentParser:
    parser = experiment_parser(__doc__, __file__, "§9")
    parser.add_argument("--every", type=int, default=29, help="measure every n-th rendered frame")
    parser.add_argument("--out", type=out_file, default=DEFAULT_OUT,
                        help="the summary (committed: experiments/results/video/tinyrenderer.md)")
    return parser


def _ms(fn, repeat: int = 1) -> float:
    start = time.process_time()
    for _ in range(repeat):
        fn()
    return 1000 * (time.process_time() - start) / repeat


def _views(plan, options, walls: tuple[str, float] | None = None, boxes: bool = False):
    """SceneViews of the plan's house; `walls`: ("box", m) box bodies that long or ("mesh", m) one
    mesh with faces in pieces that long (None: as the video builds them); `boxes`: False draws
    everything with TinyRenderer (the painters off)."""
    from fg_tea.env.base import EnvConfig
    from fg_tea.render import scene
    from fg_tea.render.compose import load_plan_scenario

    config = replace(EnvConfig(), **{k: v for k, v in plan.env.items() if k in EnvConfig.__dataclass_fields__})
    original = scene.SceneViews.__dict__["_cut_walls"]
    if walls is not None:
        kind, piece_m = walls
        cut = _box_walls if kind == "box" else original.__func__
        scene.SceneViews._cut_walls = staticmethod(lambda house, top, _=None: cut(house, top, piece_m))
    try:
        views = scene.SceneViews(load_plan_scenario(plan), config, plan.seed, options.wall_cutaway)
    finally:
        scene.SceneViews._cut_walls = original
    if not boxes:
        views.painters = {house: None for house in views.painters}
    return views


def _box_walls(house, top: float | None, piece_m: float) -> None:
    """The walls as box bodies at most `piece_m` long (the render-only copy before one mesh)."""
    from fg_tea.env import assets
    from fg_tea.env.house import WALL_COLOR
    from fg_tea.env.pybullet_quiet import pybullet
    from fg_tea.world.navigation import wall_boxes

    full = house.scenario.house.wall_height
    height = full if top is None else min(max(top, 0.05), full)
    for body, _, _ in house._walls:
        pybullet.removeBody(body, physicsClientId=house._client)
    for wall in wall_boxes(house.scenario.house):
        yaw = math.atan2(wall.axis[1], wall.axis[0])
        n = max(1, math.ceil(2 * wall.half[0] / piece_m))
        half = wall.half[0] / n
        for k in range(n):
            along = -wall.half[0] + (2 * k + 1) * half
            centre = (wall.center[0] + along * wall.axis[0], wall.center[1] + along * wall.axis[1], height / 2)
            assets.box(house._client, centre, (half, wall.half[1], height / 2), WALL_COLOR, yaw=yaw)
    house._walls = []


def _chase_args(options) -> tuple:
    return (options.chase_distance, options.chase_height, options.chase_pitch_deg, options.chase_hfov_deg)


def _frames(plan, every: int):
    for index in range(0, len(plan.frames), every):
        spec = plan.frames[index]
        yield spec.pose, plan.placements[spec.placements], spec.held


def _empty_cost() -> list[list[str]]:
    from fg_tea.env.pybullet_quiet import pybullet

    client = pybullet.connect(pybullet.DIRECT)
    rows = []
    try:
        view = pybullet.computeViewMatrix([0, 0, 2], [1, 0, 1.5], [0, 0, 1])
        for width, height in ((216, 162), (320, 180), (640, 360), (1280, 720)):
            proj = pybullet.computeProjectionMatrixFOV(50, width / height, 0.03, 30)
            ms = _ms(lambda: pybullet.getCameraImage(width, height, view, proj, renderer=pybullet.ER_TINY_RENDERER,
                                                     shadow=0, flags=pybullet.ER_NO_SEGMENTATION_MASK,
                                                     physicsClientId=client), 20)
            rows.append([f"{width}x{height}", f"{ms:.2f}", f"{1e6 * ms / (width * height):.1f}"])
    finally:
        pybullet.disconnect(client)
    return rows


def _in_view(views, house, camera) -> list[int]:
    """Bodies of `house` some part of whose visual shapes' bounds lies inside every plane of the
    camera's view volume (a sphere around each shape, conservatively)."""
    from fg_tea.env.pybullet_quiet import pybullet

    c = house._client
    m = np.reshape(camera[1], (4, 4)).T @ np.reshape(camera[0], (4, 4)).T
    kept = []
    for i in range(pybullet.getNumBodies(physicsClientId=c)):
        body = pybullet.getBodyUniqueId(i, physicsClientId=c)
        pos, orn = pybullet.getBasePositionAndOrientation(body, physicsClientId=c)
        points = []
        for shape in pybullet.getVisualShapeData(body, physicsClientId=c):
            dims, local = shape[3], shape[5]
            radius = 0.5 * float(np.linalg.norm(dims)) if shape[2] == pybullet.GEOM_BOX else 0.4
            centre, _ = pybullet.multiplyTransforms(pos, orn, local, [0, 0, 0, 1])
            points += [[centre[0] + sx * radius, centre[1] + sy * radius, centre[2] + sz * radius, 1.0]
                       for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
        x, y, z, w = m @ np.array(points).T
        if not any((a > 0).all() for a in (x - w, -x - w, y - w, -y - w, -z - w)):
            kept.append(body)
    return kept


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from fg_tea.env.pybullet_quiet import pybullet
    from fg_tea.env.house import sub_projection
    from fg_tea.render.video import plan_frames

    with tempfile.TemporaryDirectory() as tmp:
        events = default_episode(Path(tmp))
    options = default_options(workers=1)
    plan = plan_frames(events, options)
    chase = _chase_args(options)
    frames = list(_frames(plan, args.every))
    lines = ["## TinyRenderer in the video's views: where its time goes, and what avoids it", "",
             f"Made by `python experiments/video_tinyrenderer.py {' '.join(argv if argv is not None else sys.argv[1:])}"
             f"`: {len(frames)} rendered frames of the default video (every {args.every}th), chase view "
             f"{CHASE[0]}x{CHASE[1]}, inset {INSET[0]}x{INSET[1]}; CPU ms per image, one process.", "",
             "An empty scene, by image size (every call clears, flips and copies its buffers):", ""]
    lines += table_lines(["size", "ms", "ns per pixel"], _empty_cost(), align="left")

    plain = _views(plan, options, ("box", 1.0))  # bodies of their own size, as culling needs
    house = plain.chase_house
    c = house._client
    rows, cull, covered_ms = [], [0.0, 0.0, 0, 0], []
    for pose, placements, held in frames:
        plain.set_scene_state(pose, placements, held)
        camera = plain.chase_camera(*CHASE, *chase)
        full = _ms(lambda: house._render(camera, *CHASE, segmentation=False), 2)
        rgb, depth, _ = house._render(camera, *CHASE, segmentation=False)
        covered_ms.append((int((depth < 1.0).sum()), full))
        visible = set(_in_view(plain, house, camera))
        ids = [pybullet.getBodyUniqueId(i, physicsClientId=c) for i in range(pybullet.getNumBodies(physicsClientId=c))]
        saved = {b: pybullet.getBasePositionAndOrientation(b, physicsClientId=c) for b in ids if b not in visible}
        for b in saved:
            pybullet.resetBasePositionAndOrientation(b, [0, 0, -500], [0, 0, 0, 1], physicsClientId=c)
        culled = _ms(lambda: house._render(camera, *CHASE, segmentation=False), 2)
        rgb2 = house._render(camera, *CHASE, segmentation=False)[0]
        for b, (pos, orn) in saved.items():
            pybullet.resetBasePositionAndOrientation(b, pos, orn, physicsClientId=c)
        cull[0] += full
        cull[1] += culled
        cull[2] += len(saved)
        cull[3] += int((rgb != rgb2).any(axis=2).sum())
    n = len(frames)
    px = np.array([p for p, _ in covered_ms], float)
    ms = np.array([t for _, t in covered_ms])
    slope, base = np.polyfit(px, ms, 1)
    lines += ["", "The chase copy (walls as 1 m box pieces) drawn by TinyRenderer alone: "
              f"{ms.mean():.2f} ms per image, covering {px.mean():.0f} of {CHASE[0] * CHASE[1]} pixels on "
              f"average; a line through (pixels covered, ms) gives {1000 * slope:.3f} microseconds per "
              f"covered pixel and {base:.2f} ms at none.", "",
              f"Bodies out of the chase camera's view moved out of the scene ({cull[2] / n:.1f} of them per "
              f"image): {cull[0] / n:.2f} ms with them, {cull[1] / n:.2f} ms without, {cull[3]} pixels "
              "different in all: bodies out of view cost nothing measurable.", "",
              "Walls as box bodies in pieces, or as one mesh (the chase copy and the inset's, TinyRenderer "
              "alone, the same frames):", ""]
    plain.close()
    for label, walls in (("box pieces of 0.25 m", ("box", 0.25)), ("box pieces of 0.5 m", ("box", 0.5)),
                         ("box pieces of 1 m", ("box", 1.0)), ("one mesh, faces in 1 m pieces", ("mesh", 1.0)),
                         ("one mesh, whole faces", ("mesh", math.inf))):
        views = _views(plan, options, walls)
        tc = te = 0.0
        for pose, placements, held in frames:
            views.set_scene_state(pose, placements, held)
            tc += _ms(lambda: views.chase(*CHASE, *chase))
            te += _ms(lambda: views.ego(*INSET))
        rows.append([label, f"{tc / n:.2f}", f"{te / n:.2f}"])
        views.close()
    lines += table_lines(["walls", "chase ms", "inset ms"], rows, align="left")

    painted, alone = _views(plan, options, boxes=True), _views(plan, options, ("mesh", 1.0))
    window = (300, 150, 340, 180)
    painted.set_scene_state(*frames[len(frames) // 2])
    camera = painted.chase_camera(*CHASE, *chase)
    small = (camera[0], sub_projection(camera[1], *CHASE, window))
    call = _ms(lambda: painted.chase_house._render(small, 40, 30, segmentation=False), 50)
    totals = {"painted chase": 0.0, "painted inset": 0.0, "alone chase": 0.0, "alone inset": 0.0}
    differ = {"chase": 0, "inset": 0}
    for pose, placements, held in frames:
        for views, name in ((painted, "painted"), (alone, "alone")):
            views.set_scene_state(pose, placements, held)
        for view, args_ in (("chase", (*CHASE, *chase)), ("inset", INSET)):
            method = "chase" if view == "chase" else "ego"
            totals[f"painted {view}"] += _ms(lambda: getattr(painted, method)(*args_))
            totals[f"alone {view}"] += _ms(lambda: getattr(alone, method)(*args_))
            a, b = getattr(painted, method)(*args_), getattr(alone, method)(*args_)
            differ[view] += int((a != b).any(axis=2).sum())
    painted.close()
    alone.close()
    lines += ["", f"One 40x30 window of the chase copy (walls, furniture, objects, drone): {call:.2f} ms a call.", "",
              "The views as the video draws them (walls and furniture painted as TinyRenderer would, objects "
              "and drone by TinyRenderer in windows) against TinyRenderer alone (walls one mesh in 1 m "
              "pieces, as the video drew them before):", ""]
    sizes = {"chase": CHASE[0] * CHASE[1], "inset": INSET[0] * INSET[1]}
    lines += table_lines(["view", "painted ms", "TinyRenderer alone ms", "pixels different, all frames"],
                         [[v, f"{totals['painted ' + v] / n:.2f}", f"{totals['alone ' + v] / n:.2f}",
                           f"{differ[v]} of {n * sizes[v]}"] for v in ("chase", "inset")], align="left")
    lines += [""]
    text = "\n".join(lines)
    atomic_write_text(args.out, text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
