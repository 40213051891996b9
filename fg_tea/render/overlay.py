"""What is the agent thinking at this frame? Explanatory overlays drawn on video frames.

Panels, kept at the frame edges and semi-transparent so the middle of the chase view (the agent
and the site ahead of it, where the object being looked for appears) stays clear:

* top: a caption bar (phase and what is happening);
* left: the focus object's location belief as bars (at most :data:`MAX_BELIEF_ROWS` sites: the
  ones in view and the most probable), the top candidate scores with their terms and units, and
  the hidden-state probabilities;
* right, under the first-person inset: a mini-map of the house (the agent, its field of view,
  the current viewpoint and the sites its look covers; a room glance in cyan with a line to every
  covered site, a close look in amber), then the task graph by node status with a colour legend;
* in the chase view: the names of the sites in front of the camera, those in view ringed.

Everything is read from an :class:`OverlayState` that the renderer rebuilds from the log, so
overlays never touch the simulator. Below :data:`COMPACT_HEIGHT` pixels the text panels are left
out (they would be unreadable and hide the scene); the caption, mini-map and task squares stay.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import cv2
import numpy as np

from fg_tea.world.interface import logged_viewpoint

FONT = cv2.FONT_HERSHEY_SIMPLEX
STATUS_COLOURS = {  # RGB
    "pending": (120, 120, 120),
    "active": (255, 200, 40),
    "complete": (70, 190, 90),
    "skipped": (80, 150, 255),
    "failed": (230, 70, 60),
}
#: Highlight colours (RGB) of the sites covered by a close look and by a room glance.
LOOK_COLOURS = {"site": (255, 200, 40), "room": (60, 220, 255)}
#: Most sites listed in the belief panel (the sites in view first, then the most probable).
MAX_BELIEF_ROWS = 10
#: Frames less tall than this (px) get only the caption, mini-map and task squares.
COMPACT_HEIGHT = 270
#: Site names are written in the chase view up to this distance (m) from the camera.
LABEL_RANGE_M = 9.0


@dataclass
class OverlayState:
    """What the overlays show at one moment of the episode.

    Attributes:
        viewpoint: the current look's viewpoint (None between searches).
        viewpoint_kind: ``"site"`` (close look) or ``"room"`` (room glance).
        viewpoint_room: the room a glance covers (for its caption and label).
        viewpoint_position: (x, y) of the viewpoint in metres, when the log gives it.
        sites_in_view: the sites the current look covers.
        found_at: object -> site where the last look saw it.
    """

    phase: str = ""
    caption: str = ""
    focus_object: str | None = None
    sites: list[str] = field(default_factory=list)
    locations: dict[str, list[float]] = field(default_factory=dict)
    selected_site: str | None = None
    candidates: list[dict] = field(default_factory=list)
    tasks: list[tuple[str, str]] = field(default_factory=list)
    states: dict[str, float] = field(default_factory=dict)
    viewpoint: str | None = None
    viewpoint_kind: str = "site"
    viewpoint_room: str | None = None
    viewpoint_position: list[float] | None = None
    sites_in_view: list[str] = field(default_factory=list)
    found_at: dict[str, str] = field(default_factory=dict)


def _panel(img: np.ndarray, x0: int, y0: int, x1: int, y1: int, alpha: float = 0.62) -> None:
    x0, y0 = max(x0, 0), max(y0, 0)
    x1, y1 = min(x1, img.shape[1]), min(y1, img.shape[0])
    if x1 <= x0 or y1 <= y0:
        return
    # region * (1 - alpha) + 18 * alpha, truncated (the -0.5: OpenCV rounds), in one pass.
    region = img[y0:y1, x0:x1]
    cv2.convertScaleAbs(region, region, 1 - alpha, 18 * alpha - 0.5)


def _text(img: np.ndarray, text: str, x: int, y: int, scale: float, colour=(235, 235, 235),
          thickness: int = 1) -> None:
    cv2.putText(img, text, (x, y), FONT, scale, colour, thickness, cv2.LINE_AA)


def _short(name: str, n: int) -> str:
    return name if len(name) <= n else name[: n - 1] + "."


def _fit(text: str, max_px: int, scale: float) -> str:
    """`text`, shortened with a trailing '.' until it is at most `max_px` pixels wide."""
    while len(text) > 4 and cv2.getTextSize(text, FONT, scale, 1)[0][0] > max_px:
        text = text[: max(4, int(len(text) * max_px / cv2.getTextSize(text, FONT, scale, 1)[0][0])) - 1] + "."
    return text


def _intersects(a, b) -> bool:
    return min(a[2], b[2]) > max(a[0], b[0]) and min(a[3], b[3]) > max(a[1], b[1])


def belief_rows(state: OverlayState, limit: int = MAX_BELIEF_ROWS) -> list[tuple[str, float]]:
    """(site, q) rows of the belief panel, in scenario order: every site if they fit, else the
    sites in view and then the most probable, `limit` in all."""
    q = state.locations.get(state.focus_object or "", [])
    pairs = list(zip(state.sites, q))
    if len(pairs) <= limit:
        return pairs
    keep = [s for s in state.sites_in_view if s in state.sites][:limit]
    for site, _ in sorted(pairs, key=lambda sp: -sp[1]):
        if len(keep) >= limit:
            break
        if site not in keep:
            keep.append(site)
    chosen = set(keep)
    return [(s, p) for s, p in pairs if s in chosen]


def draw_overlays(frame: np.ndarray, state: OverlayState, inset_box: tuple[int, int, int, int] | None = None,
                  minimap=None, pose: Sequence[float] | None = None,
                  site_pixels: Mapping[str, tuple[float, float, float]] | None = None,
                  keep_clear: Sequence[tuple[int, int, int, int]] = ()) -> np.ndarray:
    """Draw every panel onto `frame` (H x W x 3 uint8, RGB) in place and return it.

    Args:
        frame: the composed camera image.
        state: what to show.
        inset_box: (x0, y0, x1, y1) of the first-person inset, which panels avoid.
        minimap: a :class:`fg_tea.render.floorplan.MiniMap` of the house (None: no mini-map).
        pose: the agent's (x m, y m, yaw deg), for the mini-map.
        site_pixels: site -> (column, row, distance m) of the site's surface in this frame's
            chase view (None or empty: no site names in the view).
        keep_clear: pixel boxes (x0, y0, x1, y1) where no site name is written (the agent).
    """
    h, w = frame.shape[:2]
    s = h / 540.0  # scale relative to a 960x540 frame
    compact = h < COMPACT_HEIGHT
    line = max(int(17 * s), 9)
    fs = 0.42 * s
    pad = max(int(8 * s), 2)
    panels: list[tuple[int, int, int, int]] = []
    if inset_box is not None:
        panels.append(inset_box)
    look = LOOK_COLOURS.get(state.viewpoint_kind, LOOK_COLOURS["site"])

    # Caption bar (top).
    cap_right = w if inset_box is None else inset_box[0] - pad
    cap_h = line + 2 * pad
    _panel(frame, 0, 0, cap_right, cap_h)
    panels.append((0, 0, cap_right, cap_h))
    _text(frame, _fit(f"{state.phase}  {state.caption}", cap_right - 2 * pad, fs * 1.1), pad,
          line + pad // 2, fs * 1.1, (255, 255, 255))

    # Right column: mini-map, then the task graph with its legend.
    col_w = (w - inset_box[0]) if inset_box is not None else int(0.3 * w) // 2 * 2 + 6
    col_x = w - col_w
    y = (inset_box[3] + pad // 2) if inset_box is not None else cap_h + pad // 2
    tasks = state.tasks
    if compact:
        sq = max(3, min(int(col_w / max(len(tasks), 1)), 10))
        task_h = sq + 4 if tasks else 0
    else:
        row_h = max(int(13 * s), 8)
        task_h = (line + pad + math.ceil(len(tasks) / 2) * row_h + row_h + 2 * pad) if tasks else 0
    if minimap is not None:
        avail = h - y - task_h - pad
        mh = min(avail, int(0.3 * h), int(col_w * minimap.aspect))
        mw = min(col_w, int(mh / minimap.aspect)) // 2 * 2
        mh = int(mw * minimap.aspect)
        if mw >= 24 and mh >= 16:
            covered = state.sites_in_view if state.viewpoint is not None else []
            image = minimap.render(mw, mh, pose, state.viewpoint, state.viewpoint_kind, covered,
                                   state.viewpoint_position, state.found_at)
            x0 = w - mw
            region = frame[y:y + mh, x0:x0 + mw]
            cv2.addWeighted(region, 0.15, image, 0.85, -0.5, dst=region)  # truncated, as before
            panels.append((x0, y, w, y + mh))
            if not compact and state.viewpoint is not None:
                tag = (f"room glance: {state.viewpoint_room or state.viewpoint}" if state.viewpoint_kind == "room"
                       else f"close look: {state.viewpoint}")
                th = int(14 * s)
                _panel(frame, x0, y + mh - th, w, y + mh, alpha=0.7)
                _text(frame, _short(tag, int(mw / (6.0 * s))), x0 + pad // 2, y + mh - int(4 * s), fs * 0.72, look)
            y += mh + pad // 2
    if tasks and compact:
        y0 = min(y, h - task_h)
        _panel(frame, col_x, y0, w, y0 + task_h)
        panels.append((col_x, y0, w, y0 + task_h))
        for i, (_, status) in enumerate(tasks):
            x = col_x + 2 + i * sq
            if x + sq - 1 > w:
                break
            cv2.rectangle(frame, (x, y0 + 2), (x + sq - 2, y0 + sq), STATUS_COLOURS.get(status, (200, 200, 200)), -1)
    elif tasks:
        y0 = min(y, h - task_h)
        _panel(frame, col_x, y0, w, y0 + task_h)
        panels.append((col_x, y0, w, y0 + task_h))
        _text(frame, "task graph", col_x + pad, y0 + line, fs, (255, 230, 140))
        half = math.ceil(len(tasks) / 2)
        cw = (col_w - pad) // 2
        for i, (node, status) in enumerate(tasks):
            x = col_x + pad + (i // half) * cw
            yy = y0 + line + pad // 2 + (i % half + 1) * row_h
            cv2.rectangle(frame, (x, yy - row_h + 3), (x + row_h - 4, yy - 1),
                          STATUS_COLOURS.get(status, (200, 200, 200)), -1)
            _text(frame, _short(node, int(cw / (6.2 * s)) - 2), x + row_h, yy - 2, fs * 0.68,
                  (255, 255, 255) if status == "active" else (215, 215, 215))
        # Legend: what each colour means.
        yy = y0 + line + pad // 2 + (half + 1) * row_h + pad // 2
        x = col_x + pad
        for status, colour in STATUS_COLOURS.items():
            cv2.rectangle(frame, (x, yy - row_h + 4), (x + row_h - 5, yy - 1), colour, -1)
            _text(frame, status, x + row_h - 2, yy - 2, fs * 0.62, (200, 200, 200))
            x += row_h + cv2.getTextSize(status, FONT, fs * 0.62, 1)[0][0] + int(3 * s)

    if not compact:
        top = cap_h + pad
        # Location belief bars (left).
        if state.focus_object and state.focus_object in state.locations:
            rows = belief_rows(state)
            width = int(250 * s)
            height = (len(rows) + 1) * line + 2 * pad
            _panel(frame, 0, top, width, top + height)
            panels.append((0, top, width, top + height))
            title = f"q(L[{state.focus_object}])"
            if len(rows) < len(state.sites):
                title += f"  {len(rows)} of {len(state.sites)} sites"
            _text(frame, title, pad, top + line, fs, (255, 230, 140))
            bar_x, bar_w = int(112 * s), int(96 * s)
            in_view = set(state.sites_in_view) if state.viewpoint is not None else {state.selected_site}
            for i, (site, p) in enumerate(rows):
                yy = top + (i + 2) * line
                colour = look if site in in_view else (110, 180, 255)
                _text(frame, _short(site, 15), pad, yy, fs * 0.9)
                cv2.rectangle(frame, (bar_x, yy - int(10 * s)), (bar_x + int(bar_w * p), yy - 1), colour, -1)
                _text(frame, f"{p:.2f}", bar_x + bar_w + int(4 * s), yy, fs * 0.85)
            top += height + pad

        # Candidate scores (left, below the bars), with units.
        if state.candidates:
            shown = state.candidates[:4]
            height = (len(shown) + 2) * line + 2 * pad
            width = int(330 * s)
            _panel(frame, 0, top, width, top + height)
            panels.append((0, top, width, top + height))
            _text(frame, "G = wd*d - wp*q - we*I + wa*rep - l*r", pad, top + line, fs * 0.85, (255, 230, 140))
            cols = [pad, int(150 * s), int(205 * s), int(250 * s), int(290 * s)]
            for x, head in zip(cols, ("object@viewpoint", "G", "d (m)", "q", "I (nats)")):
                _text(frame, head, x, top + 2 * line, fs * 0.72, (190, 190, 190))
            for i, c in enumerate(shown):
                yy = top + (i + 3) * line
                where = logged_viewpoint(c)
                if c.get("viewpoint_kind") == "room":
                    where = "glance " + where
                colour = (255, 200, 40) if i == 0 else (235, 235, 235)
                # A pruned candidate (docs/design.md §6.2) logs bounds: G at least, I at most.
                low, high = ((">=", "<=") if c.get("information_gain_bound") else ("", ""))
                values = (f"{_short(c['object'], 6)}@{_short(where, 14)}", f"{low}{c['total']:+.2f}",
                          f"{c['distance']:.1f}", f"{c['probability']:.2f}",
                          f"{high}{c['information_gain']:.2f}")
                for x, v in zip(cols, values):
                    _text(frame, v, x, yy, fs * 0.8, colour)
            top += height + pad

        # Hidden states (left column, below the candidates).
        if state.states:
            rows = sorted(state.states.items())
            height = (len(rows) + 1) * line + 2 * pad
            y0 = min(top, h - height)
            width = int(250 * s)
            _panel(frame, 0, y0, width, y0 + height)
            panels.append((0, y0, width, y0 + height))
            _text(frame, "hidden states q(z=1)", pad, y0 + line, fs, (255, 230, 140))
            bar_x = int(150 * s)
            for i, (name, p) in enumerate(rows):
                yy = y0 + (i + 2) * line
                _text(frame, _short(name, 21), pad, yy, fs * 0.8)
                cv2.rectangle(frame, (bar_x, yy - int(10 * s)), (bar_x + int(60 * s * p), yy - 1),
                              (70, 190, 90) if p >= 0.9 else (200, 160, 60), -1)
                _text(frame, f"{p:.2f}", bar_x + int(64 * s), yy, fs * 0.8)

    if site_pixels:
        _site_names(frame, state, site_pixels, panels, list(keep_clear), look, s, compact)
    return frame


def _site_names(frame: np.ndarray, state: OverlayState, site_pixels: Mapping[str, tuple[float, float, float]],
                panels: list[tuple[int, int, int, int]], keep_clear: list[tuple[int, int, int, int]],
                look, s: float, compact: bool) -> None:
    """Write the names of the sites in front of the chase camera, nearest first, below each
    site's surface point (so never over what stands on it), skipping any name that would land on
    a panel, the agent or a name already written; point at the sites in view."""
    h, w = frame.shape[:2]
    covered = set(state.sites_in_view) if state.viewpoint is not None else set()
    fs = max(0.36 * s, 0.25)
    taken = list(panels) + keep_clear
    for site, (u, v, dist) in sorted(site_pixels.items(), key=lambda kv: kv[1][2]):
        if dist > LABEL_RANGE_M or not (0 <= u < w and 0 <= v < h):
            continue
        x, y = int(round(u)), int(round(v))
        in_view = site in covered
        colour = look if in_view else (255, 255, 255)
        r = max(int(8 * s * 3.0 / max(dist, 1.0)), 3)
        if in_view and not any(_intersects((x - r, y, x + r, y + 2 * r), t) for t in panels):
            tip = np.array([(x, y + 2), (x - r, y + 2 * r), (x + r, y + 2 * r)], np.int32)
            cv2.fillPoly(frame, [tip], colour, cv2.LINE_AA)  # points up at the surface
        if compact and not in_view:
            continue
        # The name goes below the surface point (on the furniture's front), never over what
        # stands on the surface; if that spot is taken, beside it, lower down.
        (tw, th), base = cv2.getTextSize(site, FONT, fs, 1)
        bw, bh = tw + 6, th + base + 3
        top = y + 2 * r + int(3 * s)
        spots = [(x - bw // 2, top), (x + r + 2, top), (x - r - 2 - bw, top),
                 (x + r + 2, top + bh), (x - r - 2 - bw, top + bh)]
        if in_view:  # the sites in view are worth a longer pointer
            spots += [(x - bw // 2, top + k * bh) for k in range(1, 8)]
        box = next((b for b in ((sx, sy, sx + bw, sy + bh) for sx, sy in spots)
                    if b[0] >= 0 and b[2] <= w and b[3] <= h and not any(_intersects(b, t) for t in taken)),
                   None)
        if box is None:
            continue
        taken.append(box)
        _panel(frame, *box, alpha=0.55)
        cv2.putText(frame, site, (box[0] + 3, box[3] - base - 1), FONT, fs, colour, 1, cv2.LINE_AA)
