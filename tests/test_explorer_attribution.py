"""The explorer names the factors that moved an object's belief (fg_tea/beliefs/attribution.py,
docs/design.md §9.2): the page's data carries each belief step's ``moved_by`` as logged, and in
real Chromium (as tests/test_explorer_browser.py runs it) the panel lists, for the selected
object, every logged factor with its total variation; a factorised model's page says there is
nothing to attribute, and a log without the field says it does not record it.
"""

from __future__ import annotations

import json

import pytest

from conftest import open_explorer, run_cli
from fg_tea.render.explore import episode_data, read_episode

PROGRAM = '''\
import fg_tea as fg
base = "factorised"

def model(scenario):
    m = fg.program_from_model(scenario, fg.load_model(base))

    @m.factor("teabag")
    def never_in_the_dining_room(teabag):
        return 0.0 if teabag.room == "dining_room" else 1.0

    @m.factor("mug", "teabag", name=KEPT)
    def kept(mug, teabag):
        return 9.0 if mug.room == teabag.room else 1.0
    return m
'''.replace("KEPT", repr("kept <b>together</b> & near"))
#: A factor name with markup in it: the page shows it as text.
KEPT = "kept <b>together</b> & near"


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("attribution")
    (tmp / "mine.py").write_text(PROGRAM)
    for name, model in (("mine", "mine.py"), ("factorised", "factorised")):
        run_cli("run", "--no-video", "--env", "fake", "--model", model, "--out", tmp / name, cwd=tmp)
        run_cli("explore", tmp / name / "episode.jsonl", "--out", tmp / f"{name}.html", cwd=tmp)
    return tmp


def test_the_page_data_holds_each_belief_steps_factors(logs):
    events = read_episode(logs / "mine" / "episode.jsonl")
    data = episode_data(events)
    logged = [events[0]["belief"].get("moved_by", {})] + [e.get("moved_by", {}) for e in events[1:]
                                                          if e["event"] == "belief"]
    assert [m["by"] for m in data["moved"]] == logged
    assert data["inference"] == events[0]["inference"]
    assert {"never_in_the_dining_room", KEPT} <= {f for m in logged for v in m.values() for f in v}
    # each step points at the latest belief step at or before it
    belief_steps = [0] + [i for i, e in enumerate(events) if e["event"] == "belief" and i > 0]
    for i, step in enumerate(data["steps"]):
        assert data["moved"][step["moved"]]["seq"] == events[max(b for b in belief_steps if b <= i)]["seq"]


def _panel(page) -> tuple[str, dict[str, str]]:
    return page.evaluate("""() => {
        const root = document.querySelector('.pane[data-episode="0"]');
        const rows = {};
        root.querySelectorAll('table.moved tr').forEach(tr => {
            rows[tr.dataset.factor] = tr.querySelector('td.tv').textContent.trim(); });
        return [root.querySelector('.moved-head').textContent, rows];
    }""")


def test_the_panel_names_the_factors_in_chromium(browser, logs):
    events = read_episode(logs / "mine" / "episode.jsonl")
    page, problems = open_explorer(browser, logs / "mine.html")
    data = page.evaluate("explorer.data.episodes[0]")
    shown = 0
    for k, step in enumerate(data["steps"]):
        page.evaluate(f"explorer.go({k})")
        moved = data["moved"][step["moved"]]
        for obj in ("mug", "teabag"):
            page.evaluate(f"explorer.object({json.dumps(obj)})")
            head, rows = _panel(page)
            expected = moved["by"].get(obj, {})
            assert rows == {f: f"{tv:.3f}" for f, tv in expected.items()}, (k, obj)
            assert f"event {moved['seq']}" in head
            shown += len(rows)
    assert shown > 0
    page.evaluate("explorer.go(0)")
    page.evaluate("explorer.object('teabag')")
    head, rows = _panel(page)
    assert KEPT in rows and "never_in_the_dining_room" in rows
    assert rows[KEPT] == f"{events[0]['belief']['moved_by']['teabag'][KEPT]:.3f}"
    assert page.locator("table.moved b").count() == 0  # the name's markup is text, not elements
    method = page.inner_text(".pane[data-episode='0'] p.inference")
    assert "location queries: " + events[0]["inference"]["locations"] in method
    assert problems == []
    page.close()


def test_a_factorised_page_and_an_older_log_say_what_they_lack(browser, logs, tmp_path):
    page, problems = open_explorer(browser, logs / "factorised.html")
    head, rows = _panel(page)
    assert rows == {} and "nothing to attribute" in head
    page.close()
    noted = [json.loads(line) for line in (logs / "factorised" / "episode.jsonl").read_text().splitlines()]
    noted[0]["inference"]["attribution"]["notes"] = ["nothing attributed: <i>a capacity</i> too large"]
    (tmp_path / "noted.jsonl").write_text("".join(json.dumps(e) + "\n" for e in noted))
    run_cli("explore", tmp_path / "noted.jsonl", "--out", tmp_path / "noted.html", cwd=tmp_path)
    page, noted_problems = open_explorer(browser, tmp_path / "noted.html")
    head, rows = _panel(page)
    assert rows == {} and head == "nothing attributed: <i>a capacity</i> too large"
    assert noted_problems == []
    page.close()
    events = [json.loads(line) for line in (logs / "mine" / "episode.jsonl").read_text().splitlines()]
    events[0].pop("inference")
    old = tmp_path / "old.jsonl"
    old.write_text("".join(json.dumps(e) + "\n" for e in events))
    run_cli("explore", old, "--out", tmp_path / "old.html", cwd=tmp_path)
    page, more = open_explorer(browser, tmp_path / "old.html")
    head, rows = _panel(page)
    assert rows == {} and "does not record which factors" in head
    assert "inference in episode_start" in page.inner_text("body")
    assert problems == [] and more == []
    page.close()
