"""Lifelong sweeps: does an agent that learns from its own episodes search less, episode after episode?

This module answers *how do search and the learned beliefs change over K consecutive episodes in
one household, when episode k uses the model learned (docs/design.md §12) from that household's
episodes before k?* It is the sweep layer behind ``fg-tea compare --lifelong K`` and
``experiments/lifelong.py``; it drives environments (the fake house or PyBullet), so it is not
agent-side code.

For each household (an index h) and each arm the agent lives K episodes. Placements come from a
world distribution, drawn afresh each episode with world seed ``1000 h + k`` (the household's
habits are the distribution's), or from one fixed scenario (the same placements every episode,
episode seed ``1000 h + k``). Arms, all on the same placements and seeds:

- ``hand-set``: the model as written, every episode;
- ``learned``: site priors, detector and sensor learned (eqs. 50-53), the hand-set relational
  weights of a joint model kept (co-location counts are gathered but not applied);
- ``learned-correlations`` (models with co-location relations only): everything learned, the
  relational weights too (eqs. 54-55).

With several forgetting factors the learned arms are run once per gamma (``learned (γ=0.6)``).
An object can be moved for good mid-sequence (the recovery experiment).

Every row scores the episode (search travel, inspections, SPL, inspections until the focus
object is found) and the calibration of the belief the agent started the episode with, against
the truth of the drawn placements (evaluation only: nothing here feeds the truth to the agent):
the log loss and Brier score of the start location beliefs, the log loss of the start belief's
relation class (same site / same room / apart) for every related category pair, and the
(probability, outcome) pairs behind an expected calibration error pooled over households.
"""

from __future__ import annotations

import csv
import hashlib
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from fg_tea.common.errors import InputError
from fg_tea.common.files import atomic_path, atomic_write_text
from fg_tea.common.stats import Interval, bootstrap_statistic, t_interval
from fg_tea.common.tables import table_lines

#: The arms of a lifelong sweep (docs/design.md §12): the written model, learning with the
#: hand-set correlations, learning the correlations too.
HAND_SET, LEARNED, LEARNED_CORRELATIONS = "hand-set", "learned", "learned-correlations"
#: Seeds of household h: world (or episode) seed 1000 h + k for its k-th episode (k < 1000).
SEED_STRIDE = 1000
#: Per-episode columns of episodes.csv.
FIELDS = ["model", "arm", "household", "episode", "world_seed", "success", "focus_site",
          "focus_inspections", "inspections", "search_distance", "spl", "prior_true_focus",
          "log_loss", "brier", "relation_log_loss", "learned_logs"]
#: Curves: (column, label) of every metric with a 95 % t-interval over households.
METRICS = [("focus_inspections", "inspections until the {focus} is found"),
           ("search_distance", "search travel (m)"), ("inspections", "inspections"),
           ("spl", "SPL"), ("log_loss", "-log q0(true site), mean over objects (nats)"),
           ("brier", "Brier score of q0, mean over objects"),
           ("relation_log_loss", "-log q0(true relation class) (nats)")]
#: Every file :func:`write_outputs` writes.
OUTPUTS = ("episodes.csv", "curves.csv", "summary.md", "curves.png", "focus_curve.png")
#: Bootstrap resamples of households for the interval of the pooled calibration error.
BOOTSTRAP = 1000


