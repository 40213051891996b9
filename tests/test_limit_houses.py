"""The search limit in the 12- and 16-viewpoint generated houses, and planners that do not fit
refused before any episode (docs/design.md §6.9)."""

from __future__ import annotations

import pytest

from fg_tea.common.errors import InputError, PlannerRefused, run_script
from fg_tea.study import yardstick


@pytest.mark.slow
def test_in_256_mib_twelve_viewpoints_fit_the_caps_one_and_two_and_sixteen_the_caps_zero_and_one():
    """With a budget of 256 MiB (the default 2 GiB reaches further, two layers at a time, in
    minutes: experiments/results/search_limit_small_12/ and _16/), and caps per viewpoint after."""
    budget = 256 * 1024 ** 2
    lim, objects = yardstick.start_limit("independent_small_12", "factorised_close", "find_mug", max_bytes=budget)
    assert objects == ["mug"] and lim.viewpoints == 12
    assert (lim.lower_cap, lim.cap) == (1, 2) and lim.width < 0.002 * lim.lower and max(lim.caps) > 2
    lim, _ = yardstick.start_limit("independent_small_16", "factorised_close", "find_mug", max_bytes=budget)
    assert lim.viewpoints == 16 and (lim.lower_cap, lim.cap) == (0, 1) and lim.lower < lim.upper
    assert lim.width < 0.03 * lim.lower and max(lim.caps) > 1


def test_a_planner_that_does_not_fit_is_refused_before_any_episode(tmp_path):
    with pytest.raises(InputError, match=r"--planners: exact planner: 12 sites .* cap 2 fits"):
        yardstick.study("independent_small_12", range(2), "factorised_close", ["find_mug"],
                        ["lookahead", "exact"], tmp_path, "cmd")
    assert not (tmp_path / "episodes").exists()


def test_an_experiment_script_reports_a_refused_planner_in_one_line(capsys):
    def main() -> int:
        raise PlannerRefused("exact planner: too large", "size", "exact")

    with pytest.raises(SystemExit) as stop:
        run_script(main, "search_limit.py")
    assert stop.value.code == 2
    assert capsys.readouterr().err == "search_limit.py: error: exact planner: too large\n"


def test_the_gap_analysis_uses_the_largest_cap_that_fits_or_refuses_in_one_line():
    """At 16 viewpoints the cap-3 tables would need tens of GB (a run once died of it after every
    episode); the gap analysis takes the largest cap that fits, and the study refuses a budget
    that fits none before any episode."""
    assert yardstick.gap_cap("independent_small_16", "factorised_close", "find_three") == 1
    assert yardstick.gap_cap("independent", "factorised_close", "find_three") == 3
    with pytest.raises(InputError, match=r"--gaps: the gap analysis of find_mug needs .* at cap 1, more than"):
        yardstick.gap_cap("independent_small_16", "factorised_close", "find_mug", max_bytes=1000)
