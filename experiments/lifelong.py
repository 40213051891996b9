"""Lifelong learning curves: does an agent that learns from its own episodes search less?

For each household (a seed) the agent lives K consecutive episodes in the same house; episode k
uses the model learned (docs/design.md §12) from that household's episodes 0..k-1, and a control
arm runs the same placements with the hand-written model. Placements are drawn, episode by
episode, from a world distribution whose habits differ from the agent's priors (default
``contrary_household``: every object placed from the inverse of the prior; the mug is on the
study shelf 59 % of the time, where the prior says 0.01).

Outputs (under ``--out``, default ``runs/experiments/lifelong``): ``episodes.csv`` (one row per
episode), ``curves.csv`` (mean and 95 % interval over households per model, arm and episode),
``summary.md`` (episode 1 against episode K, paired over households) and ``curves.png``.

    python experiments/lifelong.py --households 30 --episodes 10 --out docs/lifelong
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from fg_tea.learning import Source, apply_learning, learn  # noqa: E402

FIELDS = ["model", "arm", "household", "episode", "world_seed", "success", "mug_site",
          "mug_inspections", "inspections", "search_distance", "spl", "prior_true_mug",
          "log_loss", "learned_logs"]
METRICS = [("mug_inspections", "inspections until the mug is found"),
           ("search_distance", "search travel (m)"), ("spl", "SPL"),
           ("log_loss", "-log q0(true site), mean over objects (nats)")]


def _episode(world_name: str, model_name: str, learning, world_seed: int, env_kind: str,
             move: tuple[str, str] | None = None):
    from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
    from fg_tea.model import load_model
    from fg_tea.worlds import load_world

    world = load_world(world_name)
    scenario = world.sample(world_seed)
    if move is not None:  # the household moves an object for good (the recovery experiment)
        from dataclasses import replace

        obj, site = move
        scenario = replace(scenario, objects=tuple(
            replace(o, true_site=site) if o.name == obj else o for o in scenario.objects))
    model = load_model(model_name)
    if learning is not None:
        model = apply_learning(model, learning)
    if env_kind == "fake":
        from fg_tea.env.fake import FakeHouse

        env = FakeHouse(scenario, env_config_for(model))
    else:
        from fg_tea.env.house import PyBulletHouse

        env = PyBulletHouse(scenario, env_config_for(model))
    try:
        runner = EpisodeRunner(scenario, model, env, RunConfig(seed=world_seed), world=world_name)
        metrics = runner.run()
    finally:
        close = getattr(env, "close", None)
        if close is not None:
            close()
    return runner.events, metrics, scenario


def household(args: tuple) -> list[dict]:
    """K episodes of one household for one model, learning on and off (same placements)."""
    world_name, model_name, h, episodes, env_kind, gamma, move_after, move = args
    rows = []
    for arm in ("learned", "hand-set"):
        learning = None
        for k in range(episodes):
            seed = 1000 * h + k
            moved = move if move is not None and k + 1 > move_after else None
            events, m, scenario = _episode(world_name, model_name, learning, seed, env_kind, moved)
            # evaluation only: the truth of the sampled world scores the agent's prior
            start = events[0]
            sites = [s["name"] for s in start["sites"]]
            prior = start["belief"]["locations"]
            truth = {o.name: o.true_site for o in scenario.objects}
            losses = [-math.log(max(prior[o][sites.index(truth[o])], 1e-300)) for o in prior]
            rows.append({
                "model": model_name, "arm": arm, "household": h, "episode": k + 1,
                "world_seed": seed, "success": int(bool(m["success"])),
                "mug_site": truth["mug"],
                "mug_inspections": (m["inspections_until_resolved"] or {}).get("mug"),
                "inspections": m["inspections"], "search_distance": m["search_distance"],
                "spl": m["spl"], "prior_true_mug": prior["mug"][sites.index(truth["mug"])],
                "log_loss": float(np.mean(losses)),
                "learned_logs": 0 if learning is None else len(learning.sources)})
            if arm == "learned":
                learning = learn([(events, Source(f"household{h}/episode{k + 1}",
                                                  f"{seed:064x}"))], learning, gamma)
    return rows


def _ci(values) -> tuple[float, float, float]:
    x = np.asarray([v for v in values if v is not None and v != ""], dtype=float)
    if len(x) == 0:
        return math.nan, math.nan, math.nan
    from scipy.stats import t

    mean = float(x.mean())
    if len(x) < 2:
        return mean, mean, mean
    half = float(t.ppf(0.975, len(x) - 1) * x.std(ddof=1) / math.sqrt(len(x)))
    return mean, mean - half, mean + half


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--world", default="contrary_household")
    p.add_argument("--models", nargs="+", default=["factorised", "joint"])
    p.add_argument("--households", type=int, default=30)
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--env", choices=("fake", "pybullet"), default="fake")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--out", default="runs/experiments/lifelong")
    p.add_argument("--forgetting", type=float, default=None,
                   help="forgetting factor gamma of the learned arm (default 1: never forget)")
    p.add_argument("--move", nargs=3, metavar=("OBJECT", "SITE", "AFTER"), default=None,
                   help="from episode AFTER+1 on, OBJECT always stands at SITE (recovery experiment)")
    args = p.parse_args(argv)
    if args.forgetting is not None and not 0 < args.forgetting <= 1:
        p.error("--forgetting must be in (0, 1]")
    move = (args.move[0], args.move[1]) if args.move else None
    move_after = int(args.move[2]) if args.move else 0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [(args.world, m, h, args.episodes, args.env, args.forgetting, move_after, move)
            for m in args.models for h in range(args.households)]
    rows: list[dict] = []
    if args.workers > 1:
        with ProcessPoolExecutor(args.workers) as pool:
            for part in pool.map(household, jobs):
                rows += part
    else:
        for job in jobs:
            rows += household(job)
    rows.sort(key=lambda r: (r["model"], r["arm"], r["household"], r["episode"]))
    with open(out / "episodes.csv", "w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows(rows)
    curves = []
    for model in args.models:
        for arm in ("learned", "hand-set"):
            for k in range(1, args.episodes + 1):
                sel = [r for r in rows if r["model"] == model and r["arm"] == arm and r["episode"] == k]
                row = {"model": model, "arm": arm, "episode": k, "n": len(sel)}
                for key, _ in METRICS + [("success", ""), ("prior_true_mug", "")]:
                    row[key], row[key + "_lo"], row[key + "_hi"] = _ci(r[key] for r in sel)
                curves.append(row)
    with open(out / "curves.csv", "w", newline="") as f:
        w = csv.DictWriter(f, list(curves[0]))
        w.writeheader()
        w.writerows({k: (round(v, 6) if isinstance(v, float) else v) for k, v in c.items()}
                    for c in curves)
    _summary(rows, args, out)
    _plot(curves, args, out)
    print((out / "summary.md").read_text())
    return 0


def _summary(rows, args, out: Path) -> None:
    K = args.episodes
    lines = [f"# Lifelong learning: {args.world}, {args.households} households x {K} episodes, "
             f"{args.env} house", "",
             "Means with 95 % t-intervals over households. Paired: episode K minus episode 1 of "
             "the same household, and learned minus hand-set at episode K (same placements).", "",
             "| model | metric | episode 1 (learned arm) | episode K learned | episode K hand-set | "
             "K - 1 (learned) | learned - hand-set at K |", "|---|---|---|---|---|---|---|"]
    for model in args.models:
        for key, label in METRICS:
            def get(arm, k):
                return {r["household"]: r[key] for r in rows
                        if r["model"] == model and r["arm"] == arm and r["episode"] == k}
            first, last, hand = get("learned", 1), get("learned", K), get("hand-set", K)
            fmt = lambda c: f"{c[0]:.3f} [{c[1]:.3f}, {c[2]:.3f}]"  # noqa: E731
            d1 = [last[h] - first[h] for h in first if last.get(h) is not None and first[h] is not None]
            d2 = [last[h] - hand[h] for h in last if hand.get(h) is not None and last[h] is not None]
            lines.append(f"| {model} | {label} | {fmt(_ci(first.values()))} | {fmt(_ci(last.values()))} "
                         f"| {fmt(_ci(hand.values()))} | {fmt(_ci(d1))} | {fmt(_ci(d2))} |")
    (out / "summary.md").write_text("\n".join(lines) + "\n")


def _plot(curves, args, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(METRICS), figsize=(4.2 * len(METRICS), 3.6))
    colours = {"factorised": "tab:blue", "joint": "tab:orange"}
    for ax, (key, label) in zip(axes, METRICS):
        for model in args.models:
            for arm, style in (("learned", "-"), ("hand-set", ":")):
                sel = [c for c in curves if c["model"] == model and c["arm"] == arm]
                k = [c["episode"] for c in sel]
                ax.plot(k, [c[key] for c in sel], style, marker=".", color=colours.get(model),
                        label=f"{model}, {arm}")
                ax.fill_between(k, [c[key + "_lo"] for c in sel], [c[key + "_hi"] for c in sel],
                                color=colours.get(model), alpha=0.12 if arm == "learned" else 0.05)
        ax.set(xlabel="episode in the household", title=label)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"Learning where things live: {args.world}, {args.households} households, "
                 f"95 % intervals ({args.env} house)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "curves.png", dpi=100)


if __name__ == "__main__":
    raise SystemExit(main())