@dataclass(frozen=True)
class HouseholdSpec:
    """One household's run of every arm of one model.

    Attributes:
        source: a world distribution (bundled name or file), or with `fixed` a scenario.
        fixed: True: every episode uses `source`'s own placements (a scenario).
        model: model reference (bundled name, ablation or file).
        household: index h; seeds are ``1000 h + k``.
        episodes: K >= 1.
        env: ``fake`` or ``pybullet``.
        planner: planner name.
        forgetting: gamma values of the learned arms (None: the model's own, default 1).
        move: (object, site, after): from episode after+1 on, the object stands at site.
        focus: the object whose inspections until found are reported.
        relation_pairs: category pairs scored by the relation log loss.
        log_dir: when given, every learned arm's episode log is written to
            ``log_dir/MODEL/ARM/householdH/episodeKK.jsonl`` and named (with its sha256) as the
            source of the counts, so ``fg-tea learn`` on those files rebuilds the arm's model.
        learn_transitions: the learned arms of a TOML model apply learned transition successes
            too (eq. 63); off, transition counts are gathered but the declared successes are kept.
            A model program's learned arm applies the successes of the transitions it marks
            learnable (``Program.learnable_transition``) whatever this says: the mark is the opt-in.
        effect_success: environment only, (truth effect, P(it happens)) pairs
            (:attr:`fg_tea.env.base.EnvConfig.effect_success`); never given to the agent.
    """

    source: str
    fixed: bool
    model: str
    household: int
    episodes: int
    env: str = "fake"
    planner: str = "efe"
    forgetting: tuple[float | None, ...] = (None,)
    move: tuple[str, str, int] | None = None
    focus: str = "mug"
    relation_pairs: tuple[tuple[str, str], ...] = ()
    log_dir: str | None = None
    learn_transitions: bool = False
    effect_success: tuple[tuple[str, float], ...] = ()


def relation_pairs(models: Iterable[Any]) -> tuple[tuple[str, str], ...]:
    """The category pairs (alphabetical) that any of `models` relates by co-location."""
    pairs = {tuple(sorted(r.categories)) for m in models for r in m.relations if r.kind == "co_location"}
    return tuple(sorted(pairs))


def arms_of(model: Any, forgetting: Sequence[float | None] = (None,)) -> list[tuple[str, str, float | None]]:
    """(arm label, kind, gamma) of every arm a model is run with (kind: hand-set/learned/...)."""
    kinds = [LEARNED] + ([LEARNED_CORRELATIONS] if model.program is None and model.structure == "joint" and any(
        r.kind == "co_location" for r in model.relations) else [])
    out: list[tuple[str, str, float | None]] = [(HAND_SET, HAND_SET, None)]
    for gamma in forgetting:
        for kind in kinds:
            label = kind if len(forgetting) == 1 else f"{kind} (γ={1.0 if gamma is None else gamma:g})"
            out.append((label, kind, gamma))
    return out


def _placements(spec: HouseholdSpec, k: int):
    from fg_tea.world.distributions import load_world
    from fg_tea.world.scenario import load_scenario

    seed = SEED_STRIDE * spec.household + k
    if spec.fixed:
        scenario = load_scenario(spec.source)
    else:
        scenario = load_world(spec.source).sample(seed)
    if spec.move is not None and k + 1 > spec.move[2]:  # the household moves an object for good
        obj, site, _ = spec.move
        scenario = replace(scenario, objects=tuple(
            replace(o, true_site=site) if o.name == obj else o for o in scenario.objects))
    return scenario, seed


def _episode(spec: HouseholdSpec, model, scenario, seed: int, path: Path | None = None):
    from fg_tea.episode.log import EventLog
    from fg_tea.episode.runner import EpisodeRunner, RunConfig, env_config_for
    from fg_tea.study.sweep import job_env

    extra: dict[str, Any] = {"effect_success": dict(spec.effect_success)} if spec.effect_success else {}
    env = job_env(spec.env, scenario, env_config_for(model, **extra))
    log = EventLog(path) if path is not None else None
    try:
        runner = EpisodeRunner(scenario, model, env, RunConfig(seed=seed, planner=spec.planner),
                               log, world=None if spec.fixed else spec.source)
        metrics = runner.run()
    finally:
        if log is not None:
            log.close()
        close = getattr(env, "close", None)
        if close is not None:
            close()
    return runner.events, metrics


def _relation_class(rooms: Mapping[str, str], a: str, b: str) -> int:
    return 0 if a == b else 1 if rooms[a] == rooms[b] else 2


