"""The explorer as a newcomer first met it, in the real browser (headless system Chromium): room
names that do not overlap, a candidate table and a task graph that fit half of a 1,400 px window,
the episode's metrics on the last step, site names as the log writes them, and a SEARCH that
serves several objects said so. Also the counts ``fg-tea explore`` prints."""

from __future__ import annotations


import pytest

from conftest import open_explorer, run_cli
from fg_tea.episode.log import read_log


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """The default episode under the factorised and the joint model (fake house), one page of
    the first and one of both."""
    import fg_tea as fg

    tmp = tmp_path_factory.mktemp("newcomer")
    scenario = fg.load_scenario("default_apartment")
    for model in ("factorised", "joint"):
        (tmp / model).mkdir()
        fg.run_episode(scenario, fg.load_model(model), env="fake", log=tmp / model / "episode.jsonl")
    one = run_cli("explore", tmp / "factorised" / "episode.jsonl", "--out", tmp / "one.html", cwd=tmp)
    two = run_cli("explore", tmp / "factorised" / "episode.jsonl", tmp / "joint" / "episode.jsonl",
               "--out", tmp / "two.html", cwd=tmp)
    return tmp, one.stdout, two.stdout


def _first_decision_with_several_objects(events) -> int:
    decisions = [e for e in events if e["event"] == "decision"]
    return next(k for k, e in enumerate(decisions) if len(e.get("objects", [])) > 1)


@pytest.mark.parametrize("name", ["one.html", "two.html"])
def test_room_names_do_not_overlap(browser, pages, name):
    page, problems = open_explorer(browser, pages[0] / name)
    boxes = page.evaluate("""() => [...document.querySelectorAll('.pane')].map(p =>
        [...p.querySelectorAll('svg.plan .rooms text')].map(t => {
          const r = t.getBoundingClientRect(); return [t.textContent, r.left, r.top, r.right, r.bottom]; }))""")
    for pane in boxes:
        assert {n.replace(" ", "") for n, *_ in pane} >= {"diningroom", "livingroom"}
        for i, (na, *a) in enumerate(pane):
            for nb, *b in pane[i + 1:]:
                apart = a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1]
                assert apart, (na, a, nb, b)
    assert not problems, problems


@pytest.mark.parametrize("name", ["one.html", "two.html"])
def test_the_candidate_table_and_the_task_graph_fit_1400_px(browser, pages, name):
    page, problems = open_explorer(browser, pages[0] / name)
    n_decisions = page.evaluate("explorer.data.episodes[0].decisions.length")
    for _ in range(n_decisions):
        page.keyboard.press("PageDown")
        sizes = page.evaluate("""() => [...document.querySelectorAll('.candidates-wrap, .tasks-wrap')].map(w =>
            [w.className, w.scrollWidth, w.clientWidth, w.getBoundingClientRect().right])""")
        assert len(sizes) == 2 * len(page.evaluate("explorer.data.episodes"))
        for cls, scroll, client, right in sizes:
            assert scroll <= client + 1, (cls, scroll, client)  # nothing cut off, nothing to scroll
            assert right <= 1400, (cls, right)
    assert not problems, problems


def test_the_last_step_shows_the_episodes_metrics(browser, pages):
    metrics = read_log(pages[0] / "factorised" / "episode.jsonl")[-1]
    page, problems = open_explorer(browser, pages[0] / "one.html")
    page.keyboard.press("End")
    caption = page.evaluate("document.querySelector('.pane .caption').textContent")
    assert f"{metrics['actions_complete']} of {metrics['actions_total']} actions complete" in caption
    assert f"{metrics['total_distance']:.1f} m travelled" in caption
    assert f"{metrics['frames']} simulation frames" in caption and "complete" in caption
    assert not problems, problems


def test_site_labels_are_the_sites_names(browser, pages):
    events = read_log(pages[0] / "factorised" / "episode.jsonl")
    page, problems = open_explorer(browser, pages[0] / "one.html")
    shown = page.evaluate("[...document.querySelectorAll('.pane svg.plan text.site-name')].map(t => t.textContent)")
    assert sorted(shown) == sorted(s["name"].replace("_", " ") for s in events[0]["sites"])
    assert not problems, problems


def test_a_search_serving_several_objects_is_said_on_the_page(browser, pages):
    events = read_log(pages[0] / "factorised" / "episode.jsonl")
    k = _first_decision_with_several_objects(events)
    decision = [e for e in events if e["event"] == "decision"][k]
    page, problems = open_explorer(browser, pages[0] / "one.html")
    for _ in range(k + 1):
        page.keyboard.press("PageDown")
    head = page.evaluate("document.querySelector('.pane .decision-head').textContent")
    assert f"decision {k + 1} " in head
    assert f"this SEARCH serves {len(decision['objects'])} objects ({', '.join(decision['objects'])})" in head
    assert not problems, problems


def test_explore_prints_the_counts_the_page_shows(browser, pages):
    tmp, one, two = pages
    steps = [len(read_log(tmp / m / "episode.jsonl")) for m in ("factorised", "joint")]  # a step per event
    assert f", {steps[0]} steps)" in one
    page, problems = open_explorer(browser, tmp / "two.html")
    page.keyboard.press("End")
    label = page.evaluate("document.getElementById('step-label').textContent")
    positions = page.evaluate("explorer.data.pairs.length")
    assert label == f"step {positions} / {positions}"
    assert f"({positions} slider positions: A {steps[0]} steps, B {steps[1]} steps" in two.replace("MB, ", "(")
    assert not problems, problems
