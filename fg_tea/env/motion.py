"""Motion along a path: the poses of each frame when the agent walks or turns (docs/design.md §8).

Uses the embodiment parameters of :class:`fg_tea.env.base.EnvConfig` (step length, turn rate).
"""

from __future__ import annotations

import math
from typing import Sequence

from fg_tea.env.base import EnvConfig
from fg_tea.world.interface import Pose
from fg_tea.world.navigation import Point


def wrap_deg(angle: float) -> float:
    """Angle in degrees wrapped to (-180, 180]."""
    a = math.fmod(angle + 180.0, 360.0)
    if a <= 0:
        a += 360.0
    return a - 180.0


def follow_path(pose: Pose, corners: Sequence[Point], config: EnvConfig) -> list[Pose]:
    """Per-frame poses that drive the agent from `pose` through `corners` (docs/design.md §8.2).

    Each frame either turns in place (heading error > ``turn_before_move_deg``) or turns and moves
    along the straight segment to the next corner. Turns are at most ``turn_step_deg`` and moves
    at most ``movement_step`` per frame. Positions stay on the segments between corners, so a path
    that is collision-free on the grid stays collision-free when followed.

    Args:
        pose: the starting pose; `corners[0]` is normally its position and is skipped if so.
        corners: floor points (m) to visit in order.
        config: movement parameters.

    Returns:
        The poses after each frame; the last is at the final corner.
    """
    frames: list[Pose] = []
    x, y, yaw = pose.x, pose.y, wrap_deg(pose.yaw_deg)
    for tx, ty in corners:
        while True:
            dx, dy = tx - x, ty - y
            dist = math.hypot(dx, dy)
            if dist < 1e-9:
                break
            err = wrap_deg(math.degrees(math.atan2(dy, dx)) - yaw)
            turn = max(-config.turn_step_deg, min(config.turn_step_deg, err))
            yaw = wrap_deg(yaw + turn)
            if abs(err) <= config.turn_before_move_deg:
                if dist <= config.movement_step:
                    x, y = tx, ty
                else:
                    x += dx / dist * config.movement_step
                    y += dy / dist * config.movement_step
            frames.append(Pose(x, y, yaw))
    return frames


def turn_frames(pose: Pose, target_yaw_deg: float, config: EnvConfig) -> list[Pose]:
    """Per-frame poses turning in place until within ``face_tolerance_deg`` of the target yaw."""
    frames: list[Pose] = []
    yaw = wrap_deg(pose.yaw_deg)
    while True:
        err = wrap_deg(target_yaw_deg - yaw)
        if abs(err) <= config.face_tolerance_deg:
            return frames
        yaw = wrap_deg(yaw + max(-config.turn_step_deg, min(config.turn_step_deg, err)))
        frames.append(Pose(pose.x, pose.y, yaw))


#: Where a held object rides, in the agent frame: metres forward and metres below the body centre.
#: Low enough to stay below the egocentric camera's field of view.
HELD_FORWARD_M = 0.16
HELD_BELOW_M = 0.46


def held_position(pose: Pose, config: EnvConfig) -> tuple[float, float, float]:
    """Where a held object's base rides for agent pose `pose` (x, y, z in m; z from the floor).

    The agent's body hovers at ``config.sensor_height``; the object hangs HELD_BELOW_M under it
    and HELD_FORWARD_M ahead of it, below the egocentric camera's field of view.
    """
    yaw = math.radians(pose.yaw_deg)
    return (pose.x + HELD_FORWARD_M * math.cos(yaw), pose.y + HELD_FORWARD_M * math.sin(yaw),
            config.sensor_height - HELD_BELOW_M)


def motion_of(frames: Sequence[Pose]) -> tuple[tuple[float, float, float], ...]:
    rows = [p.as_list() for p in frames]  # rounded as the log keeps them
    return tuple((x, y, yaw) for x, y, yaw in rows)