def score_start_belief(scenario, model, events: Sequence[Mapping],
                       pairs: Sequence[tuple[str, str]]) -> dict[str, Any]:
    """Calibration of the belief an episode started with, against the placements' truth.

    Returns:
        ``log_loss`` (mean over objects of -ln q0(true site)), ``brier`` (mean over objects of
        sum_j (q0(j) - [j true])^2), ``relation_log_loss`` (mean over related object pairs of
        -ln of the start belief's probability of their true relation class; None without pairs),
        and ``calibration``, an (M, 2) array of (q0(j), [j true]) over objects and sites.
    """
    from fg_tea.beliefs.engine import BeliefEngine

    start = events[0]
    sites = [s["name"] for s in start["sites"]]
    prior = start["belief"]["locations"]
    truth = {o.name: o.true_site for o in scenario.objects}
    losses, briers, records = [], [], []
    for obj, q in prior.items():
        q = np.asarray(q, dtype=float)
        hit = (np.asarray(sites) == truth[obj]).astype(float)
        losses.append(-math.log(max(float(q[sites.index(truth[obj])]), 1e-300)))
        briers.append(float(((q - hit) ** 2).sum()))
        records.append(np.column_stack([q, hit]))
    rel = None
    categories = {o.name: o.category for o in scenario.objects}
    wanted = {tuple(sorted(p)) for p in pairs}
    objs = [o for o in scenario.object_names]
    related = [(a, b) for i, a in enumerate(objs) for b in objs[i + 1:]
               if categories[a] != categories[b] and tuple(sorted((categories[a], categories[b]))) in wanted]
    if related:
        engine = BeliefEngine(scenario, model)
        pw = engine.pairwise()
        rooms = {s.name: s.room for s in scenario.sites}
        index = {o: i for i, o in enumerate(engine.objects)}
        k = len(engine.sites)
        cls = np.array([[_relation_class(rooms, engine.sites[i], engine.sites[j]) for j in range(k)]
                        for i in range(k)])
        rl = []
        for a, b in related:
            block = pw[index[a], index[b]]
            p = float(block[cls == _relation_class(rooms, truth[a], truth[b])].sum())
            rl.append(-math.log(max(p, 1e-300)))
        rel = float(np.mean(rl))
    return {"log_loss": float(np.mean(losses)), "brier": float(np.mean(briers)),
            "relation_log_loss": rel, "calibration": np.concatenate(records)}


