"""Which renderer, inset size and encoder preset for the video? CPU per image, measured here.

For a few frames of the default episode's video (``fg-tea run``'s options), in this process:
the chase view (640x360) and the first-person inset by the plain house (TinyRenderer with a floor
body and full-height walls sunk to the cut-away) and by the render-only house
(:class:`fg_tea.render.scene.SceneViews`), with PSNR between the two; the inset at other render
sizes (PSNR of the frame's inset region after scaling up, against the chosen size); x264 presets on
60 composed frames (CPU, size, PSNR of the decoded frames); and, when the EGL plugin loads, the
CPU of one EGL (Mesa) image of an empty scene.

    python experiments/video_renderers.py [--out experiments/results/video/renderers.md]

It writes runs/experiments/video_renderers/renderers.md unless --out names another file.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from fg_tea.cli.defaults import default_episode, default_options
from fg_tea.common.files import atomic_write_text, out_file
from fg_tea.common.options import experiment_parser
from fg_tea.common.tables import table_lines


def cpu_ms(fn, n: int = 5) -> float:
    fn()
    t = time.process_time()
    for _ in range(n):
        fn()
    return (time.process_time() - t) / n * 1000


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return float("inf") if mse == 0 else 10 * np.log10(255.0 ** 2 / mse)


DEFAULT_OUT = Path("runs") / "experiments" / "video_renderers" / "renderers.md"


def build_parser() -> argparse.ArgumentParser:
    parser = experiment_parser(__doc__, __file__, "§9")
    parser.add_argument("--out", type=out_file, default=DEFAULT_OUT,
                        help="markdown output (committed: experiments/results/video/renderers.md)")
    return parser


def main(argv: list[str] | None = None) -> int:
    import cv2

    from fg_tea.env.house import PyBulletHouse
    from fg_tea.render.encoder import Mp4Writer
    from fg_tea.render.frames import FrameRenderer
    from fg_tea.render.scene import SceneViews
    from fg_tea.render.video import plan_frames

    args = build_parser().parse_args(argv)
    options = default_options(workers=1)
    with tempfile.TemporaryDirectory() as tmp:
        plan = plan_frames(default_episode(Path(tmp)), options)
    renderer = FrameRenderer(plan, options)
    scene: SceneViews = renderer.views.views  # the render-only house under the reuse of views
    plain = PyBulletHouse(scene.chase_house.scenario, scene.config)
    plain.reset(plan.seed)
    chase = (options.chase_distance, options.chase_height, options.chase_pitch_deg, options.chase_hfov_deg)
    lines = ["## Renderer, inset size and encoder preset for the video", "",
             f"Made by `python experiments/video_renderers.py`; CPU ms per image (mean of 5), frames of "
             f"the default episode at `fg-tea run`'s options ({options.width}x{options.height}, scene "
             f"scale {options.scene_scale:.3f}).", ""]
    frame_rows = []
    cw, ch = int(options.width * options.scene_scale) // 2 * 2, int(options.height * options.scene_scale) // 2 * 2
    iw = int(options.width * options.inset_scale) // 2 * 2
    ih = int(iw * 3 / 4) // 2 * 2
    ew, eh = int(iw * 0.75) // 2 * 2, int(ih * 0.75) // 2 * 2
    for index in (0, 300, 900, 1500):
        spec = plan.frames[index]
        state = (spec.pose, plan.placements[spec.placements], spec.held)
        plain.set_scene_state(*state)
        scene.set_scene_state(*state)
        a = plain.render_chase(cw, ch, *chase, options.wall_cutaway)
        b = scene.chase(cw, ch, *chase)
        c, d = plain.render_ego(ew, eh)[0], scene.ego(ew, eh)
        frame_rows.append([index, f"{cpu_ms(lambda: plain.render_chase(cw, ch, *chase, options.wall_cutaway)):.1f}",
                           f"{cpu_ms(lambda: scene.chase(cw, ch, *chase)):.1f}", f"{psnr(a, b):.1f}",
                           f"{cpu_ms(lambda: plain.render_ego(ew, eh)):.1f}",
                           f"{cpu_ms(lambda: scene.ego(ew, eh)):.1f}", f"{psnr(c, d):.1f}"])
    lines += table_lines(["frame", "chase plain ms", "chase render-only ms", "PSNR", "inset plain ms",
                          "inset render-only ms", "PSNR"], frame_rows, align="left")
    lines += ["", f"Inset ({iw}x{ih} in the frame) rendered at other sizes and scaled up, against the "
              f"size used ({ew}x{eh}); the inset is {iw * ih / (options.width * options.height):.0%} of "
              "the frame, so its PSNR plus about 9 dB is the frame's.", ""]
    size_rows = []
    spec = plan.frames[300]
    scene.set_scene_state(spec.pose, plan.placements[spec.placements], spec.held)
    chosen = cv2.resize(np.ascontiguousarray(scene.ego(ew, eh)), (iw, ih), interpolation=cv2.INTER_LINEAR)
    for frac in (0.5, 0.6, 0.75, 1.0):
        w, h = int(iw * frac) // 2 * 2, int(ih * frac) // 2 * 2
        image = cv2.resize(np.ascontiguousarray(scene.ego(w, h)), (iw, ih), interpolation=cv2.INTER_LINEAR)
        size_rows.append([f"{w}x{h}", f"{cpu_ms(lambda: scene.ego(w, h)):.1f}", f"{psnr(image, chosen):.1f}"])
    lines += table_lines(["render size", "CPU ms", "inset PSNR"], size_rows, align="left")
    frames = [renderer.frame(i) for i in range(300, 360)]
    lines += ["", "x264 on 60 composed frames (one thread, no B-frames, CRF 23):", ""]
    preset_rows = []
    import av

    for preset in ("veryfast", "superfast", "ultrafast"):
        path = Path(tempfile.mkdtemp()) / "p.mp4"
        writer = Mp4Writer(path, options.width, options.height, options.fps, bframes=0, threads=1, preset=preset)
        t = time.process_time()
        for f in frames:
            writer.write(f)
        writer.close()
        spent = (time.process_time() - t) / len(frames) * 1000
        with av.open(str(path)) as c:
            decoded = [f.to_ndarray(format="rgb24") for f in c.decode(video=0)]
        quality = np.mean([psnr(a, b) for a, b in zip(frames, decoded)])
        preset_rows.append([preset, f"{spent:.1f}", path.stat().st_size // 1024, f"{quality:.1f}"])
    lines += table_lines(["preset", "CPU ms per frame", "KB", "PSNR of decoded frames"], preset_rows, align="left")
    lines += ["", egl_line(scene.config), ""]
    renderer.close()
    plain.close()
    text = "\n".join(lines)
    atomic_write_text(args.out, text)
    print(text)
    return 0


def egl_line(config) -> str:
    """EGL (the eglRenderer plugin, Mesa here): the CPU of one image of an empty scene."""
    import pkgutil

    from fg_tea.env.pybullet_quiet import pybullet

    loader = pkgutil.get_loader("eglRenderer")
    if loader is None:
        return "EGL: the eglRenderer plugin is not installed."
    client = pybullet.connect(pybullet.DIRECT)
    try:
        if pybullet.loadPlugin(loader.get_filename(), "_eglRendererPlugin", physicsClientId=client) < 0:
            return "EGL: the eglRenderer plugin does not load here."
        view = pybullet.computeViewMatrix([0, -3, 2], [0, 0, 0], [0, 0, 1])
        proj = pybullet.computeProjectionMatrixFOV(60, 16 / 9, 0.03, 30)

        def one():
            pybullet.getCameraImage(640, 360, view, proj, renderer=pybullet.ER_BULLET_HARDWARE_OPENGL,
                                    physicsClientId=client)
        return (f"EGL (the eglRenderer plugin; pybullet API {pybullet.getAPIVersion()}): {cpu_ms(one):.1f} "
                "CPU ms for one 640x360 image of an empty scene (TinyRenderer: about 3 ms).")
    finally:
        pybullet.disconnect(client)


if __name__ == "__main__":
    raise SystemExit(main())
