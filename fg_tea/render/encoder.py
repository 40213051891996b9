"""H.264 MP4 output through PyAV (browser-playable: yuv420p, faststart), written atomically.

Frames go to a temporary file beside the target, which is renamed into place only when the
video is complete, so an interrupted render never leaves a corrupt MP4 under the final name.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np


class Mp4Writer:
    """Encode RGB frames (H x W x 3 uint8) into an H.264 MP4.

    Args:
        path: the final file name.
        width, height: frame size in pixels (even numbers, as yuv420p requires).
        fps: output frame rate.
        crf: x264 quality (lower is better; 23 is x264's default).
        bframes: x264 B-frames (0 keeps decode order = display order, so segments concatenate).
    """

    def __init__(self, path: str | Path, width: int, height: int, fps: int = 30, crf: int = 23,
                 bframes: int | None = None) -> None:
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
        self._stream.options = {"preset": "veryfast", "crf": str(crf)}
        if bframes is not None:
            self._stream.options = {**self._stream.options, "bframes": str(bframes)}
        self.frames = 0

    def write(self, frame: np.ndarray) -> None:
        video_frame = self._av.VideoFrame.from_ndarray(np.ascontiguousarray(frame), format="rgb24")
        for packet in self._stream.encode(video_frame):
            self._container.mux(packet)
        self.frames += 1

    def close(self) -> Path:
        """Flush the encoder and move the finished file into place."""
        for packet in self._stream.encode():
            self._container.mux(packet)
        self._container.close()
        os.replace(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        try:
            self._container.close()
        finally:
            self._tmp.unlink(missing_ok=True)


def probe(path: str | Path) -> dict:
    """Decode a video fully; return its codec, size, frame rate and number of decoded frames."""
    import av

    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        frames = sum(1 for _ in container.decode(stream))
        return {"codec": stream.codec_context.name, "width": stream.width, "height": stream.height,
                "fps": float(stream.average_rate or 0), "frames": frames,
                "pix_fmt": stream.codec_context.pix_fmt}