def run_household(spec: HouseholdSpec) -> list[dict]:
    """K episodes of one household for every arm of one model (same placements and seeds).

    Episode k of a learned arm uses the model learned, in memory, from the arm's own episodes
    before k (:func:`fg_tea.study.learn.learn`, one log at a time, eq. 53 between logs).

    Returns:
        One row per (arm, episode): the :data:`FIELDS` columns plus ``state_readings``,
        ``goals_true`` (evaluation: the task's goals hold in truth), ``_learning`` (the counts the
        episode's model was learned from; None for the first and for ``hand-set``) and
        ``_calibration`` (the start belief's (probability, outcome) pairs, for the pooled
        calibration error); these four are not written.
    """
    from fg_tea.model.learning import Learning, Source
    from fg_tea.model.spec import apply_learning, load_model
    from fg_tea.study.learn import learn

    base = load_model(spec.model)
    rows = []
    for label, kind, gamma in arms_of(base, spec.forgetting):
        learning = None
        tables: dict | None = None  # a program's learnable tables: counts so far (design §12.6)
        moves: dict = {}  # a program's learnable transitions: eq. (61) terms so far (design §12.5)
        for k in range(spec.episodes):
            scenario, seed = _placements(spec, k)
            model = base
            if base.program is not None:
                if tables is not None:
                    model = _program_counts(base, tables, moves)
            elif learning is not None:
                applied = learning if kind == LEARNED_CORRELATIONS else replace(
                    learning, counts=learning.counts.without_relations())
                if not spec.learn_transitions:
                    applied = replace(applied, counts=replace(applied.counts, transitions={}))
                model = apply_learning(base, applied)
            path = None
            if spec.log_dir is not None and kind != HAND_SET:
                slug = "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in label)
                path = (Path(spec.log_dir) / base.name / slug / f"household{spec.household}"
                        / f"episode{k + 1:02d}.jsonl")
            events, m = _episode(spec, model, scenario, seed, path)
            scores = score_start_belief(scenario, model, events, spec.relation_pairs)
            start = events[0]
            sites = [s["name"] for s in start["sites"]]
            truth = {o.name: o.true_site for o in scenario.objects}
            focus = spec.focus if spec.focus in truth else None
            rows.append({
                "model": base.name, "arm": label,
                "household": spec.household, "episode": k + 1, "world_seed": seed,
                "success": int(bool(m["success"])),
                "focus_site": truth[focus] if focus else "",
                "focus_inspections": (m["inspections_until_resolved"] or {}).get(focus) if focus else None,
                "inspections": m["inspections"], "search_distance": m["search_distance"],
                "spl": m["spl"],
                "prior_true_focus": (start["belief"]["locations"][focus][sites.index(truth[focus])]
                                     if focus else None),
                "log_loss": scores["log_loss"], "brier": scores["brier"],
                "relation_log_loss": scores["relation_log_loss"],
                "learned_logs": (k if tables is not None else 0) if base.program is not None
                else 0 if learning is None else len(learning.sources),
                "state_readings": sum(e["event"] == "state_reading" for e in events),
                "goals_true": m.get("goals_true"),
                "_learning": learning,
                "_calibration": scores["calibration"]})
            if kind != HAND_SET and base.program is not None:
                tables = _add_tables(tables, base, scenario, events)
                moves = _add_transitions(moves, base, scenario, events, gamma)
            elif kind != HAND_SET:
                # in memory the source is named by household and episode, and its "sha256" is the
                # episode seed (there is no file); with log_dir, the written file and its hash
                source = (Source(str(path), hashlib.sha256(path.read_bytes()).hexdigest())
                          if path is not None else
                          Source(f"household{spec.household}/episode{k + 1}", f"{seed:064x}"))
                learning = learn([(events, source)], learning or Learning(), gamma)
    return rows


def _program_counts(base: Any, tables: Mapping[str, Any], moves: Mapping[str, Any] | None = None) -> Any:
    from fg_tea.model.learned_transitions import DEFAULT_TRANSITION_STRENGTH, with_transition_terms
    from fg_tea.model.program_learned import with_counts

    model = with_counts(base, tables)
    if moves:  # the learned successes of the transitions the program marks learnable (eq. 63)
        model = with_transition_terms(model, moves, DEFAULT_TRANSITION_STRENGTH, base.source)
    return model


def _add_transitions(moves: Mapping[str, Any], base: Any, scenario: Any, events: Sequence[Mapping],
                     gamma: float | None) -> dict:
    """`moves` (eq. 61's terms of the program's learnable transitions so far, forgotten by gamma,
    eq. 53) times one episode's (design §12.5; :func:`fg_tea.study.program_learning.count_transitions`)."""
    from fg_tea.model.learned_transitions import scaled
    from fg_tea.model.program_file import program_for
    from fg_tea.study.program_learning import count_transitions

    program = program_for(scenario, base)
    if not program.learnable_transitions:
        return {}
    g = 1.0 if gamma is None else gamma
    kept = {k: {"state": r["state"], "terms": scaled(r["terms"], g)} for k, r in moves.items()}
    return count_transitions(program, base, [("<lifelong episode>", events)], kept)


def _add_tables(tables: dict | None, base: Any, scenario: Any, events: Sequence[Mapping]) -> dict:
    """`tables` plus one episode's counts of the program's learnable tables (design §12.6)."""
    from fg_tea.model.program_file import program_for
    from fg_tea.study.program_learning import count_tables, declared_states, observed_values

    new = count_tables(program_for(scenario, base), [observed_values(events)], declared_states(scenario))
    return {k: n + (tables or {}).get(k, 0.0) for k, n in new.items()}


