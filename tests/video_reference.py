"""The video reference frames, and the default episode and options they were rendered with
(fg_tea.cli.defaults)."""

from __future__ import annotations

from fg_tea.cli.defaults import default_episode, default_options

#: Output frames of the default episode's video kept as references: the README's still (a room
#: glance), a frame of motion with a moving inset, a carried object, and the end. (Frame 40 was
#: one too, until a decision's caption began to say which searches its look serves.)
FRAMES = (360, 600, 1100, 2240)

__all__ = ["FRAMES", "default_episode", "default_options"]
