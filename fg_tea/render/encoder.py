"""H.264 MP4 output through PyAV (browser-playable: yuv420p, faststart), written atomically.

Frames go to a temporary file beside the target, which is renamed into place only when the
video is complete, so an interrupted render never leaves a corrupt MP4 under the final name.
"""

from __future__ import annotations

import os
from fractions import Fraction
from pathlib import Path

import numpy as np

#: x264's preset. ``ultrafast`` spends about 3 ms less CPU per 960x540 frame than ``veryfast``,
#: for a file about 2.3 times larger whose decoded frames are as close to the rendered ones
#: (experiments/results/video/renderers.md); the video's cost is its CPU.
PRESET = "ultrafast"


class Mp4Writer:
    """Encode RGB frames (H x W x 3 uint8) into an H.264 MP4.

    Args:
        path: the final file name.
        width, height: frame size in pixels (even numbers, as yuv420p requires).
        fps: output frame rate.
        crf: x264 quality (lower is better; 23 is x264's default).
        bframes: x264 B-frames (0 keeps decode order = display order, so segments concatenate).
        threads: x264 threads (None: x264's choice, which depends on the machine). Given, the
            encoding is made repeatable (no macroblock tree); 1 suits one encoder per worker.
        preset: x264 preset (default :data:`PRESET`).

    A frame written with ``repeat`` n is encoded once and shown for n frame times (its
    timestamps say so), so a held picture costs one encoding.
    """

    def __init__(self, path: str | Path, width: int, height: int, fps: int = 30, crf: int = 23,
                 bframes: int | None = None, threads: int | None = None, preset: str | None = None) -> None:
        try:
            import av
        except ImportError as exc:  # pragma: no cover - av is a core dependency
            raise RuntimeError("video output needs PyAV: pip install av") from exc
        if width % 2 or height % 2:
            raise ValueError(f"video size must be even for yuv420p, got {width}x{height}")
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._tmp = self.path.with_name(f".{self.path.name}.partial.mp4")
        self._av = av
        self._container = av.open(str(self._tmp), "w", options={"movflags": "faststart"})
        self._stream = self._container.add_stream("libx264", rate=fps)
        self._stream.width, self._stream.height = width, height
        self._stream.pix_fmt = "yuv420p"
        options: dict[str, str] = {"preset": preset or PRESET, "crf": str(crf)}
        if bframes is not None:
            options["bframes"] = str(bframes)
        if threads is not None:
            options["threads"] = str(threads)
            # Same pictures, same bytes: x264's macroblock tree gave different bytes from run to
            # run in a process that also renders (tests/test_video_speed.py), so it is off.
            options["x264-params"] = f"threads={threads}:lookahead-threads=1:sync-lookahead=0:mbtree=0"
        self._stream.options = dict(options)
        self._stream.codec_context.time_base = Fraction(1, fps)
        self._durations: dict[int, int] = {}  # pts -> frames shown
        self.frames = 0  # output frames (frame times) written
        self.pictures = 0  # encoded pictures

    def write(self, frame: np.ndarray, repeat: int = 1) -> None:
        """Append `frame`, shown for `repeat` frame times."""
        if repeat < 1:
            raise ValueError(f"repeat must be at least 1, got {repeat}")
        rgb = self._av.VideoFrame.from_ndarray(np.ascontiguousarray(frame), format="rgb24")
        video_frame = rgb.reformat(format="yuv420p", threads=1)  # one thread: CPU is the cost
        video_frame.pts = self.frames
        video_frame.time_base = self._stream.codec_context.time_base
        self._durations[self.frames] = repeat
        self._mux(self._stream.encode(video_frame))
        self.frames += repeat
        self.pictures += 1

    def _mux(self, packets) -> None:
        for packet in packets:
            if packet.pts is not None and packet.pts in self._durations:
                packet.duration = self._durations.pop(packet.pts)
            self._container.mux(packet)

    def close(self) -> Path:
        """Flush the encoder and move the finished file into place."""
        self._mux(self._stream.encode())
        self._container.close()
        os.replace(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        try:
            self._container.close()
        finally:
            self._tmp.unlink(missing_ok=True)


def probe(path: str | Path) -> dict:
    """Decode a video fully; return its codec, size, frame rate, number of decoded pictures
    (``frames``; a held picture counts once) and its length in seconds."""
    import av

    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        frames, last = 0, 0.0
        for frame in container.decode(stream):
            frames, last = frames + 1, float(frame.time or 0)
        # The last picture is shown until the stream's end (a held picture, for its hold).
        end = float(stream.duration * stream.time_base) if stream.duration and stream.time_base else 0.0
        shown = max(end, last) if frames else 0.0
        return {"codec": stream.codec_context.name, "width": stream.width, "height": stream.height,
                "fps": float(stream.guessed_rate or stream.average_rate or 0), "frames": frames,
                "seconds": shown, "pix_fmt": stream.codec_context.pix_fmt}
