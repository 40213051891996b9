"""Figures readable at every size: integer ticks for counts, bands within their range, a note when
few worlds stand behind an interval, and the paired-difference figure first in every comparison."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import pytest  # noqa: E402

from fg_tea.common.stats import t_interval  # noqa: E402
from fg_tea.study import analysis  # noqa: E402


def _rows(worlds: int, steps: int = 4):
    rows = []
    for w in range(worlds):
        for model in ("factorised", "joint"):
            trace = ";".join(str(max(0.0, 2.0 - 0.6 * i + 0.5 * ((w + i) % 2))) for i in range(steps))
            rows.append({"world": "w", "world_seed": w, "seed": w, "model": model, "planner": "efe",
                         "entropy_trace": trace, "reason": "complete", "success": True})
    return rows


def _capture(monkeypatch):
    figures = []
    monkeypatch.setattr(analysis, "save_figure", lambda fig, path, dpi=120: figures.append(fig) or path)
    return figures


@pytest.mark.parametrize("worlds, noted", [(2, True), (20, False)])
def test_entropy_plot_has_integer_ticks_a_band_above_zero_and_a_note_for_few_worlds(
        worlds, noted, monkeypatch, tmp_path):
    figures = _capture(monkeypatch)
    analysis.plot_entropy(_rows(worlds), tmp_path / "e.png", title="entropy")
    fig = figures[0]
    fig.canvas.draw()
    for ax in fig.axes:
        ticks = [t for t in ax.get_xticks() if ax.get_xlim()[0] <= t <= ax.get_xlim()[1]]
        assert ticks and all(float(t).is_integer() for t in ticks), ticks
        for band in ax.collections:
            for path in band.get_paths():
                assert path.vertices[:, 1].min() >= 0.0
        assert ax.get_ylim()[0] >= 0.0
    title = fig._suptitle.get_text()  # noqa: SLF001
    assert ("intervals are wide" in title) is noted, title


def test_the_paired_figure_draws_every_planner_with_its_interval_and_a_zero_line(monkeypatch, tmp_path):
    figures = _capture(monkeypatch)
    diffs = [{"planner": p, "model": "joint", "baseline": "factorised", "pairs": 30,
              **{m: t_interval([0.1 * k - 1.0 for k in range(30)]) for m in ("search_distance", "inspections", "spl")}}
             for p in ("efe", "nearest", "greedy")]
    analysis.plot_paired(diffs, tmp_path / "p.png")
    fig = figures[0]
    assert len(fig.axes) == 3
    labels = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    assert all(any(p in label for label in labels) for p in ("efe", "nearest", "greedy"))
    assert all(any(line.get_xdata()[0] == 0.0 for line in ax.get_lines()) for ax in fig.axes)
    assert "intervals are wide" not in fig._suptitle.get_text()  # noqa: SLF001


@pytest.mark.slow
def test_a_comparison_report_lists_the_paired_figure_first(tmp_path):
    from fg_tea.cli.main import main

    assert main(["compare", "--quick", "--env", "fake", "--worlds", "3", "--planners", "efe",
                 "nearest", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "summary.md").read_text()
    plots = text[text.index("## Plots"):].splitlines()
    assert plots[2].startswith("- `paired.png` (the answer)")
    assert (tmp_path / "paired.png").stat().st_size > 0
