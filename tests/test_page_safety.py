"""No page fg_tea writes runs script that came from its inputs (docs/design.md §9.2).

Pages are filled once, each slot escaped for its context (:mod:`fg_tea.render.page`), under a
Content-Security-Policy that runs only the page's own script. Checked three ways:

- the writer's helpers alone (a marker inside a value is never filled again);
- every name a log carries (scenario, model, planner, task, action, object, category, state, site,
  room, viewpoint, label) rewritten with each class of hostile payload (event-handler attributes,
  ``</script>``, ``<!--``, ``</title>``, attribute breaks, template markers, ``javascript:``, lone
  surrogates, line separators), through ``fg-tea explore`` (whose reader refuses lone surrogates
  in one line) and through the page writer alone (which must be safe whatever reaches it); every
  page opened in headless Chromium: no script of the payload ran, no dialog opened, no console
  error, the page finished loading, shows the names as text and still steps;
- the real commands (``run`` with a hostile model name, ``explore --label``, ``compare --pages``'s
  world pages and index), opened the same way.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fg_tea.cli.main import main
from fg_tea.render.page import fill, html_text, json_script

#: One payload of each class; each sets window.__pwned (or opens a dialog) if it ever runs.
PAYLOADS = (
    '<img src=x onerror="window.__pwned=1">',
    "</script><script>window.__pwned=2</script>",
    "<!--<script>window.__pwned=3</script>",
    "/*DATA*/{{TITLE}}/*SCRIPT*/{{CSP}}",
    '"><svg onload=window.__pwned=5>',
    "</title><script>alert(6)</script>",
    "' onfocus='window.__pwned=7' autofocus x='",
    "javascript:window.__pwned=8",
    "\ud800 \udfff lone",
    "\u2028\u2029<iframe srcdoc='<script>parent.__pwned=10</script>'>",
)


def test_a_marker_inside_a_value_is_not_filled_again():
    page = fill("<h1>{{TITLE}}</h1><script type=application/json>/*DATA*/</script>",
                {"TITLE": html_text("a/*DATA*/b{{TITLE}}"), "DATA": json_script({"x": "</script><!--"})})
    assert page == ('<h1>a/*DATA*/b{{TITLE}}</h1><script type=application/json>'
                    '{"x":"\\u003c/script\\u003e\\u003c!--"}</script>')


def test_escapes_leave_no_markup_and_survive_lone_surrogates():
    assert html_text('<a href="x">\ud800') == "&lt;a href=&quot;x&quot;&gt;\ufffd"
    text = json_script({"name\ud800": ["<b>&", 1.5]})
    assert not set("<>&") & set(text) and text.isascii()
    assert json.loads(text) == {"name\ud800": ["<b>&", 1.5]}
    with pytest.raises(KeyError):
        fill("{{A}}", {"A": "", "B": ""})


def _names(start: dict) -> list[str]:
    """Every name an episode_start carries that a page may show."""
    names = [start["scenario"], start["model"], start["planner"], start["task"]]
    names += start["objects"] + list(start["categories"].values()) + list(start["graph"])
    names += list(start["belief"]["states"])
    for site in start["sites"]:
        names += [site["name"], site["room"]]
    names += [v["name"] for v in start["viewpoints"]]
    return list(dict.fromkeys(n for n in names if isinstance(n, str) and n))


def _rename(value, mapping: dict[str, str]):
    if isinstance(value, str):
        return mapping.get(value, value)
    if isinstance(value, list):
        return [_rename(v, mapping) for v in value]
    if isinstance(value, dict):
        return {mapping.get(k, k): _rename(v, mapping) for k, v in value.items()}
    return value


def hostile_events(events: list[dict], shift: int, payloads=PAYLOADS) -> tuple[list[dict], dict[str, str]]:
    """`events` with every name given a payload (name i gets class (i + shift) mod the number of
    classes), and the renaming."""
    names = _names(events[0])
    mapping = {n: n + payloads[(i + shift) % len(payloads)] for i, n in enumerate(names)}
    renamed = [_rename(e, mapping) for e in events]
    renamed[0]["scenario_file"] = "gone.json"  # the house is drawn from the log
    return renamed, mapping


#: The payloads a log may carry: the reader refuses a lone surrogate (it is not text) in one line.
TEXT_PAYLOADS = tuple(p for p in PAYLOADS if "lone" not in p)


@pytest.fixture(scope="module")
def episode(tmp_path_factory) -> list[dict]:
    tmp = tmp_path_factory.mktemp("safety")
    assert main(["run", "--no-video", "--model", "joint", "--out", str(tmp / "run")]) == 0
    return [json.loads(line) for line in (tmp / "run" / "episode.jsonl").read_text().splitlines()]


def open_safely(browser, path: Path):
    """Open `path`; return the page once it has loaded, and the problems seen (console errors and
    warnings, page errors, dialogs, a payload that ran)."""
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    problems: list[str] = []
    page.on("console", lambda m: problems.append(f"{m.type}: {m.text}") if m.type in ("error", "warning") else None)
    page.on("pageerror", lambda e: problems.append(f"pageerror: {e}"))
    page.on("dialog", lambda d: (problems.append(f"dialog: {d.message}"), d.dismiss()))
    page.goto(path.as_uri())
    page.wait_for_load_state("load")
    return page, problems


def assert_nothing_ran(page, problems: list[str]) -> None:
    assert page.evaluate("window.__pwned") is None
    assert page.evaluate("document.querySelectorAll('iframe, img[src=x], svg[onload]').length") == 0
    assert problems == []


def assert_explorer_works(page) -> None:
    page.wait_for_function("document.body.dataset.ready === '1'", timeout=10_000)
    last = page.evaluate("document.getElementById('step-slider').max")
    page.keyboard.press("End")
    assert page.evaluate("document.getElementById('step-slider').value") == last != "0"
    n = int(last) + 1  # the label counts from 1
    assert f"step {n} / {n}" in page.inner_text("#step-label")


def _shown_as_text(page, mapping: dict[str, str], model: str) -> None:
    shown = mapping[model].replace("\ud800", "\ufffd").replace("\udfff", "\ufffd")
    assert shown.split("<")[0] in page.inner_text("h1") and page.title() == page.inner_text("h1")
    options = page.evaluate("[...document.querySelectorAll('#object option')].map(o => o.textContent)")
    assert any(o.startswith("mug") and len(o) > 3 for o in options)  # the hostile object name, as text


@pytest.mark.parametrize("shift", range(len(TEXT_PAYLOADS)))
def test_hostile_names_in_a_log_stay_text(browser, episode, shift, tmp_path):
    """Through the command: `fg-tea explore` of a log whose every name is hostile."""
    events, mapping = hostile_events(episode, shift, TEXT_PAYLOADS)
    log, page_path = tmp_path / "episode.jsonl", tmp_path / "page.html"
    log.write_text("".join(json.dumps(e) + "\n" for e in events))
    assert main(["explore", str(log), "--out", str(page_path)]) == 0
    page, problems = open_safely(browser, page_path)
    assert_explorer_works(page)
    assert_nothing_ran(page, problems)
    _shown_as_text(page, mapping, episode[0]["model"])
    page.close()


@pytest.mark.slow
@pytest.mark.parametrize("shift", range(len(PAYLOADS)))
def test_the_page_writer_is_safe_whatever_reaches_it(browser, episode, shift, tmp_path):
    """The writer alone, with names no reader would pass (lone surrogates included)."""
    from fg_tea.render.explore import page_data, write_page

    events, mapping = hostile_events(episode, shift)
    page_path = tmp_path / "page.html"
    title = mapping[episode[0]["model"]] + " · " + mapping[episode[0]["scenario"]]
    write_page(page_path, page_data([("episode.jsonl", events)]), title)
    page, problems = open_safely(browser, page_path)
    assert_explorer_works(page)
    assert_nothing_ran(page, problems)
    _shown_as_text(page, mapping, episode[0]["model"])
    page.close()


def test_a_log_with_a_lone_surrogate_is_refused_in_one_line(episode, tmp_path, capsys):
    events, _ = hostile_events(episode, PAYLOADS.index("\ud800 \udfff lone"))
    log = tmp_path / "episode.jsonl"
    log.write_text("".join(json.dumps(e) + "\n" for e in events))
    assert main(["explore", str(log)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "surrogate" in err


def test_a_page_with_markup_forced_in_runs_none_of_it(browser, episode, tmp_path):
    """The Content-Security-Policy on its own: markup spliced into a written page's body by hand
    (as no writer of fg_tea does) is parsed, yet its handler and script do not run."""
    log, page_path = tmp_path / "episode.jsonl", tmp_path / "page.html"
    log.write_text("".join(json.dumps(e) + "\n" for e in episode))
    assert main(["explore", str(log), "--out", str(page_path)]) == 0
    html = page_path.read_text()
    page_path.write_text(html.replace("<body>", "<body>" + PAYLOADS[0] + PAYLOADS[1], 1))
    page, problems = open_safely(browser, page_path)
    assert page.evaluate("window.__pwned") is None
    assert page.evaluate("document.querySelectorAll('img[src=x]').length") == 1  # parsed, not run
    assert any("Content Security Policy" in p for p in problems)
    page.close()


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_commands_write_safe_pages_from_a_hostile_model_and_label(browser, tmp_path):
    name = "m" + "".join(p for p in PAYLOADS if "lone" not in p)  # TOML has no lone surrogates
    model = tmp_path / "m.toml"
    model.write_text('extends = "factorised"\nname = ' + json.dumps(name) + "\n")
    assert main(["run", "--no-video", "--model", str(model), "--out", str(tmp_path / "r")]) == 0
    assert main(["explore", str(tmp_path / "r" / "episode.jsonl"), "--label", "<b onclick=x()>/*DATA*/",
                 "--out", str(tmp_path / "one.html")]) == 0
    assert main(["compare", "--env", "fake", "--worlds", "2", "--models", "factorised", str(model),
                 "--planners", "efe", "--pages", "1", "--workers", "1", "--out", str(tmp_path / "c")]) == 0
    worlds = sorted((tmp_path / "c" / "explore").glob("world*.html"))
    assert len(worlds) == 1
    for path in [tmp_path / "one.html", *worlds]:
        page, problems = open_safely(browser, path)
        assert_explorer_works(page)
        assert_nothing_ran(page, problems)
        page.close()
    page, problems = open_safely(browser, tmp_path / "c" / "index.html")
    assert_nothing_ran(page, problems)
    assert "m<img" in page.inner_text("#worlds thead")  # the model's name, shown as text
    page.close()


def test_a_log_too_large_for_a_page_is_refused_before_it_is_read(tmp_path, capsys):
    from fg_tea.render.explore import EXPLORE_LOG_MAX_BYTES

    log = tmp_path / "big.jsonl"
    with log.open("wb") as f:  # sparse: nothing is written, the size is what is checked
        f.truncate(EXPLORE_LOG_MAX_BYTES + 1)
    assert main(["explore", str(log)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "big.jsonl: size:" in err and "64 MB" in err
    assert not (tmp_path / "big.html").exists()


def test_a_page_over_its_cap_is_refused_and_nothing_written(episode, tmp_path, monkeypatch):
    import fg_tea.render.explore as explore
    from fg_tea.common.errors import InputError

    data = explore.page_data([("episode.jsonl", episode)])
    monkeypatch.setattr(explore, "PAGE_MAX_BYTES", 10_000)
    with pytest.raises(InputError, match="above the 0 MB a page may hold"):
        explore.write_page(tmp_path / "p.html", data, "t")
    assert not (tmp_path / "p.html").exists()
