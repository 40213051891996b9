"""Learned transitions: does the learned boil success approach the truth, and does the agent read
states less once it has learned it? (docs/design.md §12.5)

The world's kettle heats in only a fraction of boils (``--boil``, default 0.6: the environment's
``effect_success``, never shown to the agent) while the bundled models declare boil success 0.995
(``experiments/models/factorised_doubtful_kettle.toml`` declares 0.6, for worlds where a boil
almost always works: ``--boil 0.995``). For each household (a seed) and model, the agent lives
``--episodes`` consecutive episodes of the fixed scenario (default ``default_apartment``) in two
arms on the same seeds: ``hand-set`` (the
model as written) and ``learned`` (episode k uses boil's, and every other effect's, success learned
from the arm's episodes before k: eqs. 61-63, and the other counts of §12). Per episode: the
learned boil row's posterior mean and 95 % interval (the one the agent used), its expected counts,
and the number of state readings; the readings are compared between arms, paired by household and
episode, with a 95 % t-interval over households of the per-household mean difference.

Households come in two sets fixed before running: a discovery set and a confirmation set
(``--discovery``, ``--confirmation``); the script writes them to ``seeds.json`` in the output
folder first, then runs, then writes ``episodes.csv`` and ``summary.md`` (the report).

    python experiments/learned_transitions.py --out experiments/results/learned_transitions
"""

from __future__ import annotations

import argparse
import csv
import json
import shlex
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

from fg_tea.common.errors import InputError, run_script
from fg_tea.common.files import atomic_path, atomic_write_text, out_folder
from fg_tea.common.options import OUT_HELP, experiment_parser
from fg_tea.common.stats import t_interval
from fg_tea.common.tables import table_lines
from fg_tea.model import learned_transitions as lt
from fg_tea.study.households import LEARNED, HouseholdSpec, run_lifelong

#: The models compared: the bundled one, and one that verifies the kettle before pouring.
MODELS = ("factorised", "experiments/models/factorised_check_kettle.toml")
ROW = lt.row_key("boil", 0)
FIELDS = ["set", "model", "arm", "household", "episode", "state_readings", "success", "goals_true",
          "boil_learned", "boil_lo", "boil_hi", "boil_successes", "boil_failures", "learned_logs"]


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§12.5")
    p.add_argument("--models", nargs="+", default=list(MODELS), help="model files or bundled names")
    p.add_argument("--scenario", default="default_apartment", help="the fixed scenario")
    p.add_argument("--boil", type=float, default=0.6, help="true P(the kettle heats) per boil")
    p.add_argument("--episodes", type=int, default=20, help="consecutive episodes per household")
    p.add_argument("--discovery", type=int, nargs="+", default=list(range(20)),
                   help="discovery households (seeds 1000 h + k)")
    p.add_argument("--confirmation", type=int, nargs="+", default=list(range(20, 40)),
                   help="confirmation households")
    p.add_argument("--env", choices=("fake", "pybullet"), default="fake", help="environment")
    p.add_argument("--workers", type=int, default=1, help="processes")
    p.add_argument("--out", type=out_folder, default="runs/experiments/learned_transitions", help=OUT_HELP)
    return p


