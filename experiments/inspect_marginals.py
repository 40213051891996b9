r"""Inspect the beliefs of one episode, step by step, from Python (the worked API example).

Builds the PyBullet house, steps an :class:`~fg_tea.episode.runner.EpisodeRunner` one event at a
time and, after each step, prints what happened (decision, observation, action) and the belief
it left: every object's location marginal q(L_o) over the sites and every hidden-state
probability q(z = true). Finally it plots the marginals against the step (one heatmap per
object) and the hidden states (one line each) to a PNG, by default
``runs/experiments/inspect_marginals/inspect_marginals.png``.

    python experiments/inspect_marginals.py [--model joint] [--scenario default_apartment]
                                            [--seed 0] [--out FILE.png]

The documentation's figure changes only when ``--out`` names it:

    python experiments/inspect_marginals.py --scenario prior_violation \
        --out docs/inspect_marginals_prior_violation.png
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from fg_tea.common.files import out_file
from fg_tea.common.files import atomic_path
from fg_tea.common.options import MODEL_HELP, SCENARIO_HELP, experiment_parser
from fg_tea.env.house import PyBulletHouse
from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
from fg_tea.model.spec import load_model
from fg_tea.world.scenario import load_scenario

#: Default PNG, relative to the working directory like every fg-tea output under runs/.
DEFAULT_OUT = Path("runs") / "experiments" / "inspect_marginals" / "inspect_marginals.png"


def describe(event: dict) -> str | None:
    """One line for an event worth reading (None for bookkeeping events)."""
    kind = event["event"]
    if kind == "decision":
        return (f"decide   look for {event['object']} at {event['viewpoint']} "
                f"(G = {event['total']:+.2f} over {len(event['candidates'])} candidates)")
    if kind == "observation":
        seen = ", ".join(f"{o} {'SEEN' if v else 'not seen'}" for o, v in event["detections"].items())
        return f"observe  {event['viewpoint']}: {seen}"
    if kind == "state_reading":
        return (f"read     {event['state']} = {event['value']} "
                f"(q {event['before']:.3f} -> {event['after']:.3f})")
    if kind == "action":
        return f"act      {event['action']} ({event['verb']}) ok"
    if kind == "action_failed":
        return f"failed   {event['action']}: {event['reason']}"
    if kind == "skip":
        return f"skip     {event['action']} (its goal already holds)"
    if kind == "episode_end":
        return f"end      {event['reason']}"
    return None


def table(runner: EpisodeRunner) -> str:
    """The belief now: location marginals (objects x sites) and hidden-state probabilities."""
    sites, q = runner.agent.belief.sites, runner.agent.belief.location_matrix()
    lines = ["  " + f"{'':8}" + "".join(f"{s[:8]:>9}" for s in sites)]
    for obj, row in zip(runner.agent.belief.objects, q):
        lines.append("  " + f"{obj:8}" + "".join(f"{p:9.3f}" for p in row))
    states = runner.agent.belief.states()
    lines.append("  states: " + "  ".join(f"{s} {p:.3f}" for s, p in sorted(states.items())))
    return "\n".join(lines)


def plot(history: list[tuple[np.ndarray, dict[str, float]]], sites: list[str], objects: list[str],
         out: Path) -> None:
    """One heatmap per object (sites x step) and one panel of hidden states vs step; atomic."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = np.arange(len(history))
    fig, axes = plt.subplots(len(objects) + 1, 1, figsize=(9, 2.2 * (len(objects) + 1)),
                             sharex=True, constrained_layout=True)
    for i, (ax, obj) in enumerate(zip(axes, objects)):
        grid = np.stack([q[i] for q, _ in history], axis=1)          # (sites, steps)
        image = ax.imshow(grid, aspect="auto", cmap="viridis", vmin=0, vmax=1, origin="lower",
                          extent=(-0.5, len(history) - 0.5, -0.5, len(sites) - 0.5))
        ax.set_yticks(range(len(sites)), sites, fontsize=7)
        ax.set_title(f"q(L[{obj}] = site)", fontsize=9)
    fig.colorbar(image, ax=axes, label="probability", shrink=0.5)
    names = sorted({s for _, states in history for s in states})
    for name in names:
        axes[-1].plot(steps, [states.get(name, np.nan) for _, states in history], label=name,
                      drawstyle="steps-mid")
    axes[-1].set(ylim=(-0.02, 1.02), xlabel="step", ylabel="q(true)", title="hidden states")
    axes[-1].xaxis.get_major_locator().set_params(integer=True)
    axes[-1].legend(fontsize=7, ncol=4, loc="upper center", bbox_to_anchor=(0.5, -0.35))
    try:
        with atomic_path(out, ".png") as tmp:  # written whole, or not at all
            fig.savefig(tmp, format="png", dpi=110)
    finally:
        plt.close(fig)


def build_parser() -> argparse.ArgumentParser:
    parser = experiment_parser(__doc__, __file__, "§4 and §11")
    parser.add_argument("--model", default="joint", help=MODEL_HELP)
    parser.add_argument("--scenario", default="default_apartment", help=SCENARIO_HELP)
    parser.add_argument("--seed", type=int, default=0, help="episode seed")
    parser.add_argument("--out", type=out_file, default=DEFAULT_OUT, help="PNG to write (default: %(default)s)")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)

    # 1. Data: the house and the agent's generative model.
    scenario, model = load_scenario(args.scenario), load_model(args.model)
    # 2. The environment (truth lives here) and the runner (the agent's side of the loop).
    env = PyBulletHouse(scenario, env_config_for(model))
    runner = EpisodeRunner(scenario, model, env, RunConfig(seed=args.seed))
    runner.start()
    print(f"{scenario.name} · model {model.name} ({model.structure}) · seed {args.seed}")
    print("step 0 (prior)\n" + table(runner))
    history = [(runner.agent.belief.location_matrix(), runner.agent.belief.states())]
    # 3. Step until the episode ends; after each step, read the belief straight off the engine.
    try:
        while not runner.done:
            events = runner.step()
            print(f"step {len(history)}")
            for line in filter(None, map(describe, events)):
                print("  " + line)
            print(table(runner))
            history.append((runner.agent.belief.location_matrix(), runner.agent.belief.states()))
    finally:
        env.close()
    # 4. Metrics come from the event log, like every other number fg_tea reports.
    metrics = runner.metrics()
    print(f"done: {metrics['reason']} · {metrics['inspections']} inspections · "
          f"{metrics['total_distance']:.1f} m travelled")
    plot(history, list(runner.agent.belief.sites), list(runner.agent.belief.objects), args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
