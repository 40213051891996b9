"""`fg-tea run`'s exit status is documented in its --help, and a frame-limited run says why it is 1."""

from __future__ import annotations

import json

import pytest

from fg_tea.cli.main import main


def test_the_help_documents_the_exit_status(capsys):
    with pytest.raises(SystemExit) as done:
        main(["run", "--help"])
    assert done.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "Exit status: 0 when the task is complete; 1 when" in text
    assert "the frame limit (--max-frames) was reached" in text


def test_a_frame_limited_run_writes_everything_and_exits_1(tmp_path, capsys):
    assert main(["run", "--max-frames", "200", "--no-video", "--out", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert f"log: {tmp_path / 'episode.jsonl'}" in out
    end = [json.loads(line) for line in (tmp_path / "episode.jsonl").read_text().splitlines()
           if '"episode_end"' in line]
    assert end and end[0]["reason"] == "frame_limit"
    assert (tmp_path / "timings.json").is_file()
