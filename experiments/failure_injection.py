"""Does the agent still make tea when actions fail? Success under injected action failures.

Every executable verb (PICK, NAVIGATE, PLACE, INSERT, FILL, POUR, USE, WAIT) fails with
probability ``--rate`` (``EnvConfig.failure_rates``, seeded by the episode), over ``--worlds``
sampled worlds of ``--world``, for each model, with the EFE planner in the PyBullet house
(``--env fake`` for the oracle house). ``fg-tea compare`` has no failure-rate option (its jobs
hold scalar environment overrides only), hence this script. Prints success (``complete``),
success true in the world (``complete`` and every believed goal true in the final truth), and
the other episodes' end reasons; writes one CSV row per episode under ``--out`` (default
``runs/experiments/failure_injection``).

    python experiments/failure_injection.py --worlds 100 --rate 0.2      # ~3 min on 2 cores
"""

from __future__ import annotations

import argparse
import csv
import re
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from fg_tea.common.files import atomic_path, atomic_write_text, out_folder
from fg_tea.common.options import ENV_HELP, MODELS_HELP, WORKERS_HELP, WORLD_HELP, experiment_parser
from fg_tea.common.tables import table_lines

#: Default output folder, relative to the working directory like every fg-tea output under runs/.
DEFAULT_OUT = Path("runs") / "experiments" / "failure_injection"
VERBS = ("PICK", "NAVIGATE", "PLACE", "INSERT", "FILL", "POUR", "USE", "WAIT")


def run_one(args: tuple[str, int, str, float, str]) -> dict:
    from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
    from fg_tea.study.sweep import job_env, job_model, job_world

    world_name, seed, model_name, rate, env_kind = args
    world, model = job_world(world_name, ()), job_model(model_name, ())
    scenario = world.sample(seed)
    config = env_config_for(model, failure_rates={v: rate for v in VERBS})
    env = job_env(env_kind, scenario, config)
    runner = EpisodeRunner(scenario, model, env, RunConfig(seed=seed))
    try:
        for _ in range(2_000):
            runner.step()
            if runner.done:
                break
    finally:
        env.close()
    m = runner.metrics()
    return {"world": world_name, "world_seed": seed, "model": model_name, "rate": rate,
            "env": env_kind, "success": m["success"], "goals_true": m["goals_true"],
            "reason": m["reason"] if runner.done else "step_limit", "failures": m["failures"],
            "reopenings": sum(1 for e in runner.events if e["event"] == "reopen"
                              and e.get("reason") == "goal_no_longer_holds"),
            "frames": m["frames"]}


def reason_group(reason: str) -> str:
    """An end reason without its episode-specific numbers, for the end-reason table."""
    reason = reason.split(" (", 1)[0]
    return re.sub(r"failed \d+ times", "failed n times", reason)


def build_parser() -> argparse.ArgumentParser:
    p = experiment_parser(__doc__, __file__, "§7.6")
    p.add_argument("--worlds", type=int, default=100, help="number of sampled worlds (seeds 0..N-1)")
    p.add_argument("--world", default="correlated", help=WORLD_HELP)
    p.add_argument("--models", nargs="+", default=["factorised", "joint"], help=MODELS_HELP)
    p.add_argument("--rate", type=float, default=0.2,
                   help="probability in [0, 1] that each executable action fails")
    p.add_argument("--env", choices=("pybullet", "fake"), default="pybullet", help=ENV_HELP)
    p.add_argument("--workers", type=int, default=2, help=WORKERS_HELP)
    p.add_argument("--out", type=out_folder, default=str(DEFAULT_OUT), help="output folder (default: %(default)s)")
    return p


def main(argv: list[str] | None = None) -> int:
    p = build_parser()
    a = p.parse_args(argv)
    jobs = [(a.world, s, m, a.rate, a.env) for m in a.models for s in range(a.worlds)]
    with ProcessPoolExecutor(a.workers) as pool:
        rows = list(pool.map(run_one, jobs))
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / f"episodes-{a.world}-{a.env}-{a.rate}.csv") as tmp, \
            tmp.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    lines = [f"# Failure injection: rate {a.rate} on every verb, {a.worlds} `{a.world}` worlds, "
             f"EFE, {a.env}", ""]
    by_model = []
    reasons: Counter = Counter()
    for model in a.models:
        mine = [r for r in rows if r["model"] == model]
        ok = sum(r["success"] for r in mine)
        true = sum(bool(r["success"] and r["goals_true"]) for r in mine)
        by_model.append([model, len(mine), f"{ok / len(mine):.3f}", f"{true / len(mine):.3f}",
                         sum(r["reopenings"] > 0 for r in mine), f"{sum(r['failures'] for r in mine) / len(mine):.2f}",
                         max(r["failures"] for r in mine)])
        for r in mine:
            reasons[(reason_group(r["reason"]), model)] += 1
    lines += table_lines(["model", "n", "success", "success true in the world", "recovered by reopening",
                          "failed actions, mean", "failed actions, max"], by_model, align="left")
    lines += ["", "## End reasons (episodes)", ""]
    lines += table_lines(["end reason", *a.models],
                         [[group, *(reasons[(group, m)] for m in a.models)]
                          for group in sorted({g for g, _ in reasons}, key=lambda g: (g != "complete", g))],
                         align="left")
    text = "\n".join(lines) + "\n"
    atomic_write_text(out / f"summary-{a.world}-{a.env}-{a.rate}.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
