"""A missing optional extra gets one line, exit 2, and the install command that fits the install."""

from __future__ import annotations

import json

import pytest

import fg_tea.planning
from fg_tea.cli.main import main
from fg_tea.common import install


def _exit_status(argv) -> int:
    try:
        return main(argv)
    except SystemExit as exc:  # argparse reports a bad option value itself
        return int(exc.code)


@pytest.mark.parametrize("argv", [
    ["run", "--planner", "pouct:100", "--no-video"],
    ["compare", "--quick", "--env", "fake", "--planners", "pouct:100"],
    ["compare", "--quick", "--env", "fake", "--planners", "efe", "pomcp:50"],
])
def test_a_peer_planner_without_pomdp_py_is_one_line_and_exit_2(monkeypatch, capsys, tmp_path, argv):
    monkeypatch.setattr(fg_tea.planning, "peers_installed", lambda: False)
    assert _exit_status([*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "needs pomdp-py, the optional peers extra: pip install" in err[-1]
    assert "Traceback" not in "\n".join(err) and "resume" not in "\n".join(err)
    assert not (tmp_path / "out").exists()


class _Dist:
    def __init__(self, direct_url: dict | None) -> None:
        self.direct_url = direct_url

    def read_text(self, name: str) -> str | None:
        assert name == "direct_url.json"
        return None if self.direct_url is None else json.dumps(self.direct_url)


@pytest.mark.parametrize("direct_url, command", [
    ({"url": "file:///src/fg_tea", "dir_info": {"editable": True}}, 'pip install -e ".[peers]"'),
    ({"url": "file:///wheels/fg_tea-0.3.0-py3-none-any.whl", "archive_info": {}},
     'pip install "fg-tea[peers]"'),
    (None, 'pip install "fg-tea[peers]"'),  # from an index: no direct_url.json
])
def test_the_install_hint_fits_how_fg_tea_was_installed(monkeypatch, direct_url, command):
    monkeypatch.setattr(install.metadata, "distribution", lambda name: _Dist(direct_url))
    assert install.install_command("peers") == command
