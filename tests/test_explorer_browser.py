"""The explorer's pages in a real browser: headless Chromium (the system's, Debian's package)
driven by Playwright (docs/design.md §9.2).

Each page is loaded from a file URL with no console errors; every event is stepped through and
every displayed probability (each site's location probability of the chosen object, each hidden
state) is read back from the page and checked against the log itself, to the printed 3 decimals;
the first differing decision of a known pair is checked; screenshots are taken at three steps and
must not be blank.

Locally these tests skip with a one-line reason when Chromium or Playwright is missing; under CI
(``FG_TEA_BROWSER_REQUIRED=1``, set by .ci/run) a missing browser is a failure.
"""

from __future__ import annotations

import json

import pytest

from conftest import open_explorer, run_cli
from fg_tea.episode.log import read_log

@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """The default episode (factorised and joint: they part at decision 2), a 27-site
    milk-and-sugar episode, and their pages."""
    from fg_tea.study.sweep import Job, run_job

    tmp = tmp_path_factory.mktemp("browser")
    for model in ("factorised", "joint"):
        run_cli("run", "--no-video", "--model", model, "--out", tmp / model, cwd=tmp)
    run_job(Job("generated_medium_milk_sugar", 3, "factorised", "efe", task="make_tea_milk_sugar"),
            tmp / "milk" / "episode.jsonl")
    run_cli("explore", tmp / "factorised" / "episode.jsonl", "--out", tmp / "one.html", cwd=tmp)
    run_cli("explore", tmp / "factorised" / "episode.jsonl", tmp / "joint" / "episode.jsonl",
         "--out", tmp / "two.html", cwd=tmp)
    run_cli("explore", tmp / "milk" / "episode.jsonl", "--out", tmp / "milk.html", cwd=tmp)
    return tmp


def expected_states(events: list[dict]) -> list[tuple[dict, dict]]:
    """(locations, hidden states) after each event, read from the log itself: the last
    observation's ``after`` or belief snapshot's ``locations``, the last states snapshot, reading
    or action's ``belief_after``."""
    start = events[0]
    loc = {o: list(p) for o, p in start["belief"]["locations"].items()}
    states = dict(start["belief"]["states"])
    out = []
    for e in events:
        if e["event"] == "observation":
            loc.update(e["after"])
        elif e["event"] == "belief":
            loc.update(e["locations"])
            states.update(e["states"])
        elif e["event"] == "state_reading" and e.get("state") in states:
            states[e["state"]] = e["after"]
        elif e["event"] == "action" and isinstance(e.get("belief_after"), dict):
            states.update(e["belief_after"])
        out.append(({o: list(p) for o, p in loc.items()}, dict(states)))
    return out


def _read(page, pane: int) -> tuple[dict[str, str], dict[str, str]]:
    return page.evaluate(
        """(pane) => {
            const root = document.querySelector(`.pane[data-episode="${pane}"]`);
            const sites = {}, states = {};
            root.querySelectorAll('text.site-p').forEach(t => { sites[t.dataset.site] = t.textContent.trim(); });
            root.querySelectorAll('td.p').forEach(t => { states[t.dataset.state] = t.textContent.trim(); });
            return [sites, states];
        }""", pane)


