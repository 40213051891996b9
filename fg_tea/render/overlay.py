"""Explanatory overlays drawn on video frames (blueprint section 12).

Panels: the current object's location belief as bars (with the selected site marked), the top
candidate scores with their terms, task progress by node status, and the hidden-state
probabilities. Everything is read from an :class:`OverlayState` that the renderer rebuilds from
the log, so overlays never touch the simulator.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

FONT = cv2.FONT_HERSHEY_SIMPLEX
STATUS_COLOURS = {  # RGB
    "pending": (120, 120, 120),
    "active": (255, 200, 40),
    "complete": (70, 190, 90),
    "skipped": (80, 150, 255),
    "failed": (230, 70, 60),
}


@dataclass
class OverlayState:
    """What the overlays show at one moment of the episode."""

    phase: str = ""
    caption: str = ""
    focus_object: str | None = None
    sites: list[str] = field(default_factory=list)
    locations: dict[str, list[float]] = field(default_factory=dict)
    selected_site: str | None = None
    candidates: list[dict] = field(default_factory=list)
    tasks: list[tuple[str, str]] = field(default_factory=list)
    states: dict[str, float] = field(default_factory=dict)


def _panel(img: np.ndarray, x0: int, y0: int, x1: int, y1: int, alpha: float = 0.62) -> None:
    x0, y0 = max(x0, 0), max(y0, 0)
    x1, y1 = min(x1, img.shape[1]), min(y1, img.shape[0])
    if x1 <= x0 or y1 <= y0:
        return
    region = img[y0:y1, x0:x1].astype(np.float32)
    img[y0:y1, x0:x1] = (region * (1 - alpha) + 18 * alpha).astype(np.uint8)


def _text(img: np.ndarray, text: str, x: int, y: int, scale: float, colour=(235, 235, 235),
          thickness: int = 1) -> None:
    cv2.putText(img, text, (x, y), FONT, scale, colour, thickness, cv2.LINE_AA)


def _short(name: str, n: int) -> str:
    return name if len(name) <= n else name[: n - 1] + "."


def draw_overlays(frame: np.ndarray, state: OverlayState, inset_box: tuple[int, int, int, int] | None = None) -> np.ndarray:
    """Draw every panel onto `frame` (H x W x 3 uint8, RGB) in place and return it.

    Args:
        frame: the composed camera image.
        state: what to show.
        inset_box: (x0, y0, x1, y1) of the first-person inset, which panels avoid.
    """
    h, w = frame.shape[:2]
    s = h / 540.0  # scale relative to a 960x540 frame
    line = max(int(17 * s), 9)
    fs = 0.42 * s
    pad = int(8 * s)

    # Caption bar (top).
    _panel(frame, 0, 0, w if inset_box is None else inset_box[0] - pad, line + 2 * pad)
    _text(frame, _short(f"{state.phase}  {state.caption}", int(w / (9.5 * s))), pad, line + pad // 2,
          fs * 1.1, (255, 255, 255))

    # Location belief bars (left).
    top = line + 3 * pad
    if state.focus_object and state.focus_object in state.locations:
        q = state.locations[state.focus_object]
        width = int(250 * s)
        height = (len(state.sites) + 1) * line + 2 * pad
        _panel(frame, 0, top, width, top + height)
        _text(frame, f"q(L[{state.focus_object}])", pad, top + line, fs, (255, 230, 140))
        bar_x, bar_w = int(112 * s), int(96 * s)
        for i, (site, p) in enumerate(zip(state.sites, q)):
            y = top + (i + 2) * line
            colour = (255, 200, 40) if site == state.selected_site else (110, 180, 255)
            _text(frame, _short(site, 15), pad, y, fs * 0.9)
            cv2.rectangle(frame, (bar_x, y - int(10 * s)), (bar_x + int(bar_w * p), y - 1), colour, -1)
            _text(frame, f"{p:.2f}", bar_x + bar_w + int(4 * s), y, fs * 0.85)
        top += height + pad

    # Candidate scores (left, below the bars).
    if state.candidates:
        rows = state.candidates[:4]
        height = (len(rows) + 1) * line + 2 * pad
        width = int(330 * s)
        _panel(frame, 0, top, width, top + height)
        _text(frame, "G = wd*d - wp*q - we*I + wa*rep - l*r", pad, top + line, fs * 0.85, (255, 230, 140))
        for i, c in enumerate(rows):
            y = top + (i + 2) * line
            txt = (f"{_short(c['object'], 6)}@{_short(c['site'], 12)} G={c['total']:+.2f} "
                   f"d={c['distance']:.1f} q={c['probability']:.2f} I={c['information_gain']:.2f}")
            _text(frame, txt, pad, y, fs * 0.8, (255, 200, 40) if i == 0 else (235, 235, 235))
        top += height + pad

    # Task progress (right column, below the inset).
    right = w - int(215 * s)
    ytop = (inset_box[3] + pad) if inset_box else line + 3 * pad
    if state.tasks:
        rows = state.tasks
        row_h = max(int(13 * s), 8)
        height = len(rows) * row_h + 2 * pad + line
        _panel(frame, right, ytop, w, ytop + height)
        _text(frame, "task graph", right + pad, ytop + line, fs, (255, 230, 140))
        for i, (node, status) in enumerate(rows):
            y = ytop + line + pad + (i + 1) * row_h
            cv2.rectangle(frame, (right + pad, y - row_h + 3), (right + pad + row_h - 4, y - 1),
                          STATUS_COLOURS.get(status, (200, 200, 200)), -1)
            _text(frame, _short(node, 22), right + pad + row_h + 2, y - 1, fs * 0.75,
                  (255, 255, 255) if status == "active" else (215, 215, 215))

    # Hidden states (left column, below the candidates).
    if state.states:
        rows = sorted(state.states.items())
        height = (len(rows) + 1) * line + 2 * pad
        y0 = min(top, h - height)
        width = int(250 * s)
        _panel(frame, 0, y0, width, y0 + height)
        _text(frame, "hidden states q(z=1)", pad, y0 + line, fs, (255, 230, 140))
        bar_x = int(150 * s)
        for i, (name, p) in enumerate(rows):
            y = y0 + (i + 2) * line
            _text(frame, _short(name, 21), pad, y, fs * 0.8)
            cv2.rectangle(frame, (bar_x, y - int(10 * s)), (bar_x + int(60 * s * p), y - 1),
                          (70, 190, 90) if p >= 0.9 else (200, 160, 60), -1)
            _text(frame, f"{p:.2f}", bar_x + int(64 * s), y, fs * 0.8)
    return frame
