"""``fg-tea learn``: a learned model from episode logs (docs/design.md §12).
"""

from __future__ import annotations

import argparse

from fg_tea.cli.common import command, out_path
from fg_tea.common.errors import InputError
from fg_tea.common.resources import DEFAULT_MODEL


# ------------------------------------------------------------------------------ learning
@command("learn")
def cmd_learn(args: argparse.Namespace) -> int:
    """Write a model that extends a base model and holds the counts learned from logs
    (docs/design.md §12)."""
    from fg_tea.common.resources import is_program_ref
    from fg_tea.study.learn import learn_files, summary

    if is_program_ref(args.base):
        return _learn_program(args)
    if args.scenario is not None:
        raise InputError("<command line>", "--scenario", "is for a model program's --base; a TOML model's "
                         "counts are kept by category and site, for any house")
    out, learning = learn_files(args.logs, args.base, args.out, name=args.name,
                                forgetting=args.forgetting, prior_strength=args.prior_strength)
    from fg_tea.model.spec import load_model

    base = load_model(args.base)
    info = summary(learning, base.declared_transitions or base.transitions)
    where = _shares(info["sites"]) or "no objects found"
    together = _shares({pair: {k.replace("_", " "): v for k, v in shares.items()}
                        for pair, shares in info["co_location"].items() if shares})
    print(f"learned: {out} ({len(args.logs)} new log(s), {info['sources']} in all; found at: {where}"
          + (f"; kept together: {together}" if together else "")
          + "".join(f"; {row} success {t['declared']:g} -> {t['learned']:.3f} (95 % {t['interval_95'][0]:.3f}-"
                    f"{t['interval_95'][1]:.3f})" for row, t in info["transitions"].items()) + ")")
    return 0


def _learn_program(args: argparse.Namespace) -> int:
    """``--base PROGRAM``: the program's learnable tables counted from the logs (docs/design.md §12.6)."""
    from fg_tea.study.program_learning import learn_program

    for flag, value in (("--forgetting", args.forgetting), ("--name", args.name)):
        if value is not None:
            raise InputError("<command line>", flag, "applies to TOML models; a learned program keeps "
                             "every count and is named by its file")
    out, counts, rows = learn_program(args.logs, args.base, args.out, args.scenario, args.prior_strength)
    told = "; ".join([f"{name}: {int(n.sum())} episode(s) counted" for name, n in counts.items()]
                     + [f"{key} ({row['state']}): {len(row['terms'])} likelihood term(s)" for key, row in rows.items()])
    print(f"learned: {out} ({len(args.logs)} new log(s); {told})")
    return 0


def _shares(groups: dict[str, dict[str, float]]) -> str:
    """``group: key share, ...; group: ...`` with shares to two decimals."""
    return "; ".join(f"{g}: " + ", ".join(f"{k} {v:.2f}" for k, v in shares.items())
                     for g, shares in groups.items())


def add_parser(sub) -> None:
    p = sub.add_parser("learn", help="learn site priors, co-location, detector and sensor reliability and action "
                       "effect successes from logs",
                       description="Count, from episode logs and only from what the agent observed, "
                       "where it found each object, which objects it found together (same site, same "
                       "room, apart), the looks that saw or missed an object at the site where it "
                       "stood, state readings that other readings settled, and, for every effect of "
                       "every action, the likelihood of its success probability given the state "
                       "readings (exact under the agent's own model of the episode); write "
                       "a model file that extends --base and holds the counts (docs/design.md §12). "
                       "Learning from A then B (with the first result as --base) equals learning "
                       "from A and B at once.")
    p.add_argument("logs", nargs="*", metavar="LOG", help="episode.jsonl logs, counted in this order")
    p.add_argument("--base", default=DEFAULT_MODEL,
                   help="base model file (.toml), or bundled model or ablation name; or a model program "
                   "(my_model.py, module:attr), whose tables marked learnable are counted from what "
                   "the agent observed: a location where its first confirm_search found the object, a "
                   "state where its first readings agree; a table over several variables counts an "
                   "episode only when all of them were observed (docs/design.md §12.6); the effects of "
                   "transitions it marks learnable (m.learnable_transition) get the likelihood terms of "
                   "their success from the state readings (§12.5); logs must come "
                   "from that program (episode_start.program.sha256) (default: %(default)s)")
    p.add_argument("--out", required=True, type=out_path,
                   help="the learned model file to write (.toml; .py for a program's, a program itself)")
    p.add_argument("--scenario", default=None,
                   help="a program's house, whose sites its tables range over (default: the first log's)")
    p.add_argument("--name", default=None, help="the learned model's name (default: <base>_learned)")
    p.add_argument("--forgetting", type=float, default=None,
                   help="forgetting factor gamma in (0, 1]: held counts are multiplied by it before "
                   "each new log (default: the base's, else 1 = never forget)")
    p.add_argument("--prior-strength", type=float, default=None,
                   help="pseudo-count mass S of the declared location prior (default: the base's, "
                   "else 5)")