def main(argv=None) -> int:
    p = build_parser()
    args = p.parse_args(argv)
    if not 0.0 <= args.boil <= 1.0 or args.episodes < 1 or set(args.discovery) & set(args.confirmation):
        p.error("--boil in [0, 1], --episodes >= 1, and the two household sets must not overlap")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    sets = {"discovery": sorted(args.discovery), "confirmation": sorted(args.confirmation)}
    atomic_write_text(out / "seeds.json", json.dumps({**sets, "seed_rule": "1000 household + episode",
                                                      "fixed_before_running": True}, indent=2) + "\n")
    started, cpu = time.time(), time.process_time()
    try:
        specs = [HouseholdSpec(args.scenario, True, model, h, args.episodes, args.env,
                               learn_transitions=True, effect_success=(("boil", args.boil),))
                 for model in args.models for h in sets["discovery"] + sets["confirmation"]]
        rows = run_lifelong(specs, args.workers)
    except InputError as exc:
        p.error(str(exc))
    declared = {}
    from fg_tea.model.spec import load_model

    for model in args.models:
        m = load_model(model)
        declared[m.name] = (m.transition("boil").effects[0].success, m)
    table = [_row(r, sets, declared) for r in rows]
    with atomic_path(out / "episodes.csv") as tmp, tmp.open("w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows(table)
    command = shlex.join(["python", "experiments/learned_transitions.py",
                          *(argv if argv is not None else sys.argv[1:])])
    atomic_write_text(out / "summary.md", report(table, args, command,
                                                 {name: p for name, (p, _) in declared.items()}))
    print((out / "summary.md").read_text())
    print(f"{len(rows)} episodes in {time.time() - started:.0f} s wall, "
          f"{time.process_time() - cpu:.0f} s CPU (this process)")
    return 0


def _row(r: dict, sets: dict, declared: dict) -> dict:
    p0, model = declared[r["model"]]
    learning = r.get("_learning")
    terms = learning.counts.transitions.get(ROW, ()) if learning is not None else ()
    strength = learning.transition_strength if learning is not None else lt.DEFAULT_TRANSITION_STRENGTH
    applied = r["arm"] == LEARNED
    mean = lt.posterior_mean(p0, strength, terms) if applied else p0
    lo, hi = lt.interval(p0, strength, terms) if applied else (p0, p0)
    s, f = lt.expected_counts(p0, strength, terms) if applied else (0.0, 0.0)
    return {"set": next(k for k, v in sets.items() if r["household"] in v), "model": r["model"],
            "arm": r["arm"], "household": r["household"], "episode": r["episode"],
            "state_readings": r["state_readings"], "success": r["success"],
            "goals_true": int(bool(r["goals_true"])),
            "boil_learned": round(mean, 6), "boil_lo": round(lo, 6), "boil_hi": round(hi, 6),
            "boil_successes": round(s, 4), "boil_failures": round(f, 4), "learned_logs": r["learned_logs"]}


def _fmt(iv) -> str:
    return "n/a" if iv.mean is None else (f"{iv.mean:.3f}" if iv.low is None or iv.low != iv.low
                                          else f"{iv.mean:.3f} [{iv.low:.3f}, {iv.high:.3f}]")


def report(table: list[dict], args, command: str, declared: dict[str, float]) -> str:
    """The summary: per set and model, the learned boil row by episode and the readings, paired."""
    said = ", ".join(f"{m} declares {p:g}" for m, p in sorted(declared.items()))
    lines = [f"# Learned transitions: boil truly heats with p = {args.boil}; {said}",
             "", f"Command: `{command}`", "",
             f"{args.scenario}, {args.env} house, {args.episodes} episodes per household; households "
             f"fixed before the run (seeds.json). Learned arm: episode k uses the counts of its own "
             "episodes before k (docs/design.md §12.5, eqs. 61-63). Intervals: 95 % t-intervals over "
             "households (paired differences: learned minus hand-set, per household mean over episodes).",
             ""]
    for set_name in ("discovery", "confirmation"):
        for model in sorted({r["model"] for r in table}):
            mine = [r for r in table if r["set"] == set_name and r["model"] == model]
            if not mine:
                continue
            households = sorted({r["household"] for r in mine})
            lines += [f"## {set_name}: {model} ({len(households)} households)", ""]
            body = []
            for k in sorted({r["episode"] for r in mine}):
                le = [r for r in mine if r["episode"] == k and r["arm"] == LEARNED]
                hs = [r for r in mine if r["episode"] == k and r["arm"] != LEARNED]
                mean = lambda key, rows: sum(float(r[key]) for r in rows) / len(rows)  # noqa: E731
                body.append([k, f"{mean('boil_learned', le):.3f}",
                             f"{mean('boil_lo', le):.3f}-{mean('boil_hi', le):.3f}",
                             f"{mean('boil_successes', le):.2f} / {mean('boil_failures', le):.2f}",
                             f"{mean('state_readings', hs):.2f}", f"{mean('state_readings', le):.2f}"])
            lines += table_lines(["episode", "learned boil success (mean over households)",
                                  "its 95 % posterior interval (mean bounds)", "expected successes / failures counted",
                                  "readings hand-set", "readings learned"], body, align="left")
            diffs = []
            for h in households:
                le = [r["state_readings"] for r in mine if r["household"] == h and r["arm"] == LEARNED]
                hs = [r["state_readings"] for r in mine if r["household"] == h and r["arm"] != LEARNED]
                diffs.append(sum(le) / len(le) - sum(hs) / len(hs))
            last = [float(r["boil_learned"]) for r in mine if r["arm"] == LEARNED
                    and r["episode"] == max(x["episode"] for x in mine)]
            final = [r for r in mine if r["arm"] == LEARNED and r["episode"] == max(x["episode"] for x in mine)]
            es, ef = (sum(float(r[k]) for r in final) for k in ("boil_successes", "boil_failures"))
            share = f"{es / (es + ef):.3f}" if es + ef > 0 else "n/a"
            succ = {arm: t_interval(float(r["success"]) for r in mine if (r["arm"] == LEARNED) == arm)
                    for arm in (False, True)}
            tea = {arm: t_interval(float(r["goals_true"]) for r in mine if (r["arm"] == LEARNED) == arm)
                   for arm in (False, True)}
            lines += ["", f"- State readings per episode, learned minus hand-set (paired): "
                      f"{_fmt(t_interval(diffs))}",
                      f"- Learned boil success used in the last episode, over households: "
                      f"{_fmt(t_interval(last))} (truth {args.boil}, declared {declared[model]:g})",
                      f"- Its expected counts, summed over households: {es:.2f} successes, {ef:.2f} failures, "
                      f"a success share of {share} (the readings alone; the posterior mean adds the "
                      f"prior's S_t = {lt.DEFAULT_TRANSITION_STRENGTH:g} pseudo-trials at the declared success)",
                      f"- Episodes the agent called a success: hand-set {_fmt(succ[False])}, "
                      f"learned {_fmt(succ[True])} (share of episodes, interval over episodes)",
                      f"- Episodes whose tea was truly made (the task's goals hold in the world's truth; "
                      f"evaluation only): hand-set {_fmt(tea[False])}, learned {_fmt(tea[True])}", ""]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    run_script(main, "learned_transitions.py")
