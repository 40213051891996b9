"""Why did a search give up an object that was there? Every look at its true site, replayed.

For each episode of a sweep CSV that ended ``not_found`` in the chosen cell (world
distribution, model, planner), this script runs the same job again with its log (same world,
seeds and code, so the same episode) and lists every look whose view held the object's true
site: the viewpoint, close look or glance, the detection probability the agent's model gave
(``detection_probability`` in the log), the pixel count the camera rendered, the probability the
camera drew its verdict from (its visibility curve at that count), and whether it saw the object.
A model that is wrong about a look shows as a gap between the two probabilities; runs of misses
the model allows show as misses at probabilities that agree.

    python experiments/trace_give_ups.py --world generated_small_milk_sugar \\
        --out experiments/results/false_give_ups/trace

Writes ``looks.csv`` (one row per look) and ``trace.md`` to ``--out``.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

from fg_tea.common.errors import InputError, run_script
from fg_tea.common.files import atomic_write_text, out_folder
from fg_tea.common.options import experiment_parser
from fg_tea.study.analysis import markdown_table
from fg_tea.study.rows import read_rows, write_csv_atomic

DEFAULT_CSV = ROOT / "experiments" / "results" / "joint_vs_factorised" / "houses" / "episodes.csv"
DEFAULT_OUT = "runs/experiments/trace_give_ups"


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§7.8")
    p.add_argument("--episodes", type=Path, default=DEFAULT_CSV, help="the sweep CSV")
    p.add_argument("--world", default="generated_small_milk_sugar", help="world distribution of the cell")
    p.add_argument("--models", nargs="+", default=["factorised", "joint"], help="models of the cell")
    p.add_argument("--planner", default="factorised_efe", help="planner of the cell")
    p.add_argument("--out", type=out_folder, default=DEFAULT_OUT, help="output folder")
    return p


def job_of(row: dict):
    """The sweep job that wrote `row` (its key names every field that is not a default)."""
    from fg_tea.study.keys import job_from_key

    return job_from_key(row["key"])


def trace(row: dict) -> list[dict]:
    """Every look at the given-up object's true site in the episode of `row`, replayed."""
    from fg_tea.episode.log import read_log
    from fg_tea.episode.runner import env_config_for
    from fg_tea.study.sweep import job_model, job_world, run_job

    job = job_of(row)
    obj = str(row["reason"]).split(":", 1)[1].split("(")[0].strip()
    site = row[f"true_site_{obj}"]
    model = job_model(job.model, ())
    scenario = job_world(job.world, ()).sample(job.world_seed)
    category = next(o.category for o in scenario.objects if o.name == obj)
    curve = env_config_for(model).camera_curve  # the job's camera: the model's default
    with tempfile.TemporaryDirectory() as tmp:
        again = run_job(job, Path(tmp) / "episode.jsonl")
        events = read_log(Path(tmp) / "episode.jsonl")
    if again["reason"] != row["reason"]:
        raise InputError("<episodes>", row["key"], "the episode ran differently this time "
                         f"({again['reason']!r}); was the table made by other code?")
    looks = []
    for e in events:
        if e.get("event") != "observation" or site not in (e.get("sites_in_view") or []):
            continue
        pixels = int((e.get("pixel_counts") or {}).get(obj, 0))
        seen = bool(e["detections"].get(obj))
        looks.append({"world_seed": job.world_seed, "model": job.model, "object": obj, "site": site,
                      "viewpoint": e["viewpoint"], "kind": e.get("viewpoint_kind", "site"),
                      "model_p": float(e["detection_probability"][obj][site]), "pixels": pixels,
                      "camera_p": float(curve.probability(category, pixels)) if curve else None,
                      "seen": seen})
    return looks


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    rows = [r for r in read_rows(args.episodes) if r["world"] == args.world
            and r["model"] in args.models and r["planner"] == args.planner
            and str(r["reason"]).startswith("not_found")]
    looks = [look for r in sorted(rows, key=lambda r: (r["model"], r["world_seed"])) for look in trace(r)]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv_atomic(out / "looks.csv", looks)
    close = [x for x in looks if x["kind"] == "site"]
    gaps = [abs(x["model_p"] - x["camera_p"]) for x in looks if x["camera_p"] is not None]
    command = shlex.join(["python", "experiments/trace_give_ups.py", *(sys.argv[1:] if argv is None else argv)])
    summary = [["episodes traced", len(rows)], ["looks at the true site", len(looks)],
               ["close looks", len(close)], ["close looks that saw the object", sum(x["seen"] for x in close)],
               ["close looks: least model p", f"{min(x['model_p'] for x in close):.3f}" if close else "–"],
               ["close looks: largest model p", f"{max(x['model_p'] for x in close):.3f}" if close else "–"],
               ["close looks: fewest pixels", min((x["pixels"] for x in close), default="–")],
               ["close looks: most pixels", max((x["pixels"] for x in close), default="–")],
               ["largest gap between model p and camera p", f"{max(gaps):.3f}" if gaps else "–"]]
    body = [[x["world_seed"], x["model"], x["object"], x["site"], x["viewpoint"], x["kind"],
             f"{x['model_p']:.3f}", x["pixels"],
             "–" if x["camera_p"] is None else f"{x['camera_p']:.3f}", "yes" if x["seen"] else "no"]
            for x in looks]
    text = "\n".join([
        "# Searches given up with the object there: every look at its site", "",
        f"Regenerate: `{command}`", "",
        f"Cell: `{args.world}`, models {', '.join(args.models)}, planner `{args.planner}`, from "
        f"`{args.episodes.relative_to(ROOT) if args.episodes.is_relative_to(ROOT) else args.episodes}`. "
        "Each episode was run again with its log; model p is the agent's detection probability for "
        "the look, camera p the camera's curve at the pixel count it rendered.", "",
        "## Summary", "", markdown_table(["quantity", "value"], summary), "",
        "## Looks", "", markdown_table(["world seed", "belief", "object", "site", "viewpoint", "kind",
                                        "model p", "pixels", "camera p", "seen"], body), ""])
    path = atomic_write_text(out / "trace.md", text)
    print(f"report: {path}")
    return 0


if __name__ == "__main__":
    run_script(main, "trace_give_ups.py")
