"""Video: H.264 MP4 that decodes, re-rendered from a log (short form in CI; full size is slow)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fg_tea.cli import main
from fg_tea.episode.log import read_log
from fg_tea.render.encoder import probe
from fg_tea.render.video import VideoOptions, plan_frames


@pytest.fixture(scope="module")
def logged(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    assert main(["run", "--no-video", "--out", str(out), "--seed", "1"]) == 0
    return out / "episode.jsonl"


@pytest.fixture(scope="module")
def close_logged(tmp_path_factory):
    """A close-look run (one look per site), the raw material of the viewpoint tests below."""
    out = tmp_path_factory.mktemp("close")
    assert main(["run", "--no-video", "--out", str(out), "--seed", "1",
                 "--model", "factorised_close"]) == 0
    return out / "episode.jsonl"


VIEWPOINT_FIELDS = ("viewpoint", "viewpoint_kind", "sites_in_view", "found_at",
                    "detection_probability", "site_pixel_counts", "viewpoints")


def _as_old_log(events):
    """The same events as a runner without viewpoints wrote them: a look named by its "site"."""
    def old(e):
        out = {k: v for k, v in e.items() if k not in VIEWPOINT_FIELDS}
        if e.get("event") in ("decision", "observation"):
            out["site"] = e["viewpoint"]
        if "candidates" in e:
            out["candidates"] = [{**{k: v for k, v in c.items() if k not in VIEWPOINT_FIELDS},
                                  "site": c["viewpoint"]} for c in e["candidates"]]
        return out
    return [old(e) for e in events]


def test_frame_plan_replays_every_motion_frame(logged):
    events = read_log(logged)
    options = VideoOptions(hold_seconds=0.5)
    plan = plan_frames(events, options)
    motion = sum(len(e.get("motion", [])) for e in events)
    rendered_motion = sum(1 for f in plan.frames if f.repeat == 1)
    assert rendered_motion >= motion  # every pose of motion is a frame
    assert plan.output_frames > motion  # plus held frames for reading
    held = [f for f in plan.frames if f.repeat == 15]
    assert held, "decision frames are held for hold_seconds * fps output frames"
    # The held object rides with the agent between its PICK and its PLACE/INSERT.
    assert {f.held for f in plan.frames} >= {None, "mug", "teabag", "kettle"}


def test_a_draft_is_about_stride_times_shorter_and_cheaper(logged):
    """``--frame-stride n``: about n times fewer output frames and n times fewer rendered frames
    (it used to keep the full length, repeating each rendered frame, and save about 7x at n = 20)."""
    events = read_log(logged)
    full = plan_frames(events, VideoOptions())
    for stride in (5, 20):
        draft = plan_frames(events, VideoOptions(frame_stride=stride))
        assert full.output_frames / draft.output_frames >= 0.8 * stride, stride
        assert len(full.frames) / len(draft.frames) >= 0.5 * stride, stride
        longest = max(f.repeat for f in full.frames)  # the closing pause
        assert max(f.repeat for f in draft.frames) <= max(1, longest // stride)


def test_render_from_log_gives_a_decodable_browser_mp4(logged, tmp_path):
    out = tmp_path / "small.mp4"
    code = main(["render", str(logged), "--out", str(out), "--width", "192", "--height", "108",
                 "--frame-stride", "12", "--hold", "0.1", "--workers", "2"])
    assert code == 0
    info = probe(out)
    assert info["codec"] == "h264" and info["pix_fmt"] == "yuv420p" and info["fps"] == 30.0
    assert (info["width"], info["height"]) == (192, 108)
    assert info["frames"] > 50
    assert not list(tmp_path.glob(".*partial*"))


def test_views_differ_and_overlays_draw(logged, tmp_path):
    import av

    frames = {}
    for view in ("first", "third"):
        out = tmp_path / f"{view}.mp4"
        assert main(["render", str(logged), "--out", str(out), "--view", view, "--width", "128",
                     "--height", "72", "--frame-stride", "40", "--hold", "0.05", "--workers", "1"]) == 0
        with av.open(str(out)) as c:
            frames[view] = next(iter(c.decode(video=0))).to_ndarray(format="rgb24")
    assert not np.array_equal(frames["first"], frames["third"])


def test_bad_log_is_one_line(tmp_path, capsys):
    bad = tmp_path / "x.jsonl"
    bad.write_text('{"event": "something"}\n')
    assert main(["render", str(bad)]) == 2
    assert "not an fg_tea episode log" in capsys.readouterr().err


@pytest.mark.slow
def test_full_size_default_video(logged, tmp_path):
    out = tmp_path / "full.mp4"
    assert main(["render", str(logged), "--out", str(out)]) == 0
    info = probe(out)
    assert (info["width"], info["height"]) == (960, 540) and info["frames"] > 1500


def test_wall_cutaway_is_for_people_only():
    """Lowered walls change the chase view; the agent's camera and evidence stay as they were."""
    from fg_tea.env.base import EnvConfig
    from fg_tea.env.house import PyBulletHouse
    from fg_tea.world.scenario import load_scenario

    house = PyBulletHouse(load_scenario("default_apartment"), EnvConfig(ego_width=160, ego_height=120))
    try:
        house.reset(0)
        ego_before = house.render_ego(160, 120)
        full = house.render_chase(192, 108)
        cut = house.render_chase(192, 108, wall_cutaway=1.0)
        ego_after = house.render_ego(160, 120)
        assert np.abs(full.astype(int) - cut.astype(int)).mean() > 5  # the view opens up
        for before, after in zip(ego_before, ego_after):
            assert np.array_equal(before, after)  # walls restored for the agent
        assert np.array_equal(full, house.render_chase(192, 108))
    finally:
        house.close()