def _check_every_step(page, logs: list[list[dict]]) -> int:
    """Step through every slider position; check every displayed probability against the log."""
    expected = [expected_states(events) for events in logs]
    sites = [[s["name"] for s in events[0]["sites"]] for events in logs]
    pairs = page.evaluate("explorer.data.pairs")
    objects = page.evaluate("Array.from(document.querySelectorAll('#object option')).map(o => o.value)")
    checked = 0
    for i, pair in enumerate(pairs):
        if i % 7 == 0:  # each object in turn shades the plan
            page.select_option("#object", objects[(i // 7) % len(objects)])
        page.evaluate(f"explorer.go({i})")
        chosen = page.eval_on_selector("#object", "s => s.value")
        for pane, step in enumerate(pair):
            shown_sites, shown_states = _read(page, pane)
            loc, states = expected[pane][step]
            if chosen in loc:
                assert shown_sites == {s: f"{p:.3f}" for s, p in zip(sites[pane], loc[chosen])}, (i, pane, chosen)
            assert shown_states == {k: f"{v:.3f}" for k, v in states.items()}, (i, pane)
            checked += len(shown_sites) + len(shown_states)
    return checked


def _not_blank(png: bytes) -> None:
    import io

    from PIL import Image

    image = Image.open(io.BytesIO(png)).convert("RGB").resize((200, 140))
    colours = len(image.getcolors(maxcolors=1 << 20) or ())
    assert colours > 40, f"the screenshot looks blank ({colours} colours)"


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_one_episode_every_step_shows_the_logs_probabilities(browser, pages):
    events = read_log(pages / "factorised" / "episode.jsonl")
    page, problems = open_explorer(browser, pages / "one.html")
    assert _check_every_step(page, [events]) > 500
    n = len(page.evaluate("explorer.data.pairs"))
    for i in (0, n // 2, n - 1):  # three steps, three screenshots
        page.evaluate(f"explorer.go({i})")
        png = page.screenshot(full_page=True)
        _not_blank(png)
    # the keyboard and the buttons step too
    page.evaluate("explorer.go(0)")
    page.keyboard.press("ArrowRight")
    page.click("#next")
    assert page.evaluate("explorer.index()") == 2
    page.keyboard.press("End")
    assert page.evaluate("explorer.index()") == n - 1
    assert "/ " + str(n) in page.inner_text("#step-label")
    # the candidate table marks the logged choice; a header click sorts it
    first = next(i for i, e in enumerate(events) if e["event"] == "decision")
    page.evaluate(f"explorer.go({first})")
    chosen = page.inner_text(".pane[data-episode='0'] table.candidates tr.chosen")
    assert events[first]["object"] in chosen and events[first]["viewpoint"] in chosen
    page.click(".pane[data-episode='0'] table.candidates th:has-text('total')")
    totals = page.eval_on_selector_all(".pane[data-episode='0'] table.candidates tbody tr",
                                       "rows => rows.map(r => r.dataset.total)")
    values = [float(t) for t in totals if t not in (None, "")]
    assert values and (values == sorted(values) or values == sorted(values, reverse=True))
    # a click on a site shows its history for every object
    site = events[0]["sites"][0]["name"]
    page.click(f".pane[data-episode='0'] circle.site[data-site='{site}']")
    history = page.inner_text(f".pane[data-episode='0'] .site-history[data-site='{site}']")
    assert all(obj in history for obj in events[0]["objects"])
    assert problems == []
    page.close()


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_two_episodes_side_by_side_mark_where_choices_part(browser, pages):
    logs = [read_log(pages / m / "episode.jsonl") for m in ("factorised", "joint")]
    decisions = [[(e["object"], e["viewpoint"]) for e in ev if e["event"] == "decision"] for ev in logs]
    first = next(k for k in range(min(map(len, decisions))) if decisions[0][k] != decisions[1][k])
    page, problems = open_explorer(browser, pages / "two.html")
    assert page.get_attribute("#divergence", "data-decision") == str(first)
    page.click("#goto-divergence")
    pair = page.evaluate("explorer.data.pairs[explorer.index()]")
    for pane, events in enumerate(logs):
        assert events[pair[pane]]["event"] == "decision"
        assert (events[pair[pane]]["object"], events[pair[pane]]["viewpoint"]) == decisions[pane][first]
    assert _check_every_step(page, logs) > 1000
    _not_blank(page.screenshot(full_page=True))
    assert problems == []
    page.close()


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_a_27_site_five_object_page(browser, pages):
    events = read_log(pages / "milk" / "episode.jsonl")
    assert len(events[0]["sites"]) >= 20 and len(events[0]["objects"]) == 5
    assert (pages / "milk.html").stat().st_size < 5e6
    page, problems = open_explorer(browser, pages / "milk.html")
    assert _check_every_step(page, [events]) > 1000
    _not_blank(page.screenshot(full_page=True))
    assert problems == []
    page.close()


def test_a_page_that_lacks_its_house_says_so(browser, pages, tmp_path):
    text = (pages / "factorised" / "episode.jsonl").read_text().splitlines()
    start = json.loads(text[0])
    start["scenario"], start["scenario_file"], start["inputs"]["scenario"] = "gone#1", "gone.json", None
    log = tmp_path / "old.jsonl"
    log.write_text("\n".join([json.dumps(start)] + text[1:len(text) // 2]) + "\n")
    run_cli("explore", log, "--out", tmp_path / "old.html", cwd=tmp_path)
    page, problems = open_explorer(browser, tmp_path / "old.html")
    notices = page.inner_text("#notices")
    assert "gone.json" in notices and "episode_end" in notices
    _not_blank(page.screenshot(full_page=True))
    assert problems == []
    page.close()


@pytest.mark.slow
def test_the_video_is_seeked_to_each_steps_last_frame(browser, tmp_path):
    """A small video (the log records how it was rendered): each step seeks it to the step's
    last frame in the frame plan (docs/design.md §8.6)."""
    from fg_tea.render.video import VideoOptions, plan_frames

    run_cli("run", "--width", "160", "--height", "96", "--scene-scale", "0.5", "--frame-stride", "10",
         "--fps", "10", "--hold", "0.5", "--out", tmp_path / "v", cwd=tmp_path)
    run_cli("explore", tmp_path / "v" / "episode.jsonl", "--video", tmp_path / "v" / "episode.mp4",
         "--out", tmp_path / "page" / "v.html", cwd=tmp_path)
    events = read_log(tmp_path / "v" / "episode.jsonl")
    plan = plan_frames(events, VideoOptions(width=160, height=96, scene_scale=0.5, frame_stride=10, fps=10,
                                            hold_seconds=0.5))
    page, problems = open_explorer(browser, tmp_path / "page" / "v.html")
    page.wait_for_function("document.getElementById('video').readyState >= 1", timeout=10_000)
    assert page.get_attribute("#video", "src") == "../v/episode.mp4"
    starts = [plan.event_frames[e["seq"]] for e in events] + [plan.output_frames]
    for i in (3, len(events) // 2, len(events) - 3):  # the step's last frame: the state after it
        page.evaluate(f"explorer.go({i})")
        page.wait_for_function(f"Math.abs(document.getElementById('video').currentTime - "
                               f"{max(starts[i], starts[i + 1] - 1) / 10}) < 0.051", timeout=5_000)
    assert page.evaluate("document.getElementById('video').error") is None
    assert problems == []
    page.close()
