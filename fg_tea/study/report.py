"""The report of a model x planner comparison: ``summary.md``, ``summary.csv``, ``paired.csv`` and
the figures, the paired-difference figure first (docs/design.md §11).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

from fg_tea.common.files import atomic_write_text
from fg_tea.common.stats import Interval
from fg_tea.study.analysis import (METRICS, YARDSTICK, _order, paired_differences, paired_markdown,
                                   plot_bars, plot_entropy, plot_paired, plot_ratios, ratio_markdown,
                                   ratio_to_reference, refused, step_limited, summary_markdown,
                                   summary_table)
from fg_tea.study.bounds import bound_markdown, bound_table
from fg_tea.study.rows import write_csv_atomic


def _summary_csv_rows(summary: Sequence[Mapping[str, Any]], metrics: Sequence[str],
                      bounds: Sequence[Mapping[str, Any]] = ()) -> list[dict]:
    out = []
    for i, s in enumerate(summary):
        row = {k: v for k, v in s.items() if not isinstance(v, Interval)}
        for m in list(metrics) + ["success"]:
            iv = s[m]
            row.update({f"{m}_mean": iv.mean, f"{m}_ci_low": iv.low, f"{m}_ci_high": iv.high})
        if bounds:
            b = bounds[i]
            row.update({"search_bound": b["bound"], "search_travel_over_bound": b["travel_over_bound"],
                        "search_bound_fault": b["bound_fault"]})
        out.append(row)
    return out


def _diff_csv_rows(diffs: Sequence[Mapping[str, Any]], metrics: Sequence[str]) -> list[dict]:
    out = []
    for d in diffs:
        row = {k: v for k, v in d.items() if not isinstance(v, Interval)}
        for m in metrics:
            for suffix in ("", "_baseline", "_other"):
                iv = d.get(f"{m}{suffix}")
                if iv is not None:
                    name = f"{m}{suffix or '_difference'}"
                    row.update({f"{name}_mean": iv.mean, f"{name}_ci_low": iv.low, f"{name}_ci_high": iv.high})
        out.append(row)
    return out


def comparison_report(rows: Sequence[Mapping[str, Any]], out: str | Path, *, title: str = "Comparison",
                      command: str = "", baseline_model: str = "factorised",
                      joint_model: str = "joint", reference_planner: str = "optimal") -> dict[str, Path]:
    """Write summary.md, summary.csv, paired.csv and plots for a model x planner sweep.

    Sections: means with 95 % CIs per (model, planner); search travel beside a lower bound on the
    optimum (:mod:`fg_tea.study.bounds`, also in summary.csv as ``search_bound``); paired
    differences joint − factorised per
    planner; each planner vs the Bayes-optimal planner (ratio and excess travel, per model); an
    ablation table (every other model − `baseline_model`) when the sweep has other models.

    Args:
        rows: the sweep's rows.
        out: the output folder.
        title: the markdown title.
        command: the command that reproduces the sweep (quoted in the report).
        baseline_model: the reference model of paired differences.
        joint_model: the model compared with the baseline in the headline section.
        reference_planner: the planner used as the limit.

    Returns:
        Name -> path of every file written.
    """
    out = Path(out)
    metrics = METRICS
    models = _order((r["model"] for r in rows), (baseline_model, joint_model))
    planners = _order((r["planner"] for r in rows),
                      ("efe", "factorised_efe", "nearest", "greedy", "random", "optimal"))
    ordered = sorted(rows, key=lambda r: (models.index(r["model"]), planners.index(r["planner"]), r["key"]))
    summary = summary_table(ordered, ("model", "planner"), metrics + (YARDSTICK,))
    files: dict[str, Path] = {}
    worlds = sorted({(r["world"], r["world_seed"]) for r in rows})
    n_refused = sum(refused(r) for r in rows)
    n_stuck = sum(step_limited(r) for r in rows)
    lines = [f"# {title}", ""]
    if command:
        lines += ["Reproduce with:", "", f"    {command}", ""]
    lines += [f"{len(rows)} episodes: {len(worlds)} worlds of "
              f"{', '.join(sorted({str(r['world']) for r in rows}))} × {len(models)} models "
              f"({', '.join(map(str, models))}) × {len(planners)} planners ({', '.join(map(str, planners))}); "
              f"every configuration solves the same worlds with the same seeds."
              + (f" {n_refused} episodes were refused by the optimal planner's site limit and are "
                 "excluded." if n_refused else "")
              + (f" {n_stuck} episodes were stopped at the sweep's step limit (the planner kept "
                 "re-inspecting a site in place); they count as failures in the success rate and "
                 "are excluded from the travel and inspection means and from the pairs." if n_stuck else ""),
              "",
              "Means with 95 % Student-t confidence intervals (success rate: Wilson interval). "
              "Search travel is the metres walked to inspect sites until every object was found; "
              "total travel includes making the tea. The clairvoyant search travel is the shortest "
              "route from the start through viewpoints of the model that see every searched object "
              "where it truly stands (perfect detection; docs/design.md §11); SPL = clairvoyant ÷ "
              "max(search travel, clairvoyant) per episode, 0 when an object was never found.", "",
              "## Means per model and planner", "",
              summary_markdown(summary, metrics=metrics + (YARDSTICK,))]
    bounds = bound_table(summary, ordered)
    lines += ["## Search travel beside a lower bound on the optimum", "",
              "Per model and planner: mean search travel, and the mean over the same worlds of a lower "
              "bound on the least expected search travel any policy achieves from the start under the "
              "model's own prior (perfect looks, one object at a time, each look at its cheapest arrival; "
              "docs/design.md §6.9). The optimum lies between them, so travel ÷ bound is an upper end of the "
              "planner's ratio to it, in worlds drawn from the model's prior (elsewhere a reference "
              "point). Where there is none, the reason.", "",
              bound_markdown(bounds), ""]
    if baseline_model in models and joint_model in models:
        diffs = paired_differences([r for r in ordered if r["model"] in (baseline_model, joint_model)],
                                   "model", baseline_model, metrics + ("success",), by=("planner",))
        lines += [f"## Paired differences: {joint_model} − {baseline_model} (same worlds)", "",
                  "Negative = the joint model travels less / inspects less.", "",
                  paired_markdown(diffs, "model", metrics=metrics)]
        write_csv_atomic(out / "paired.csv", _diff_csv_rows(diffs, metrics + ("success",)))
        files["paired.csv"] = out / "paired.csv"
        files["paired.png"] = plot_paired(diffs, out / "paired.png", "model", (
            "search_distance", "inspections", "spl"),
            f"{joint_model} − {baseline_model}, paired world by world (mean, 95 % CI; blue: excludes 0)")
    if reference_planner in planners and len(planners) > 1:
        ratios = ratio_to_reference(ordered, "planner", reference_planner, "search_distance", by=("model",))
        lines += [f"## Search travel relative to the Bayes-optimal limit (planner `{reference_planner}`)",
                  "",
                  "Per world: search travel of the planner ÷ that of the optimal planner with the same "
                  "model (1.00 = the limit); excess = difference in metres. The optimal planner is "
                  "Bayes-optimal for its own belief under perfect detection, so a ratio below 1 is "
                  "possible when a planner is lucky on a world.", "",
                  ratio_markdown([r for r in ratios if r["planner"] != reference_planner])]
        files["ratio_to_optimal.png"] = plot_ratios(
            [r for r in ratios if r["planner"] != reference_planner], out / "ratio_to_optimal.png",
            title="Search travel relative to the Bayes-optimal limit (95 % CI)")
    others = [m for m in models if m not in (baseline_model, joint_model)]
    if baseline_model in models and others:
        abl = paired_differences([r for r in ordered if r["model"] in [baseline_model] + others],
                                 "model", baseline_model, metrics + ("success",), by=("planner",))
        lines += [f"## Ablations: each model − {baseline_model} (same worlds)", "",
                  paired_markdown(abl, "model", metrics=metrics)]
    quality = [c for c in ("quality_kl_mean", "quality_brier_mean", "quality_brier_final", "quality_ece")
               if any(r.get(c) is not None for r in rows)]
    if quality:
        lines += ["## Belief quality (from fg_tea.episode.quality)", "",
                  "Per episode, then averaged: KL of the factorised from the joint posterior on the same "
                  "evidence (nats, mean over steps), Brier score of the agent's location beliefs against "
                  "the true sites (mean over steps, and after the last inspection), expected calibration "
                  "error.", "",
                  summary_markdown(summary_table(ordered, ("model", "planner"), quality), metrics=quality,
                                   digits=3)]
    write_csv_atomic(out / "summary.csv", _summary_csv_rows(summary, metrics + (YARDSTICK,), bounds))
    files["summary.csv"] = out / "summary.csv"
    files["travel_inspections.png"] = plot_bars(summary, out / "travel_inspections.png",
                                                ("search_distance", "total_distance", "inspections"),
                                                title="Travel and inspections per model and planner (95 % CI)")
    files["entropy.png"] = plot_entropy(ordered, out / "entropy.png",
                                        title="Location-belief entropy over inspections (mean ± 95 % CI)")
    lines += ["## Plots", ""]
    if "paired.png" in files:
        lines.append(f"- `paired.png` (the answer): {joint_model} − {baseline_model} per planner, "
                     "paired world by world, with 95 % intervals.")
    lines += ["- `travel_inspections.png`: search travel, total travel and inspections per model and planner.",
              "- `entropy.png`: summed location entropy of the searched objects after each inspection.",
              ]
    if "ratio_to_optimal.png" in files:
        lines.append("- `ratio_to_optimal.png`: search travel relative to the Bayes-optimal limit.")
    lines.append("")
    files["summary.md"] = atomic_write_text(out / "summary.md", "\n".join(lines))
    return files


__all__ = ["comparison_report"]