# ------------------------------------------------------------------ viewpoints in the overlays
ROOM_VANTAGES = [{"name": "kitchen_centre", "room": "kitchen", "position": [2.0, 2.2]},
                 {"name": "dining_room_door", "room": "dining_room", "position": [2.0, 4.6]},
                 {"name": "living_room_centre", "room": "living_room", "position": [7.0, 2.8]},
                 {"name": "study_centre", "room": "study", "position": [8.5, 5.5]}]


def _glance_scenario(tmp_path):
    """The default apartment with one room vantage per room, written to a file."""
    import json

    from fg_tea.common.resources import DEFAULT_SCENARIO
    from fg_tea.world.scenario import load_scenario

    data = json.loads(open(load_scenario(DEFAULT_SCENARIO).source).read())
    data["room_vantages"] = ROOM_VANTAGES
    path = tmp_path / "glances.json"
    path.write_text(json.dumps(data))
    return load_scenario(path)


def _with_viewpoints(events, scenario, glance_room: str | None):
    """The log as the viewpoint-aware runner writes it: every look names its viewpoint, and the
    first look at a site of `glance_room` becomes a room glance from that room's vantage."""
    import copy

    events = copy.deepcopy(events)
    start = events[0]
    start["scenario_file"] = scenario.source
    start["viewpoints"] = [{"name": v.name, "kind": v.kind, "position": list(v.position),
                            "sites": list(v.sites), "room": v.room} for v in scenario.viewpoints]
    glance = next((v for v in scenario.viewpoints if v.kind == "room" and v.room == glance_room), None)
    converted = False
    for e in events:
        if e["event"] not in ("decision", "observation"):
            continue
        site = e["viewpoint"]
        if site not in scenario.site_names:  # already a room glance in the runner's own log
            continue
        as_glance = glance is not None and not converted and scenario.site(site).room == glance.room
        vp = glance if as_glance else scenario.viewpoint(site)
        e["viewpoint"], e["viewpoint_kind"] = vp.name, vp.kind
        if e["event"] == "observation":
            e["sites_in_view"] = list(vp.sites)
            e["found_at"] = {o: site for o, seen in e["detections"].items() if seen}
            converted = converted or as_glance
    return events


def test_old_logs_fall_back_to_close_looks(close_logged):
    events = _as_old_log(read_log(close_logged))
    assert not any("viewpoint" in e for e in events)  # written by a runner without viewpoints
    plan = plan_frames(events, VideoOptions(hold_seconds=0.1))
    looks = [o for o in plan.overlays if o.viewpoint is not None]
    assert looks
    for o in looks:
        assert o.viewpoint_kind == "site" and o.sites_in_view == [o.viewpoint]
        assert o.viewpoint_position is not None  # the site's vantage, from episode_start
    assert any(o.found_at for o in looks)


def test_room_glance_is_planned_and_captioned(close_logged, tmp_path):
    scenario = _glance_scenario(tmp_path)
    events = _with_viewpoints(read_log(close_logged), scenario, "dining_room")
    plan = plan_frames(events, VideoOptions(hold_seconds=0.1))
    glances = [o for o in plan.overlays if o.viewpoint_kind == "room"]
    assert glances, "the converted look shows as a room glance"
    dining = [s.name for s in scenario.sites if s.room == "dining_room"]
    for o in glances:
        assert o.viewpoint == "dining_room_door" and o.sites_in_view == dining
        assert o.viewpoint_room == "dining_room" and o.viewpoint_position == [2.0, 4.6]
    assert any("room glance: dining_room" in o.caption for o in glances)
    results = [o.caption for o in glances if "found" in o.caption]  # after the look
    assert results and all(c.startswith("room glance: dining_room (2 sites)")
                           for c in results), results


