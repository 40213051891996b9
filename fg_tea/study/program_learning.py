"""``fg-tea learn --base my_model.py``: counts for a model program's learnable tables, from logs
(docs/design.md §12.6).

Only what the agent observed is counted, by the rules of docs/design.md §12.2:

1. **Where an object stood.** The first ``confirm_search`` of an object names the site where it
   stood when the episode began (rule 1): that is the observed value of its location variable.
2. **A task state at the start.** The readings of a state before any action's transition touched
   it (its first time slice) observe its start value when they agree (one count, whatever their
   number); readings that disagree observe nothing. A reading is taken as true: the sensor's
   errors (specificity 0.95 for the bundled sensor) bias a state's learned prior by at most that.
3. **A table over several variables** counts an episode only when every variable of its scope
   was observed in it, at the cell of the observed values.

A learnable table over a variable no log observes (a variable of the program's own, or a state
the scenario does not declare) is refused in one line, as is a log of another program (its
``episode_start.program.sha256``, or the ``learned_from`` of a learned program, must be the
base's) or of another house.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, Collection, Mapping, Sequence

import numpy as np

from fg_tea.common.errors import InputError
from fg_tea.model.program_learned import PRIOR_STRENGTH


def observed_values(events: Sequence[Mapping], file: str = "<log>") -> dict[str, Any]:
    """What one episode observed: object -> the site it stood on at the start (rule 1), and
    state -> its start value (rule 2)."""
    seen: dict[str, Any] = {}
    for e in events:
        if e.get("event") == "confirm_search" and isinstance(e.get("object"), str):
            seen.setdefault(e["object"], e.get("site"))
    touched: set[str] = set()
    readings: dict[str, list[bool]] = {}
    for e in events:
        if e.get("event") == "action" and isinstance(e.get("transition"), dict):
            touched |= {eff["state"] for eff in e["transition"].get("effects") or []
                        if isinstance(eff, dict) and isinstance(eff.get("state"), str)}
        elif e.get("event") == "state_reading" and isinstance(e.get("state"), str) \
                and isinstance(e.get("value"), bool) and e["state"] not in touched:
            readings.setdefault(e["state"], []).append(e["value"])
    for state, values in readings.items():
        if all(v == values[0] for v in values):
            seen[state] = values[0]
    return seen


def check_log(events: Sequence[Mapping], log: str, sha256: str, sites: Sequence[str]) -> None:
    """Refuse a log of another program or another house (one line naming the log and field)."""
    record = events[0].get("program") if events else None
    if not isinstance(record, dict):
        raise InputError(log, "line 1: $.program", "the log was not written by a model program; "
                         "learn a program's tables from its own episodes")
    if sha256 not in (record.get("sha256"), record.get("learned_from")):
        raise InputError(log, "line 1: $.program.sha256", f"written by another program ({record.get('spec')!r}, "
                         f"{str(record.get('sha256'))[:12]}); the base is {sha256[:12]}")
    logged = tuple(s.get("name") for s in events[0].get("sites") or [] if isinstance(s, dict))
    if logged != tuple(sites):
        raise InputError(log, "line 1: $.sites", "recorded in another house than the one the tables are "
                         "learned for (--scenario)")


def declared_states(scenario: Any) -> list[str]:
    """The task states `scenario` declares (``object.state``): the only states a log can read."""
    return [f"{o.name}.{s}" for o in scenario.objects for s in o.state_priors]


def count_tables(program: Any, episodes: Sequence[Mapping[str, Any]],
                 declared: Collection[str] | None = None) -> dict[str, np.ndarray]:
    """Counts N of every learnable table of `program` over the observed values of `episodes`.

    Args:
        declared: the task states the scenario declares (:func:`declared_states`); a state
            outside them is never read, so a learnable table over it is refused. None: every
            state the program declares is taken as readable.

    Raises:
        InputError: a learnable table's scope holds a variable no log can observe (a variable
            of the program's own, or a state the scenario does not declare).
    """
    by_name = {v.name: v for v in program.variables}
    counts = {}
    for f in program.factors:
        if not f.learnable:
            continue
        hidden = [v for v in f.scope if by_name[v].kind not in ("location", "state")]
        if hidden:
            raise InputError(program.source, f"factor {f.name!r}", f"is learnable but {hidden[0]!r} is a "
                             "variable no episode observes; only tables over locations and task states "
                             "can be counted")
        unread = [v for v in f.scope if by_name[v].kind == "state" and declared is not None and v not in declared]
        if unread:
            raise InputError(program.source, f"factor {f.name!r}", f"is learnable but {unread[0]!r} is a "
                             "state the scenario does not declare, which no episode reads; only tables "
                             "over locations and declared task states can be counted")
        n = np.zeros(tuple(by_name[v].card for v in f.scope))
        for seen in episodes:
            if all(v in seen for v in f.scope):
                cell = tuple(_index(by_name[v], seen[v]) for v in f.scope)
                if None not in cell:
                    n[cell] += 1.0
        counts[f.name] = n
    return counts


def _index(variable: Any, value: Any) -> int | None:
    labels = [getattr(v, "name", v) for v in variable.values]
    return labels.index(value) if value in labels else None


def count_transitions(program: Any, model: Any, read: Sequence[tuple[str, Sequence[Mapping]]],
                      previous: Mapping[str, Any] | None = None) -> dict[str, dict[str, Any]]:
    """Eq. (61)'s terms of every effect of the transitions `program` marks learnable, over the logs
    `read` ((file, events) pairs), by rule 5 of docs/design.md §12.2
    (:func:`fg_tea.study.transition_counts.transition_terms`; the terms of several episodes
    multiply, :func:`fg_tea.model.learned_transitions.combine`), added to `previous` (a learned
    program's ``transition_terms``). Returns ``{"boil.effect0": {"state": template, "terms": ...}}``.
    """
    from fg_tea.model.learned_transitions import combine, normalised
    from fg_tea.study.transition_counts import transition_terms

    marked = set(program.learnable_transitions)
    declared = model.declared_transitions if model.declared_transitions is not None else model.transitions
    out = {key: {"state": row["state"], "terms": normalised([tuple(t) for t in row["terms"]])}
           for key, row in (previous or {}).items()}
    for log, events in read:
        for key, terms in transition_terms(events, log).items():
            name, _, k = key.rpartition(".effect")
            if name not in marked:
                continue
            row = out.setdefault(key, {"state": declared[name].effects[int(k)].state, "terms": ()})
            row["terms"] = combine(row["terms"], terms)
    return dict(sorted(out.items()))


def learned_text(source: str, sha256: str, counts: Mapping[str, np.ndarray], logs: Sequence[str],
                 prior_strength: float, transitions: Mapping[str, Mapping[str, Any]] | None = None,
                 transition_strength: float = 0.0) -> str:
    """The learned program file (docs/design.md §12.6): it names its source and holds the counts."""
    lines = [
        f'"""Written by `fg-tea learn`: {source} with its learnable tables learned from '
        f'{len(logs)} episode log(s).',
        "",
        "Each counted table is replaced by its Dirichlet posterior mean, the declared table (normalised)",
        "being the prior mean with PRIOR_STRENGTH pseudo-counts (docs/design.md §12.6). Run it as any",
        "model program: fg-tea run --model THIS_FILE.",
        '"""',
        "",
        "from fg_tea.model.program_learned import learned_model",
        "",
        f"SOURCE = {json.dumps(source)}",
        f"learned_from = {json.dumps(sha256)}  # the SHA-256 of SOURCE when it was learned from",
        f"PRIOR_STRENGTH = {prior_strength!r}",
        f"LOGS = {json.dumps(list(logs), indent=4)}",
        f"COUNTS = {json.dumps({k: n.tolist() for k, n in counts.items()})}",
        *([f"# eq. (61) terms [successes, failures, log weight] of each learnable transition's effect "
           "(docs/design.md §12.5);",
           "# the model's transitions use eq. (63)'s success with transition_strength (S_t) pseudo-trials",
           f"transition_strength = {transition_strength!r}",
           "transition_terms = " + json.dumps({k: {"state": r["state"], "terms": [list(t) for t in r["terms"]]}
                                               for k, r in transitions.items()})] if transitions else []),
        "",
        "base, model = learned_model(SOURCE, learned_from, COUNTS, PRIOR_STRENGTH, here=__file__)",
        "",
    ]
    return "\n".join(lines)


