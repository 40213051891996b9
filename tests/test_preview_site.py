"""`fg-tea preview --site NAME` renders the view from a site's or room vantage's inspection pose
and prints the visible pixels of each object, as an inspection counts them (docs/guide/commands.md)."""

from __future__ import annotations

import pytest
import re
import subprocess
import sys

import cv2


def _preview(tmp_path, *args):
    return subprocess.run([sys.executable, "-m", "fg_tea.cli", "preview", *args], capture_output=True,
                          text=True, timeout=600, cwd=tmp_path, stdin=subprocess.DEVNULL)


@pytest.mark.slow  # over 1.5 s: the full suite runs it, the quick loop does not
def test_a_close_look_and_a_room_glance_are_rendered_with_their_pixels(tmp_path):
    close = _preview(tmp_path, "--site", "kitchen_counter")
    assert close.returncode == 0, close.stderr
    # The default apartment keeps the kettle on the kitchen counter: the look sees it.
    assert re.search(r"view from kitchen_counter \(site, sites kitchen_counter\): .*kettle [\d,]+ px \(seen\)",
                     close.stdout), close.stdout
    still = tmp_path / "runs" / "default_apartment-preview-kitchen_counter.png"
    start = _preview(tmp_path)
    assert start.returncode == 0, start.stderr
    a, b = cv2.imread(str(still)), cv2.imread(str(tmp_path / "runs" / "default_apartment-preview.png"))
    assert a.shape == b.shape and (a != b).mean() > 0.1  # another pose, another picture
    glance = _preview(tmp_path, "--site", "kitchen_centre", "--out", "g.png")
    assert glance.returncode == 0, glance.stderr
    assert "view from kitchen_centre (room, sites " in glance.stdout and (tmp_path / "g_plan.png").is_file()


def test_an_unknown_site_is_one_line_naming_the_known_ones(tmp_path):
    done = _preview(tmp_path, "--site", "kitchen_countr")
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    assert "--site" in done.stderr and "kitchen_counter" in done.stderr


def test_the_search_sequence_a_planner_would_follow_is_printed(tmp_path):
    done = _preview(tmp_path, "--search", "--planner", "greedy", "--looks", "5", "--out", "s.png")
    assert done.returncode == 0, done.stderr
    lines = [line for line in done.stdout.splitlines() if re.match(r"\s+\d+\. ", line)]
    assert len(lines) == 5 and "search sequence of greedy if no look finds anything" in done.stdout
    assert "ended: 5 looks (--looks)" in done.stdout
    views = [re.match(r"\s+\d+\. (\S+) \((site|room), [\d.]+ m\)", line).group(1) for line in lines]
    assert len(set(views)) > 1  # misses move the search on
    bad = _preview(tmp_path, "--search", "--looks", "0")
    assert bad.returncode == 2 and "--looks" in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