def test_overlay_marks_a_room_glance(tmp_path):
    """The mini-map and bars show a glance's covered sites, unlike a close look or no look."""
    from fg_tea.render.floorplan import MiniMap
    from fg_tea.render.overlay import LOOK_COLOURS, OverlayState, draw_overlays

    scenario = _glance_scenario(tmp_path)
    minimap = MiniMap(scenario)
    living = [s.name for s in scenario.sites if s.room == "living_room"]
    base = OverlayState(phase="SEARCH", caption="test", sites=list(scenario.site_names),
                        focus_object="mug", locations={"mug": [1 / 8] * 8},
                        tasks=[("search_mug", "active"), ("pick_mug", "pending")])
    glance = dataclasses.replace(base, viewpoint="living_room_centre", viewpoint_kind="room",
                                 sites_in_view=living, viewpoint_position=[7.0, 2.8])
    close = dataclasses.replace(base, viewpoint="coffee_table", sites_in_view=["coffee_table"])
    pose = (7.0, 2.8, 180.0)
    for width, height in ((320, 180), (960, 540)):
        frames = {}
        for name, state in (("none", base), ("close", close), ("glance", glance)):
            frame = np.full((height, width, 3), 128, np.uint8)
            frames[name] = draw_overlays(frame, state, None, minimap, pose)
        cyan = lambda img: int(np.all(np.abs(img.astype(int) - LOOK_COLOURS["room"]) < 30, axis=2).sum())
        assert cyan(frames["glance"]) > cyan(frames["close"]) + 20
        assert cyan(frames["none"]) == cyan(frames["close"])
        assert not np.array_equal(frames["none"], frames["close"])


def test_room_glance_log_renders(close_logged, tmp_path):
    scenario = _glance_scenario(tmp_path)
    log = tmp_path / "glance.jsonl"
    import json

    log.write_text("".join(json.dumps(e) + "\n" for e in _with_viewpoints(read_log(close_logged), scenario,
                                                                            "living_room")))
    out = tmp_path / "glance.mp4"
    assert main(["render", str(log), "--out", str(out), "--width", "256", "--height", "144",
                 "--frame-stride", "40", "--hold", "0.05", "--workers", "1"]) == 0
    assert probe(out)["frames"] > 20


def test_belief_panel_keeps_the_sites_in_view_among_many():
    from fg_tea.render.overlay import MAX_BELIEF_ROWS, OverlayState, belief_rows

    sites = [f"s{i}" for i in range(48)]
    q = list(np.linspace(1, 2, 48) / np.linspace(1, 2, 48).sum())  # the last sites most probable
    state = OverlayState(sites=sites, focus_object="mug", locations={"mug": q}, viewpoint="glance",
                         viewpoint_kind="room", sites_in_view=["s0", "s1"])
    rows = belief_rows(state)
    names = [s for s, _ in rows]
    assert len(rows) == MAX_BELIEF_ROWS and names[:2] == ["s0", "s1"] and names[-1] == "s47"
    assert names == sorted(names, key=sites.index)  # scenario order
    small = OverlayState(sites=sites[:8], focus_object="mug", locations={"mug": q[:8]})
    assert [s for s, _ in belief_rows(small)] == sites[:8]


def test_task_panel_draws_the_current_action_as_active(close_logged):
    """From the first search on, the task panel shows the action being carried out as active."""
    events = read_log(close_logged)
    plan = plan_frames(events, VideoOptions(hold_seconds=0.1))
    active = [[n for n, s in plan.overlays[f.overlay].tasks if s == "active"] for f in plan.frames]
    # The first held frame after the start is the first decision, serving the first search.
    first_decision = next(i for i, f in enumerate(plan.frames) if f.repeat > 1 and i > 0)
    first_search = next(e["action"] for e in events if e.get("event") == "activate")
    assert active[first_decision] == [first_search]
    # Every practical action the log activated is active in some frame of the video.
    activated = {e["action"] for e in events if e.get("event") == "activate"}
    shown = {n for names in active for n in names}
    assert activated <= shown, activated - shown


@pytest.mark.parametrize("pitch", [90.0, -90.0])
def test_the_chase_camera_pitch_endpoints_render(pitch, tmp_path):
    """--third-person-pitch accepts [-90, 90]; straight down and straight up render (they gave
    NaN view matrices: the world's vertical was both the viewing direction and the image's up)."""
    out = tmp_path / "p.png"
    assert main(["preview", "--third-person-pitch", str(pitch), "--out", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_render_still_writes_one_frame_of_the_video_as_a_png(logged, tmp_path, capsys):
    import cv2

    out = tmp_path / "still.png"
    assert main(["render", str(logged), "--still", "0", "--width", "320", "--height", "180",
                 "--out", str(out)]) == 0
    assert "still: " in capsys.readouterr().out
    image = cv2.imread(str(out))
    assert image.shape == (180, 320, 3)
    assert main(["render", str(logged), "--still", "9999999", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--still: frame 9999999 is not in the video" in err[0]