def learn_program(logs: Sequence[str | Path], base: str, out: str | Path, scenario_ref: str | None = None,
                  prior_strength: float | None = None
                  ) -> tuple[Path, dict[str, np.ndarray], dict[str, dict[str, Any]]]:
    """``fg-tea learn --base PROGRAM``: count the program's learnable tables and the terms of its
    learnable transitions (:func:`count_transitions`) over `logs` and write the learned program
    file `out` (atomically, after it loads and builds). Returns (out, table counts, transition rows).

    Raises:
        InputError: a bad log, base, out path or option (one line: file, field, fault).
    """
    from fg_tea.common.files import atomic_write_text
    from fg_tea.model.program_file import load_program_source, program_for
    from fg_tea.model.spec import load_model
    from fg_tea.study.learn import read_log
    from fg_tea.world.scenario import load_scenario

    out = Path(out)
    if out.suffix != ".py":
        raise InputError("<command line>", "--out", f"{out} must end in .py (a learned model program)")
    strength = PRIOR_STRENGTH if prior_strength is None else prior_strength
    if not (math.isfinite(strength) and strength > 0):
        raise InputError("<command line>", "--prior-strength", f"expected a positive number, got {strength}")
    model = load_model(base)
    source = load_program_source(base)
    root = source.learned_from or source.sha256
    read = [(str(log), read_log(log)[0]) for log in logs]
    if scenario_ref is None:
        if not read:
            raise InputError("<command line>", "--scenario", "name the house, or give a log to take it from")
        start = read[0][1][0]
        scenario_ref = str(start.get("scenario_file") or start.get("scenario"))
    scenario = load_scenario(scenario_ref)
    program = program_for(scenario, model)
    if not program.learnable and not program.learnable_transitions:
        raise InputError(str(base), "factors", "the program marks no table learnable (learnable=True) "
                         "and no transition (learnable_transition)")
    episodes = []
    for log, events in read:
        check_log(events, log, root, scenario.site_names)
        episodes.append(observed_values(events, log))
    counts = count_tables(program, episodes, declared_states(scenario))
    from fg_tea.model.learned_transitions import DEFAULT_TRANSITION_STRENGTH

    previous_rows = _module_value(base, "transition_terms", {}) if source.learned_from else {}
    rows = count_transitions(program, model, read, previous_rows) if program.learnable_transitions else {}
    t_strength = (_module_value(base, "transition_strength", DEFAULT_TRANSITION_STRENGTH) if source.learned_from
                  else DEFAULT_TRANSITION_STRENGTH)
    if source.learned_from:  # learning on from a learned program: its counts add up
        previous = _counts_of(base)
        counts = {k: v + np.asarray(previous.get(k, 0.0)) for k, v in counts.items()}
        origin = _source_of(base)
        if origin.endswith(".py") and not Path(origin).is_absolute():
            origin = str(Path(base).resolve().parent / origin)
        all_logs = _logs_of(base) + [str(p) for p in logs]
    else:
        origin, all_logs = source.spec, [str(p) for p in logs]
    if origin.endswith(".py"):  # named from the learned file's folder, wherever it is run from
        origin = os.path.relpath(Path(origin).resolve(), out.resolve().parent)
    text = learned_text(origin, root, counts, all_logs, strength, rows, t_strength)
    atomic_write_text(out, text)
    load_model(str(out))  # it loads: every check a run makes of a program
    return out, counts, rows


_MISSING = object()


def _module_value(path: str, name: str, default: Any = _MISSING) -> Any:
    import ast

    tree = ast.parse(Path(path).read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == name for t in node.targets):
            return ast.literal_eval(node.value)
    if default is not _MISSING:
        return default
    raise InputError(path, name, "not a learned program file (no such assignment)")


def _source_of(path: str) -> str:
    return str(_module_value(path, "SOURCE"))


def _counts_of(path: str) -> dict[str, Any]:
    return dict(_module_value(path, "COUNTS"))


def _logs_of(path: str) -> list[str]:
    return list(_module_value(path, "LOGS"))


__all__ = ["observed_values", "check_log", "count_tables", "count_transitions", "declared_states", "learned_text",
           "learn_program"]
