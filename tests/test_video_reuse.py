"""A frame whose scene is the previous frame's reuses that frame's camera views: the same pixels
as rendering them anew, and fewer images rendered (fg_tea.render.frames.RepeatedViews)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fg_tea.render.frames import FrameRenderer
from fg_tea.render.video import plan_frames
from video_reference import default_episode, default_options


@pytest.mark.slow
def test_a_frame_at_the_previous_scene_reuses_its_views_with_the_same_pixels(tmp_path):
    options = dataclasses.replace(default_options(), width=192, height=108, workers=1)
    plan = plan_frames(default_episode(tmp_path), options)
    scene = [(f.pose, f.placements, f.held) for f in plan.frames]
    again = next(i for i in range(1, len(scene)) if scene[i] == scene[i - 1])
    assert plan.frames[again].overlay != plan.frames[again - 1].overlay  # the overlays differ
    reusing = FrameRenderer(plan, options)
    fresh = FrameRenderer(plan, options)
    try:
        reusing.frame(again - 1)
        after = reusing.frame(again)
        assert reusing.views.reused == 2 and reusing.views.rendered == 2  # chase and inset, once
        alone = fresh.frame(again)
        assert fresh.views.reused == 0
        np.testing.assert_array_equal(after, alone)
        # The kept images are not the drawn-on frame: a third look still matches.
        np.testing.assert_array_equal(reusing.frame(again), alone)
        moved = next(i for i in range(again + 1, len(scene)) if scene[i] != scene[i - 1])
        reusing.frame(moved)
        assert reusing.views.rendered == 4  # a new scene renders anew
    finally:
        reusing.close()
        fresh.close()