def run_lifelong(specs: Sequence[HouseholdSpec], workers: int = 1) -> list[dict]:
    """Every household spec, serially (workers = 1) or on a process pool; rows sorted."""
    rows: list[dict] = []
    if workers > 1 and len(specs) > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(workers) as pool:
            for part in pool.map(run_household, specs):
                rows += part
    else:
        for spec in specs:
            rows += run_household(spec)
    rows.sort(key=lambda r: (r["model"], r["arm"], r["household"], r["episode"]))
    return rows


# ---------------------------------------------------------------------------------------------
# Curves, summary and plot


def pooled_ece(records: Sequence[np.ndarray], seed: int = 0) -> tuple[float, float, float]:
    """Expected calibration error (10 bins) of the pooled (probability, outcome) pairs of
    several households, with a 95 % percentile interval from resampling households
    (:func:`fg_tea.common.stats.bootstrap_statistic`: NaN bounds with one household)."""
    from fg_tea.episode.quality import calibration, expected_calibration_error

    return bootstrap_statistic(records, lambda recs: expected_calibration_error(calibration(np.concatenate(recs))),
                               BOOTSTRAP, seed)


def curves(rows: Sequence[Mapping]) -> list[dict]:
    """Per model, arm and episode: n, and mean with 95 % interval of every metric, success and
    the prior on the focus object's true site (t-intervals over households) and the pooled
    calibration error ``ece`` (household bootstrap)."""
    out = []
    keys = sorted({(r["model"], r["arm"]) for r in rows}, key=lambda x: (x[0], _arm_order(x[1])))
    for model, arm in keys:
        mine = [r for r in rows if r["model"] == model and r["arm"] == arm]
        for k in sorted({r["episode"] for r in mine}):
            sel = [r for r in mine if r["episode"] == k]
            row: dict[str, Any] = {"model": model, "arm": arm, "episode": k, "n": len(sel)}
            for key in [m for m, _ in METRICS] + ["success", "prior_true_focus"]:
                iv = t_interval(r[key] for r in sel)
                row[key], row[key + "_lo"], row[key + "_hi"] = iv.mean, iv.low, iv.high
            row["ece"], row["ece_lo"], row["ece_hi"] = pooled_ece(
                [r["_calibration"] for r in sel if r.get("_calibration") is not None], seed=k)
            out.append(row)
    return out


def _arm_order(arm: str) -> tuple[int, str]:
    for i, kind in enumerate((HAND_SET, LEARNED_CORRELATIONS, LEARNED)):
        if arm.startswith(kind):
            return (i, arm)
    return (9, arm)


