"""Analysis of sweep rows: means with confidence intervals, paired differences, tables and plots.

This module answers the second half of the experiment question ("which model searches better, and
by how much, with what uncertainty?") over the rows written by :mod:`fg_tea.study.sweep`.

**Intervals.** A mean is reported with a two-sided 95 % Student-t interval,
``mean ± t_{0.975, n-1} · s / sqrt(n)`` with the sample standard deviation s (ddof = 1); with
fewer than two values the interval is undefined (NaN). A success rate is a proportion, for
which the t-interval collapses to a point when every episode succeeds, so it gets the Wilson
score interval instead: ``(p + z²/2n ± z sqrt(p(1-p)/n + z²/4n²)) / (1 + z²/n)``, z = 1.95996.

**Pairing.** Every configuration of a sweep solves the same world seeds with the same episode
seeds, so configurations are compared world by world: a paired difference is the t-interval of
the per-world differences (``b - a`` for "b minus a"), and a ratio to a reference (such as the
Bayes-optimal planner) is the t-interval of the per-world ratios. Rows refused by the optimal
planner (reason ``refused: ...``) are excluded from means and pairs, and counted. Episodes the
sweep stopped at its step limit (reason ``step_limit: ...``, a planner looping in place) count
as failures in the success rate but are excluded from the travel and inspection means and pairs
(their numbers would only measure the limit), and are counted separately.

**Plots** are drawn with matplotlib's object-oriented API on the Agg canvas (no pyplot, no
window). Belief entropy over time uses the ``entropy_trace`` list column of each row (summed
location entropy of the searched objects after each inspection); an episode whose search ended
keeps its last value, so every curve is a mean over all worlds of the configuration.

Every file is written atomically: to a temporary file in the same folder, then renamed.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from fg_tea.common.files import atomic_path
from fg_tea.common.stats import Z95, Interval, t_interval, wilson_interval
from fg_tea.common.tables import markdown_table
from fg_tea.study.sweep import REFUSED, STEP_LIMIT

#: Metrics summarised by default (search travel first: it is what the planners optimise).
METRICS = ("search_distance", "total_distance", "inspections", "spl")
#: The clairvoyant yardstick, summarised beside the metrics (not differenced: it is a property
#: of the world and the model's viewpoints, not of the search).
YARDSTICK = "clairvoyant_search_travel"
#: Human-readable names and units.
LABELS = {"search_distance": "search travel (m)", "total_distance": "total travel (m)",
          "inspections": "inspections", "success": "success rate",
          "spl": "SPL", "clairvoyant_search_travel": "clairvoyant search travel (m)",
          "repeated_sites": "repeated sites",
          "entropy_reduction_per_inspection": "entropy reduction / inspection (nats)",
          "quality_kl_mean": "KL(joint ‖ factorised) (nats)", "quality_brier_mean": "Brier (mean)",
          "quality_brier_final": "Brier (final)", "quality_ece": "ECE"}
#: Pairing columns: the world and the episode seed (plus whatever strata the caller adds).
PAIR_ON = ("world", "world_seed", "seed")


def _isnan(v: Any) -> bool:
    return isinstance(v, float) and math.isnan(v)


def refused(row: Mapping[str, Any]) -> bool:
    """Whether the optimal planner declined this episode (too many open sites)."""
    return str(row.get("reason") or "").startswith(REFUSED)


def step_limited(row: Mapping[str, Any]) -> bool:
    """Whether the sweep stopped this episode at its step limit."""
    return str(row.get("reason") or "").startswith(STEP_LIMIT)


#: The reason the probability give-up writes (docs/design.md §7.8): ``not_found: o (...;
#: remaining probability x < p)``; the cost rule's reasons say what the best look costs, or name
#: its safety net.
PROBABILITY_GIVE_UP = re.compile(r"^not_found: .*; remaining probability [^;()]* < [^;()]*\)$")


def given_up_by_probability(row: Mapping[str, Any]) -> bool:
    """The episode ended because the probability rule gave a search up."""
    return bool(PROBABILITY_GIVE_UP.match(str(row.get("reason") or "")))


def excluded(row: Mapping[str, Any]) -> bool:
    """Rows left out of metric means and pairs: refused or step-limited episodes."""
    return refused(row) or step_limited(row)


def _groups(rows: Iterable[Mapping[str, Any]], by: Sequence[str]) -> dict[tuple, list[Mapping[str, Any]]]:
    out: dict[tuple, list] = {}
    for row in rows:
        out.setdefault(tuple(row.get(c) for c in by), []).append(row)
    return out


def _order(values: Iterable[Any], preferred: Sequence[Any] = ()) -> list[Any]:
    """Distinct values: those in `preferred` first in its order, then the rest sorted."""
    values = list(dict.fromkeys(values))
    head = [v for v in preferred if v in values]
    return head + sorted((v for v in values if v not in head), key=lambda v: (str(type(v)), v))


# ---------------------------------------------------------------------------------- tables
def summary_table(rows: Sequence[Mapping[str, Any]], by: Sequence[str] = ("model", "planner"),
                  metrics: Sequence[str] = METRICS, confidence: float = 0.95) -> list[dict[str, Any]]:
    """Per group: episode count, refusals, success rate (Wilson) and each metric's mean (t-interval).

    Args:
        rows: sweep rows.
        by: grouping columns, e.g. ``("model", "planner")`` or ``("model", "planner", "same_site_teabag_kettle")``.
        metrics: numeric columns to summarise.
        confidence: interval coverage.

    Returns:
        One dict per group, in order of first appearance, with the `by` columns, ``n`` (episodes
        in the metric means), ``refused``, ``step_limited``, ``success`` (an :class:`Interval`
        over every episode not refused: the task finished by the agent's beliefs),
        ``true_success`` (finished, and every final goal the agent believes is also true in the
        world's final truth) and one :class:`Interval` per metric.
    """
    out = []
    for key, group in _groups(rows, by).items():
        attempted = [r for r in group if not refused(r)]
        measured = [r for r in attempted if not step_limited(r)]
        entry: dict[str, Any] = dict(zip(by, key))
        entry["n"] = len(measured)
        entry["refused"] = len(group) - len(attempted)
        entry["step_limited"] = len(attempted) - len(measured)
        entry["success"] = wilson_interval(sum(bool(r.get("success")) for r in attempted), len(attempted))
        # Success is judged by the agent's beliefs; "true" also asks the world (goals_true).
        entry["true_success"] = wilson_interval(
            sum(bool(r.get("success")) and r.get("goals_true") is True for r in attempted), len(attempted))
        for m in metrics:
            entry[m] = t_interval((r.get(m) for r in measured), confidence)
        out.append(entry)
    return out


def paired_differences(rows: Sequence[Mapping[str, Any]], vary: str, baseline: Any,
                       metrics: Sequence[str] = METRICS, by: Sequence[str] = ("planner",),
                       pair_on: Sequence[str] = PAIR_ON, confidence: float = 0.95
                       ) -> list[dict[str, Any]]:
    """Paired differences ``other - baseline`` of the column `vary`, world by world.

    Args:
        rows: sweep rows.
        vary: the column being compared, e.g. ``"model"`` or ``"planner"``.
        baseline: its reference value, e.g. ``"factorised"``.
        metrics: numeric columns to difference (``success`` is treated as 0/1).
        by: strata within which pairs are formed (e.g. ``("planner",)``).
        pair_on: columns that identify one world (and episode seed) within a stratum.
        confidence: interval coverage.

    Returns:
        Per stratum and other value: the `by` columns, `vary` (the other value), ``baseline``,
        ``pairs``, and per metric an :class:`Interval` of the differences under the metric's name,
        plus ``<metric>_baseline`` and ``<metric>_other`` (the means over the same pairs).

    Raises:
        ValueError: two rows of one configuration share a pairing key (the pairing is ambiguous).
    """
    out = []
    for key, group in _groups([r for r in rows if not excluded(r)], by).items():
        table: dict[Any, dict[tuple, Mapping[str, Any]]] = {}
        for r in group:
            pk = tuple(r.get(c) for c in pair_on)
            slot = table.setdefault(r.get(vary), {})
            if pk in slot:
                raise ValueError(f"two rows with {vary}={r.get(vary)!r} share the pairing key "
                                 f"{dict(zip(pair_on, pk))} within {dict(zip(by, key))}; add the "
                                 "distinguishing column to `by`")
            slot[pk] = r
        if baseline not in table:
            continue
        base = table[baseline]
        for other in table:  # first-appearance order
            if other == baseline:
                continue
            common = [pk for pk in base if pk in table[other]]
            entry: dict[str, Any] = dict(zip(by, key))
            entry.update({vary: other, "baseline": baseline, "pairs": len(common)})
            for m in metrics:
                a = [_num(base[pk].get(m)) for pk in common]
                b = [_num(table[other][pk].get(m)) for pk in common]
                ok = [(x, y) for x, y in zip(a, b) if x is not None and y is not None]
                entry[m] = t_interval((y - x for x, y in ok), confidence)
                entry[f"{m}_baseline"] = t_interval((x for x, _ in ok), confidence)
                entry[f"{m}_other"] = t_interval((y for _, y in ok), confidence)
            out.append(entry)
    return out


def ratio_to_reference(rows: Sequence[Mapping[str, Any]], vary: str = "planner",
                       reference: Any = "optimal", metric: str = "search_distance",
                       by: Sequence[str] = ("model",), pair_on: Sequence[str] = PAIR_ON,
                       confidence: float = 0.95) -> list[dict[str, Any]]:
    """Per-world ratios ``metric(other) / metric(reference)`` with t-intervals.

    With the defaults this is each planner's search travel relative to the Bayes-optimal planner
    on the same world and model (1.0 = as good as the limit). Worlds where the reference's value
    is zero are skipped and counted in ``zero_reference``.

    Returns:
        Per stratum and other value: the `by` columns, `vary`, ``reference``, ``pairs``,
        ``zero_reference`` and ``ratio`` (an :class:`Interval`), plus ``difference`` (an
        :class:`Interval` of ``other - reference`` in the metric's unit).
    """
    out = []
    for key, group in _groups([r for r in rows if not excluded(r)], by).items():
        table: dict[Any, dict[tuple, Mapping[str, Any]]] = {}
        for r in group:
            table.setdefault(r.get(vary), {})[tuple(r.get(c) for c in pair_on)] = r
        if reference not in table:
            continue
        ref = table[reference]
        for other in table:  # first-appearance order
            common = [pk for pk in ref if pk in table[other]]
            raw = [(_num(ref[pk].get(metric)), _num(table[other][pk].get(metric))) for pk in common]
            pairs = [(x, y) for x, y in raw if x is not None and y is not None]
            zero = sum(1 for x, _ in pairs if x == 0)
            entry: dict[str, Any] = dict(zip(by, key))
            entry.update({vary: other, "reference": reference, "pairs": len(pairs), "zero_reference": zero,
                          "ratio": t_interval((y / x for x, y in pairs if x != 0), confidence),
                          "difference": t_interval((y - x for x, y in pairs), confidence)})
            out.append(entry)
    return out


def _num(v: Any) -> float | None:
    if v is None or isinstance(v, str) or _isnan(v):
        return None
    return float(v)


# ---------------------------------------------------------------------------------- markdown
def summary_markdown(summary: Sequence[Mapping[str, Any]], by: Sequence[str] = ("model", "planner"),
                     metrics: Sequence[str] = METRICS, digits: int = 2) -> str:
    """The summary table (means [95 % CI]) as markdown."""
    header = (list(by) + ["n"] + [LABELS.get(m, m) for m in metrics]
              + ["success rate", "success, true in the world"])
    body = []
    for s in summary:
        n = (f"{s['n']}" + (f" (+{s['refused']} refused)" if s["refused"] else "")
             + (f" (+{s['step_limited']} step-limited)" if s.get("step_limited") else ""))
        body.append([s[c] for c in by] + [n] + [s[m].fmt(digits) for m in metrics]
                    + [s["success"].fmt(3), s["true_success"].fmt(3)])
    return markdown_table(header, body)


def paired_markdown(diffs: Sequence[Mapping[str, Any]], vary: str, by: Sequence[str] = ("planner",),
                    metrics: Sequence[str] = METRICS, digits: int = 2) -> str:
    """Paired differences as markdown: baseline mean, other mean, difference [95 % CI]."""
    header = list(by) + [f"{vary} (vs baseline)", "pairs"]
    for m in metrics:
        header += [f"{LABELS.get(m, m)}: baseline", "other", "difference [95% CI]"]
    body = []
    for d in diffs:
        line = [d[c] for c in by] + [f"{d[vary]} − {d['baseline']}", d["pairs"]]
        for m in metrics:
            line += [f"{d[f'{m}_baseline'].mean:.{digits}f}", f"{d[f'{m}_other'].mean:.{digits}f}",
                     d[m].fmt(digits)]
        body.append(line)
    return markdown_table(header, body)


def ratio_markdown(ratios: Sequence[Mapping[str, Any]], vary: str = "planner",
                   by: Sequence[str] = ("model",), unit: str = "m", digits: int = 2) -> str:
    """Ratios to the reference as markdown."""
    header = list(by) + [vary, "pairs", "ratio to reference [95% CI]", f"excess ({unit}) [95% CI]"]
    body = [[r[c] for c in by] + [r[vary], r["pairs"], r["ratio"].fmt(digits), r["difference"].fmt(digits)]
            for r in ratios]
    return markdown_table(header, body)


# ---------------------------------------------------------------------------------- files
def save_figure(fig, path: str | Path, dpi: int = 120) -> Path:
    """Save a matplotlib Figure as PNG atomically (temporary file, then rename)."""
    path = Path(path)
    with atomic_path(path, ".png") as tmp:
        fig.savefig(tmp, format="png", dpi=dpi, bbox_inches="tight")
    return path


def figure_row(width: float = 7.5, height: float = 4.0, ncols: int = 1):
    """A figure (constrained layout) and its one row of `ncols` axes."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, ncols, squeeze=False)[0]
    return fig, axes


def _err(iv: Interval) -> tuple[float, float]:
    if math.isnan(iv.low):
        return 0.0, 0.0
    return iv.mean - iv.low, iv.high - iv.mean


def plot_bars(summary: Sequence[Mapping[str, Any]], path: str | Path,
              metrics: Sequence[str] = ("search_distance", "inspections"), group: str = "planner",
              series: str = "model", title: str = "") -> Path:
    """Grouped bars (one group per `group` value, one bar per `series` value) with 95 % CI whiskers."""
    groups = list(dict.fromkeys(s[group] for s in summary))
    names = list(dict.fromkeys(s[series] for s in summary))
    panel = max(3.5, 0.3 * len(groups) * max(1, len(names)) + 1.0)
    fig, axes = figure_row(panel * len(metrics), 4.0, len(metrics))
    width = 0.8 / max(1, len(names))
    lookup = {(s[group], s[series]): s for s in summary}
    for ax, metric in zip(axes, metrics):
        for i, name in enumerate(names):
            xs, ys, lo, hi = [], [], [], []
            for g, value in enumerate(groups):
                s = lookup.get((value, name))
                if s is None or s[metric].n == 0:
                    continue
                xs.append(g + (i - (len(names) - 1) / 2) * width)
                ys.append(s[metric].mean)
                e = _err(s[metric])
                lo.append(e[0])
                hi.append(e[1])
            ax.bar(xs, ys, width, yerr=[lo, hi], capsize=3, label=str(name))
        ax.set_xticks(range(len(groups)), [str(g) for g in groups], rotation=30, ha="right")
        ax.set_ylabel(LABELS.get(metric, metric))
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend(title=series)
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)


def entropy_curves(rows: Sequence[Mapping[str, Any]], by: Sequence[str] = ("model", "planner")
                   ) -> dict[tuple, tuple[np.ndarray, np.ndarray]]:
    """Mean (and standard error of) summed location entropy after each inspection, per group.

    Each row's ``entropy_trace`` is padded with its last value to the longest trace of its group.

    Returns:
        group -> (mean, standard error), arrays over inspection index 0.. (0 = before searching).
    """
    out = {}
    for key, group in _groups([r for r in rows if not excluded(r)], by).items():
        traces = [[float(x) for x in str(r.get("entropy_trace") or "").split(";") if x]
                  for r in group]
        traces = [t for t in traces if t]
        if not traces:
            continue
        length = max(len(t) for t in traces)
        padded = np.array([t + [t[-1]] * (length - len(t)) for t in traces])
        sem = padded.std(axis=0, ddof=1) / math.sqrt(len(padded)) if len(padded) > 1 else np.zeros(length)
        out[key] = (padded.mean(axis=0), sem)
    return out


def plot_entropy(rows: Sequence[Mapping[str, Any]], path: str | Path,
                 by: Sequence[str] = ("model", "planner"), title: str = "") -> Path:
    """Belief entropy over inspections: mean ± 1.96 SE per group, one panel per first `by` value."""
    curves = entropy_curves(rows, by)
    panels = _order((k[0] for k in curves), ("factorised", "joint"))
    fig, axes = figure_row(5.0 * max(1, len(panels)), 4.0, max(1, len(panels)))
    for ax, panel in zip(axes, panels):
        for key, (mean, sem) in curves.items():
            if key[0] != panel:
                continue
            x = np.arange(len(mean))
            label = " / ".join(str(k) for k in key[1:]) or str(panel)
            line, = ax.plot(x, mean, label=label, marker=".")
            # entropy is never negative: the band is clipped to its range
            ax.fill_between(x, np.maximum(mean - Z95 * sem, 0.0), mean + Z95 * sem,
                            color=line.get_color(), alpha=0.15)
        ax.set_title(f"{by[0]} = {panel}")
        ax.xaxis.set_major_locator(_integer_ticks())  # inspections are counts
        ax.set_ylim(bottom=0.0)
        ax.set_xlabel("inspections")
        ax.set_ylabel("summed location entropy (nats)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    if title:
        fig.suptitle(title)
    _few_worlds_note(fig, len({(r.get("world"), r.get("world_seed")) for r in rows if not excluded(r)}))
    return save_figure(fig, path)


#: Below this many paired worlds a figure says so on its face: intervals are wide or missing.
FEW_WORLDS = 5


def _integer_ticks():
    from matplotlib.ticker import MaxNLocator

    return MaxNLocator(integer=True)


def _few_worlds_note(fig, worlds: int) -> None:
    """Below :data:`FEW_WORLDS` worlds, say so under the figure's title."""
    if worlds < FEW_WORLDS:
        note = f"n = {worlds} world{'s' if worlds != 1 else ''}: intervals are wide or not shown"
        old = fig._suptitle.get_text() if fig._suptitle is not None else ""  # noqa: SLF001
        fig.suptitle(f"{old}\n{note}" if old else note, fontsize=10)


def plot_paired(diffs: Sequence[Mapping[str, Any]], path: str | Path, vary: str = "model",
                metrics: Sequence[str] = ("search_distance", "inspections", "spl"),
                title: str = "") -> Path:
    """The answer of a comparison: paired differences (other − baseline, world by world) with
    95 % intervals and a zero line, one panel per metric, one row per planner."""
    fig, axes = figure_row(3.6 * len(metrics), 0.9 + 0.45 * max(1, len(diffs)), len(metrics))
    labels = [f"{d.get('planner', '')}: {d[vary]} − {d['baseline']}" for d in diffs]
    y = np.arange(len(diffs))[::-1]
    for ax, m in zip(axes, metrics):
        for yi, d in zip(y, diffs):
            iv = d[m]
            lo, hi = _err(iv)
            color = "#1f77b4" if not math.isnan(iv.low) and (iv.low > 0 or iv.high < 0) else "#7f7f7f"
            ax.errorbar([iv.mean], [yi], xerr=[[lo], [hi]], fmt="o", color=color, capsize=3)
        ax.axvline(0.0, color="black", linewidth=0.8)
        ax.set_yticks(y, labels if m == metrics[0] else [""] * len(labels), fontsize=8)
        ax.set_xlabel(f"{LABELS.get(m, m)}: difference")
        ax.grid(axis="x", alpha=0.3)
    fig.suptitle(title or "Paired differences, world by world (mean, 95 % CI; blue: excludes 0)",
                 fontsize=10)
    _few_worlds_note(fig, min((int(d.get("pairs", 0)) for d in diffs), default=0))
    return save_figure(fig, path)


def plot_ratios(ratios: Sequence[Mapping[str, Any]], path: str | Path, vary: str = "planner",
                by: str = "model", title: str = "") -> Path:
    """Ratio to the reference per `vary` value and `by` value, with 95 % CI whiskers and a line at 1."""
    groups = list(dict.fromkeys(r[vary] for r in ratios))
    names = list(dict.fromkeys(r[by] for r in ratios))
    fig, axes = figure_row(max(6.0, 1.2 * len(groups)), 4.0)
    ax = axes[0]
    width = 0.8 / max(1, len(names))
    lookup = {(r[vary], r[by]): r for r in ratios}
    for i, name in enumerate(names):
        xs, ys, lo, hi = [], [], [], []
        for g, value in enumerate(groups):
            r = lookup.get((value, name))
            if r is None or r["ratio"].n == 0:
                continue
            xs.append(g + (i - (len(names) - 1) / 2) * width)
            ys.append(r["ratio"].mean)
            e = _err(r["ratio"])
            lo.append(e[0])
            hi.append(e[1])
        ax.bar(xs, ys, width, yerr=[lo, hi], capsize=3, label=str(name))
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.set_xticks(range(len(groups)), [str(g) for g in groups], rotation=30, ha="right")
    ax.set_ylabel("search travel / Bayes-optimal search travel")
    ax.legend(title=by)
    ax.grid(axis="y", alpha=0.3)
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)


def plot_sweep(diffs: Sequence[Mapping[str, Any]], x: str, path: str | Path,
               metrics: Sequence[str] = ("search_distance", "inspections"), sign: float = -1.0,
               xlabel: str | None = None, ylabel: str = "saved by the joint model", title: str = "") -> Path:
    """A paired difference against a knob: one panel per metric, mean with 95 % CI whiskers.

    Args:
        diffs: rows of :func:`paired_differences` stratified by `x`.
        x: the knob column.
        sign: multiplies the differences (``-1``: plot ``baseline - other``, i.e. what `other` saves).
    """
    fig, axes = figure_row(5.0 * len(metrics), 4.0, len(metrics))
    points = sorted((d for d in diffs if d[x] is not None), key=lambda d: d[x])
    for ax, metric in zip(axes, metrics):
        xs = [d[x] for d in points]
        ivs = [d[metric] for d in points]
        ys = [sign * iv.mean for iv in ivs]
        errs = np.array([_err(iv) for iv in ivs]).T if ivs else np.zeros((2, 0))
        if sign < 0 and len(ivs):
            errs = errs[::-1]
        ax.errorbar(xs, ys, yerr=errs, marker="o", capsize=4)
        ax.axhline(0.0, color="k", lw=0.8, ls="--")
        ax.set_xlabel(xlabel or x)
        ax.set_ylabel(f"{LABELS.get(metric, metric)} {ylabel}")
        ax.grid(alpha=0.3)
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)


# ---------------------------------------------------------------------------------- report
__all__ = ["METRICS", "YARDSTICK", "LABELS", "PAIR_ON", "Interval", "t_interval", "wilson_interval", "refused",
           "step_limited", "excluded",
           "summary_table", "paired_differences", "ratio_to_reference", "markdown_table",
           "summary_markdown", "paired_markdown", "ratio_markdown", "save_figure",
           "plot_bars", "entropy_curves", "plot_entropy", "plot_paired", "plot_ratios", "plot_sweep",
           "FEW_WORLDS"]
