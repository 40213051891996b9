"""The video reference frames, and the default episode and options they were rendered with
(fg_tea.cli.defaults)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fg_tea.cli.defaults import default_episode, default_options

#: Output frames of the default episode's video kept as references: the README's still (a room
#: glance), a frame of motion with a moving inset, a carried object, and the end. (Frame 40 was
#: one too, until a decision's caption began to say which searches its look serves.)
FRAMES = (360, 600, 1100, 2240)



def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """Peak signal-to-noise ratio of two 8-bit images, dB (inf when equal)."""
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return float("inf") if mse == 0 else 10 * np.log10(255.0 ** 2 / mse)


def rendered_index(plan, output_frame: int) -> int:
    """The rendered frame a video's output frame shows (held frames repeat one rendering)."""
    seen = 0
    for index, spec in enumerate(plan.frames):
        if seen + spec.repeat > output_frame:
            return index
        seen += spec.repeat
    raise AssertionError(output_frame)


def check_frames_against(folder: Path, events) -> None:
    """Every reference frame in `folder` (frameNNNN.png) against the default episode's frames
    rendered now: the same shape and PSNR >= 40 dB."""
    from PIL import Image

    from fg_tea.render.frames import FrameRenderer
    from fg_tea.render.video import plan_frames

    options = default_options()
    plan = plan_frames(events, options)
    renderer = FrameRenderer(plan, options)
    try:
        for n in FRAMES:
            reference = np.asarray(Image.open(folder / f"frame{n:04d}.png").convert("RGB"))
            frame = renderer.frame(rendered_index(plan, n))
            assert frame.shape == reference.shape
            assert psnr(frame, reference) >= 40.0, n
    finally:
        renderer.close()


__all__ = ["FRAMES", "check_frames_against", "default_episode", "default_options", "psnr", "rendered_index"]