def write_outputs(rows: Sequence[Mapping], out: Path, title: str, command: str,
                  focus: str = "mug") -> dict[str, Path]:
    """episodes.csv, curves.csv, summary.md, curves.png and focus_curve.png under `out`, each
    written whole or not at all (a temporary file and a rename)."""
    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / "episodes.csv") as tmp, tmp.open("w", newline="") as f:
        w = csv.DictWriter(f, FIELDS, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    table = curves(rows)
    with atomic_path(out / "curves.csv") as tmp, tmp.open("w", newline="") as f:
        w = csv.DictWriter(f, list(table[0]))
        w.writeheader()
        w.writerows({k: (round(v, 6) if isinstance(v, float) else v) for k, v in c.items()}
                    for c in table)
    atomic_write_text(out / "summary.md", summary_markdown(rows, table, title, command, focus))
    plot(table, out / "curves.png", title, focus)
    plot(table, out / "focus_curve.png", title, focus, only=("focus_inspections",))
    return {"episodes": out / "episodes.csv", "curves": out / "curves.csv",
            "summary": out / "summary.md", "plot": out / "curves.png",
            "focus_plot": out / "focus_curve.png"}


def _fmt(c: Interval) -> str:
    return c.fmt(3)


def summary_markdown(rows: Sequence[Mapping], table: Sequence[Mapping], title: str, command: str,
                     focus: str = "mug") -> str:
    """Episode 1 against episode K per model, arm and metric, paired over households, and each
    learned arm against the hand-set arm at episode K (same placements)."""
    K = max(r["episode"] for r in rows)
    lines = [f"# {title}", "", f"Regenerate: `{command}`", "",
             "Means with 95 % t-intervals over households (calibration error: pooled over "
             "households, 95 % household-bootstrap interval). Paired: episode K minus episode 1 of "
             "the same household and arm; each arm minus hand-set at episode K (same placements).", ""]
    body = []
    keys = sorted({(r["model"], r["arm"]) for r in rows}, key=lambda x: (x[0], _arm_order(x[1])))
    for model, arm in keys:
        for key, label in METRICS:
            def get(a: str, k: int) -> dict:
                return {r["household"]: r[key] for r in rows
                        if r["model"] == model and r["arm"] == a and r["episode"] == k
                        and r[key] is not None and r[key] != ""}
            first, last, hand = get(arm, 1), get(arm, K), get(HAND_SET, K)
            if not first and not last:
                continue
            d1 = [last[h] - first[h] for h in first if h in last]
            d2 = [last[h] - hand[h] for h in last if h in hand] if arm != HAND_SET else []
            body.append([model, arm, label.format(focus=focus), _fmt(t_interval(first.values())),
                         _fmt(t_interval(last.values())), _fmt(t_interval(d1)), _fmt(t_interval(d2)) if d2 else "–"])
        c1 = [c for c in table if c["model"] == model and c["arm"] == arm and c["episode"] == 1]
        cK = [c for c in table if c["model"] == model and c["arm"] == arm and c["episode"] == K]
        if c1 and cK:
            body.append([model, arm, "calibration error of q0 (ECE, pooled)", _fmt(_ece(c1[0])), _fmt(_ece(cK[0])),
                         "–", "–"])
    lines += table_lines(["model", "arm", "metric", "episode 1", "episode K", "K − 1 (paired)",
                          "arm − hand-set at K"], body, align="left")
    lines += _between_arms(rows, keys, focus)
    lines += ["", f"{len(rows)} episodes; success rate "
              f"{np.mean([r['success'] for r in rows]):.3f}."]
    return "\n".join(lines) + "\n"


def _ece(c: Mapping) -> Interval:
    return Interval(c["ece"], c["ece_lo"], c["ece_hi"], c["n"])


#: Columns compared between learned arms, episode by episode (paired over households).
BETWEEN = [("focus_inspections", "inspections until the {focus} is found"),
           ("search_distance", "search travel (m)"),
           ("prior_true_focus", "q0 of the {focus}'s true site"),
           ("relation_log_loss", "-log q0(true relation class)")]


def _gamma_of(arm: str) -> float:
    """The forgetting factor in an arm label such as ``learned (γ=0.6)`` (1 without one)."""
    if "γ=" not in arm:
        return 1.0
    return float(arm.split("γ=")[1].rstrip(")"))


def _between_arms(rows: Sequence[Mapping], keys: Sequence[tuple[str, str]], focus: str) -> list[str]:
    """Per episode, each further learned arm of a model minus its first learned arm (paired
    over households): learned-correlations − learned, or γ = g − the first γ given."""
    out: list[str] = []
    for model in sorted({m for m, _ in keys}):
        learned = [a for m, a in keys if m == model and a != HAND_SET]
        if len(learned) < 2:
            continue
        # the reference: the plain learned arm, with the largest gamma (least forgetting)
        ref = min(learned, key=lambda a: (a.startswith(LEARNED_CORRELATIONS), -_gamma_of(a)))
        others = sorted((a for a in learned if a != ref), key=lambda a: (
            a.startswith(LEARNED_CORRELATIONS), -_gamma_of(a)))
        episodes = sorted({r["episode"] for r in rows})
        out += ["", f"**{model}: paired differences between learned arms, per episode** (mean "
                f"[95 % t-interval] over households, reference arm `{ref}`)", ""]
        body = []
        for arm in others:
            for key, label in BETWEEN:
                cells = []
                for k in episodes:
                    a = {r["household"]: r[key] for r in rows if r["model"] == model and r["arm"] == arm
                         and r["episode"] == k and r[key] not in (None, "")}
                    b = {r["household"]: r[key] for r in rows if r["model"] == model and r["arm"] == ref
                         and r["episode"] == k and r[key] not in (None, "")}
                    d = t_interval(a[h] - b[h] for h in a if h in b)
                    cells.append(d.fmt(2))
                if all(c == "–" for c in cells):
                    continue
                body.append([arm, label.format(focus=focus), *cells])
        out += table_lines([f"arm − {ref}", "metric", *(f"ep. {k}" for k in episodes)], body, align="left")
    return out


def plot(table: Sequence[Mapping], path: Path, title: str, focus: str = "mug",
         only: Sequence[str] | None = None) -> None:
    """Learning curves with 95 % bands: one panel per metric (or only the metrics `only`
    names), one line per model and arm."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [m for m in METRICS if any(not math.isnan(c[m[0]]) for c in table)] + \
        [("ece", "calibration error of q0 (ECE)")]
    if only is not None:
        panels = [m for m in panels if m[0] in only]
    cols = min(4, len(panels))
    rows_n = math.ceil(len(panels) / cols)
    wide = 6.0 if cols == 1 else 4.2
    fig, axes = plt.subplots(rows_n, cols, figsize=(wide * cols, 3.4 * rows_n + (0.4 if cols == 1 else 0)),
                             squeeze=False)
    colours = {"factorised": "tab:blue", "joint": "tab:orange"}
    styles = {HAND_SET: ":", LEARNED: "-", LEARNED_CORRELATIONS: "--"}
    keys = sorted({(c["model"], c["arm"]) for c in table}, key=lambda x: (x[0], _arm_order(x[1])))
    palette = iter(["tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink", "tab:gray"])
    extra: dict[str, str] = {}
    for ax, (key, label) in zip(axes.flat, panels):
        for model, arm in keys:
            sel = [c for c in table if c["model"] == model and c["arm"] == arm]
            kind = next((s for s in (LEARNED_CORRELATIONS, LEARNED, HAND_SET) if arm.startswith(s)), LEARNED)
            colour = colours.get(model) or extra.setdefault(model, next(palette, "black"))
            if kind == LEARNED_CORRELATIONS or ("γ=" in arm and arm != kind):
                colour = extra.setdefault(f"{model}/{arm}", next(palette, "black"))
            k = [c["episode"] for c in sel]
            ax.plot(k, [c[key] for c in sel], styles[kind], marker=".", color=colour,
                    label=f"{model}, {arm}")
            ax.fill_between(k, [c[key + "_lo"] for c in sel], [c[key + "_hi"] for c in sel],
                            color=colour, alpha=0.05 if kind == HAND_SET else 0.12)
        ax.set(xlabel="episode in the household", title=label.format(focus=focus))
        ax.xaxis.get_major_locator().set_params(integer=True)
        ax.title.set_fontsize(9)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    import textwrap

    heading = title + " (95 % intervals over households)"
    fig.suptitle(textwrap.fill(heading, 70) if cols == 1 else heading, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def check_move(move: tuple[str, str, int] | None, scenario, episodes: int) -> None:
    """Refuse a move naming an object or site the house lacks, or an episode out of range.

    Raises:
        InputError: one line naming ``--move`` and the fault.
    """
    if move is None:
        return
    obj, site, after = move
    if obj not in scenario.object_names:
        raise InputError("<command line>", "--move", f"no object {obj!r} in {scenario.name} "
                         f"(objects: {', '.join(scenario.object_names)})")
    if site not in scenario.site_names:
        raise InputError("<command line>", "--move", f"no site {site!r} in {scenario.name}")
    if not 0 <= after < episodes:
        raise InputError("<command line>", "--move", f"AFTER must be from 0 to {episodes - 1} "
                         f"(the episodes before the move), got {after}")


__all__ = ["FIELDS", "HAND_SET", "HouseholdSpec", "LEARNED", "LEARNED_CORRELATIONS", "METRICS",
           "arms_of", "check_move", "curves", "plot", "pooled_ece", "relation_pairs",
           "run_household", "run_lifelong", "score_start_belief", "summary_markdown",
           "write_outputs"]
