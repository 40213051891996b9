"""Transition counts from a log: the likelihood of each effect's success probability given the
state readings the agent took (docs/design.md §12.5, rule 5, eq. 61).

The forward pass runs the agent's own model of the episode, as the log records it: the start
belief's state probabilities (``episode_start.belief.states``, independent, eq. 21), every action
the environment reported done with its logged transition (``action.transition.effects``: states,
values, requirements and the success probabilities the agent used, eq. 27), and every
``state_reading`` with its logged sensitivity and specificity (eqs. 23-24). For one row (an effect
of a transition) the success probability is left symbolic: a trial of the row (requirements hold,
target not already at the value) splits the pass into a success branch and a failure branch, and
the pass carries the numbers of each. What comes out is eq. (61), exactly: the probability of the
readings as a mixture of theta^s (1 - theta)^f. The other rows keep the values the agent used.

Only readings are evidence: ``world_truth``, ``yardstick``, ``episode_start.world`` and the
environment's parameters are never read. A row whose readings say nothing about it (no reading of
anything its effect touches downstream, so the mixture does not depend on theta) has no count.

Agent side: nothing here imports the simulator.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from fg_tea.common.errors import InputError
from fg_tea.model.learned_transitions import Terms, is_constant, normalised, row_key

#: Most task states one forward pass holds jointly (2^n joint states).
MAX_STATES = 16


def _steps(events: Sequence[Mapping], file: str) -> list[tuple[str, Any]]:
    """The episode as ("act", (transition name, effects)) and ("read", (state, value, alpha, beta))."""
    steps: list[tuple[str, Any]] = []
    for i, e in enumerate(events):
        kind = e.get("event")
        if kind == "action" and isinstance(e.get("transition"), dict):
            if not (e.get("outcome") or {}).get("ok", False):
                continue  # a failed action has no effect (docs/design.md §7.6)
            name = (e.get("parameters") or {}).get("transition")
            effects = e["transition"].get("effects")
            if not isinstance(name, str) or not isinstance(effects, list) or not all(
                    isinstance(x, dict) and isinstance(x.get("state"), str)
                    and isinstance(x.get("value"), bool) and isinstance(x.get("success"), (int, float))
                    and isinstance(x.get("requires", []), list) for x in effects):
                raise InputError(file, f"event {i}: action", "expected parameters.transition and "
                                 "transition.effects (state, value, success, requires)")
            if e["transition"].get("form", "full") != "full":
                raise InputError(file, f"event {i}: action.transition.form", "transition counts "
                                 "(docs/design.md §12.5) need the full form of eq. 27; this "
                                 "episode used the direct form")
            steps.append(("act", (name, effects)))
        elif kind == "state_reading":
            try:
                steps.append(("read", (str(e["state"]), bool(e["value"]), float(e["sensitivity"]),
                                       float(e["specificity"]))))
            except (KeyError, TypeError, ValueError):
                raise InputError(file, f"event {i}: state_reading",
                                 "expected state, value, sensitivity and specificity") from None
    return steps


def transition_terms(events: Sequence[Mapping], file: str = "<log>") -> dict[str, Terms]:
    """Eq. (61) for every row the episode's readings say something about: row key -> terms."""
    steps = _steps(events, file)
    if not any(kind == "act" for kind, _ in steps):
        return {}
    priors = ((events[0].get("belief") or {}).get("states"))
    if not isinstance(priors, dict):
        raise InputError(file, "line 1: $.belief.states", "expected the start belief of the task "
                         "states (transition counts need it)")
    names = sorted(priors)
    index = {s: i for i, s in enumerate(names)}
    for kind, step in steps:
        touched = ([x["state"] for x in step[1]] + [r for x in step[1] for r in x.get("requires", [])]
                   if kind == "act" else [step[0]])
        for s in touched:
            if s not in index:
                raise InputError(file, "line 1: $.belief.states", f"no start belief for state {s!r}")
    if len(names) > MAX_STATES:
        raise InputError(file, "line 1: $.belief.states", f"{len(names)} task states; transition "
                         f"counts hold at most {MAX_STATES} jointly")
    rows = sorted({(step[0], k) for kind, step in steps if kind == "act" for k in range(len(step[1]))})
    out: dict[str, Terms] = {}
    for name, k in rows:
        terms = _forward(steps, names, index, priors, (name, k))
        if not is_constant(terms):
            out[row_key(name, k)] = terms
    return out


def _forward(steps: list, names: list[str], index: Mapping[str, int], priors: Mapping[str, float],
             row: tuple[str, int]) -> Terms:
    n = len(names)
    bits = (np.arange(2 ** n)[:, None] >> np.arange(n)[None, :]) & 1  # joint index -> state bits
    start = np.ones(2 ** n)
    for s, i in index.items():
        p = float(priors[s])
        start = start * np.where(bits[:, i] == 1, p, 1.0 - p)
    alpha: dict[tuple[int, int], np.ndarray] = {(0, 0): start}
    for kind, step in steps:
        if kind == "read":
            state, value, sens, spec = step
            col = bits[:, index[state]]
            like = np.where(col == 1, sens if value else 1.0 - sens, (1.0 - spec) if value else spec)
            alpha = {key: a * like for key, a in alpha.items()}
            continue
        name, effects = step
        new: dict[tuple[int, int], np.ndarray] = {}
        for (s0, f0), a in alpha.items():
            # entries: (old joint index, new joint index, weight, successes, failures)
            old = np.arange(2 ** n)
            cur, w = old.copy(), a.copy()
            ds, df = np.zeros(2 ** n, dtype=int), np.zeros(2 ** n, dtype=int)
            for k, eff in enumerate(effects):
                t, v = index[eff["state"]], int(eff["value"])
                req = [index[r] for r in eff.get("requires", [])]
                ob = bits[old]
                cond = np.all(ob[:, req], axis=1) if req else np.ones(len(old), dtype=bool)
                if t in req:
                    cond &= ob[:, t] == 1
                trial = cond & (ob[:, t] != v)
                moved = np.where(v == 1, cur | (1 << t), cur & ~(1 << t))
                tracked = (name, k) == row
                p = 1.0 if tracked else float(eff["success"])
                succ_w = w[trial] * p
                fail_w = w[trial] * (1.0 - p) if not tracked else w[trial]
                old = np.concatenate([old[~trial], old[trial], old[trial]])
                cur = np.concatenate([cur[~trial], moved[trial], cur[trial]])
                w = np.concatenate([w[~trial], succ_w, fail_w])
                ds = np.concatenate([ds[~trial], ds[trial] + int(tracked), ds[trial]])
                df = np.concatenate([df[~trial], df[trial], df[trial] + int(tracked)])
            for dsv, dfv in set(zip(ds.tolist(), df.tolist())):
                sel = (ds == dsv) & (df == dfv)
                key = (s0 + dsv, f0 + dfv)
                acc = new.setdefault(key, np.zeros(2 ** n))
                np.add.at(acc, cur[sel], w[sel])
        alpha = new
    total = {key: float(a.sum()) for key, a in alpha.items()}
    top = max(total.values())
    if top <= 0.0:
        return ()
    return normalised({key: float(np.log(v)) for key, v in total.items() if v > 0.0})


__all__ = ["transition_terms"]
