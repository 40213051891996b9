"""The video made cheaper again looks the same: frames against those of the code before (commit
be13560), camera images kept for scenes that come again, OpenCV's copies in the render-only views,
and x264's faster preset. (The cost itself is measured by experiments/bench_video.py, not here.)
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fg_tea.render.encoder import PRESET, Mp4Writer
from fg_tea.render.frames import FrameRenderer, RepeatedViews
from fg_tea.render.scene import _contiguous_rgb, floor_mask
from fg_tea.render.video import plan_frames
from video_reference import default_episode, default_options


@pytest.fixture(scope="module")
def default_events(tmp_path_factory):
    return default_episode(tmp_path_factory.mktemp("default"))


def _scenes(plan) -> list[tuple]:
    return [(tuple(f.pose), f.placements, f.held) for f in plan.frames]


@pytest.mark.slow
def test_a_scene_seen_a_while_ago_reuses_its_views_with_the_same_pixels(default_events):
    """The default episode's drone turns and turns back: a frame whose scene came some frames
    before (not the previous one) gives the pixels of rendering it anew, without rendering."""
    options = dataclasses.replace(default_options(), width=192, height=108, workers=1)
    plan = plan_frames(default_events, options)
    scenes = _scenes(plan)
    first = {}
    for index, scene in enumerate(scenes):
        if scene in first and index - first[scene] > 1:
            earlier, again = first[scene], index
            break
        first.setdefault(scene, index)
    else:
        raise AssertionError("no scene comes again after others")
    reusing, fresh = FrameRenderer(plan, options), FrameRenderer(plan, options)
    try:
        for index in range(earlier, again):
            reusing.frame(index)
        rendered = reusing.views.rendered
        after = reusing.frame(again)
        assert reusing.views.rendered == rendered  # nothing rendered for it
        np.testing.assert_array_equal(after, fresh.frame(again))
        assert fresh.views.reused == 0
    finally:
        reusing.close()
        fresh.close()


class _CountingViews:
    """Views whose images are new arrays of a given size, counting the renders."""

    def __init__(self, nbytes: int) -> None:
        self.config, self.renders, self.side = None, 0, int(np.sqrt(nbytes // 3))

    def set_scene_state(self, pose, placements, held) -> None:
        self.pose = pose

    def chase(self, *args) -> np.ndarray:
        self.renders += 1
        return np.full((self.side, self.side, 3), int(self.pose[0]) % 256, np.uint8)

    ego = chase

    def close(self) -> None:
        pass


def test_kept_images_stay_within_their_budget_and_the_oldest_go_first():
    image = 300 * 300 * 3
    views = RepeatedViews(_CountingViews(image), kept_bytes=3 * image)
    for x in (1, 2, 3, 1, 4, 5, 1):  # scene 1 is used again each time before it would be dropped
        views.set_scene_state((x, 0, 0), {}, None)
        assert views.chase(10, 10)[0, 0, 0] == x
    assert views.views.renders == 5 and views.reused == 2
    views.set_scene_state((2, 0, 0), {}, None)  # dropped for 4 and 5: rendered again
    views.chase(10, 10)
    assert views.views.renders == 6
    assert sum(kept.nbytes for scene in views._kept.values() for kept in scene.values()) <= 3 * image  # noqa: SLF001


@pytest.mark.slow
def test_opencv_copies_give_the_pixels_of_numpy_indexing(default_events):
    """The render-only views' RGB copy and floor fill, against the numpy code they replace."""
    options = default_options()
    plan = plan_frames(default_events, options)
    renderer = FrameRenderer(plan, options)
    views = renderer.views.views
    try:
        for index in (0, len(plan.frames) // 2):
            spec = plan.frames[index]
            views.set_scene_state(spec.pose, plan.placements[spec.placements], spec.held)
            camera = views.chase_camera(640, 360, options.chase_distance, options.chase_height,
                                        options.chase_pitch_deg, options.chase_hfov_deg)
            rgb, depth, _ = views.chase_house._render(camera, 640, 360, segmentation=False)  # noqa: SLF001
            expected = np.array(rgb)
            empty = (depth >= 1.0) & floor_mask(camera, 640, 360, views.floor_rect).view(bool)
            assert 0 < empty.mean() < 1
            expected[empty] = views.floor_rgb
            np.testing.assert_array_equal(views._render(views.chase_house, camera, 640, 360), expected)  # noqa: SLF001
    finally:
        renderer.close()


def test_a_copy_of_rgb_channels_is_writable_and_equal():
    rgba = np.random.default_rng(0).integers(0, 256, (36, 64, 4), dtype=np.uint8)
    for view in (rgba[:, :, :3], rgba[::2, :, :3], rgba[:, :, 1:]):
        copy = _contiguous_rgb(view)
        np.testing.assert_array_equal(copy, view)
        assert copy.flags.c_contiguous and copy.flags.writeable and not np.shares_memory(copy, rgba)


def test_the_encoder_uses_the_fast_preset(tmp_path):
    """x264 writes its settings into the stream: ultrafast has no CABAC and no deblocking."""
    writer = Mp4Writer(tmp_path / "a.mp4", 64, 64, fps=10, bframes=0, threads=1)
    for k in range(3):
        writer.write(np.full((64, 64, 3), 40 * k, np.uint8))
    writer.close()
    data = (tmp_path / "a.mp4").read_bytes()
    assert PRESET == "ultrafast"
    assert b"cabac=0" in data and b"deblock=0" in data
