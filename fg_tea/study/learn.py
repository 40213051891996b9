"""Learning from logs: counting what the agent itself observed, and writing the learned model file.

The equations live in :mod:`fg_tea.model.learning` (docs/design.md §12, eqs. 50-55); this module
reads episode logs through the guarded reader, applies the counting rules
(:func:`counts_from_events`) and writes the model that ``fg-tea learn`` produces. It never reads
``episode_end.world_truth``, ``episode_end.yardstick`` or ``episode_start.world``.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Mapping, Sequence

from fg_tea.common.errors import InputError
from fg_tea.model.learning import (
    COUNTED_SENSOR,
    RELATION_CLASSES,
    SENSOR_KEYS,
    Counts,
    Learning,
    Source,
    _sorted,
    band_of,
    beta_interval,
)
from fg_tea.world.interface import logged_viewpoint

if TYPE_CHECKING:  # model imports this module; import it lazily to avoid a cycle
    pass




def _fail(file: str, where: str, fault: str) -> InputError:
    return InputError(file, where, fault)


def read_log(path: str | Path) -> tuple[list[dict], str]:
    """The events of a log file (:func:`fg_tea.episode.log.read_log`, strict: every check of the
    log's meaning) and the episode's identity: the sha256 of its content
    (:func:`fg_tea.episode.log.episode_digest`), the same for two files of one episode whatever
    their bytes (key order, spacing, blank lines).

    Raises:
        InputError: the file cannot be read, a line is not an event, or the log has no
            ``episode_start``.
    """
    from fg_tea.episode.log import episode_digest, read_log as read_events

    events = read_events(path, strict=True)
    return events, episode_digest(events)


def house_of(events: Sequence[Mapping], file: str = "<log>") -> tuple[str, ...]:
    """The site names of the house a log was recorded in (from ``episode_start.sites``)."""
    sites = events[0].get("sites")
    if not isinstance(sites, list) or not sites or not all(
            isinstance(s, dict) and isinstance(s.get("name"), str) for s in sites):
        raise _fail(file, "line 1: $.sites", "expected the list of the house's sites")
    return tuple(s["name"] for s in sites)


def counts_from_events(events: Sequence[Mapping], file: str = "<log>") -> Counts:
    """The counts of one episode, by the counting rules below (docs/design.md §12.2).

    Only what the agent observed is read; ``world_truth``, ``yardstick`` and
    ``episode_start.world`` are not.

    1. **Sites.** The first ``confirm_search`` of each object names the site where the agent
       found it, i.e. where it stood when the episode began (eq. 3): N_{c(o), site} += 1. Later
       confirmations of the same object (after a recovery moved it) are not counted.
    2. **Detector.** For an object found at site j*, every ``observation`` up to and including the
       one that found it, that considered the object and had j* in view, is one trial at the site
       where the object stood: a hit if it was seen there (``found_at``), else a miss, in the band
       of the look (close, or a glance nearer or farther than 2.5 m from j*). Looks without j* in
       view, and every look for an object never found, carry no count (where the object stood is
       unknown to the agent).
    3. **State sensor.** A reading is settled when its state's time slice (the readings between two
       actions whose transitions touch the state) holds at least two *other* readings and they all
       agree; their value is the settled value. The reading is then a true/false
       positive/negative of the sensor ``state``.
    4. **Co-location.** For every two objects of different categories that were both found (rule
       1's sites, where each stood at the start), one count of their relation: the same site,
       the same room on different sites (``episode_start.sites[].room``), or apart; keyed by the
       two categories in alphabetical order. A pair with an object never found carries no count.
    5. **Transitions.** For every effect of every transition the episode ran, the likelihood of its
       success probability given the episode's state readings, under the agent's own model of the
       episode as logged: eq. (61), a mixture over the numbers of successes and failures
       (:func:`fg_tea.study.transition_counts.transition_terms`). An effect the readings say
       nothing about has no count.

    Raises:
        InputError: the log lacks a field a rule needs (file and event named).
    """
    start = events[0]
    cats = start.get("categories") or {}
    if not isinstance(cats, dict):
        raise _fail(file, "line 1: $.categories", "expected object -> category")
    sites = house_of(events, file)
    site_pos = {s["name"]: s.get("position") for s in start["sites"]}
    views = {v["name"]: v for v in start.get("viewpoints") or [] if isinstance(v, dict)}

    def category(obj: str) -> str:  # logs before categories were logged: names are categories
        return str(cats.get(obj, obj))

    found: dict[str, tuple[str, int]] = {}  # object -> (site, index of its first confirmation)
    for i, e in enumerate(events):
        if e["event"] == "confirm_search":
            obj, site = e.get("object"), e.get("site")
            if not isinstance(obj, str) or site not in sites:
                raise _fail(file, f"event {i}: confirm_search", "expected an object and a site of the house")
            found.setdefault(obj, (site, i))
    site_counts: dict[str, dict[str, float]] = {}
    for obj, (site, _) in found.items():
        row = site_counts.setdefault(category(obj), {})
        row[site] = row.get(site, 0.0) + 1.0

    det: dict[str, dict[str, tuple[float, float]]] = {}
    for i, e in enumerate(events):
        if e["event"] != "observation":
            continue
        try:
            considered = list(e["objects"]) if "objects" in e else list(e["detections"])
            in_view = list(e.get("sites_in_view") or [logged_viewpoint(e)])
            found_at = dict(e.get("found_at") or {})
            detections = dict(e["detections"])
            kind = e.get("viewpoint_kind", "site")
            vp_name = logged_viewpoint(e)
        except (KeyError, TypeError):
            raise _fail(file, f"event {i}: observation", "expected objects, detections and site") from None
        for obj in considered:
            if obj not in found:
                continue
            site, first = found[obj]
            if i > first or site not in in_view:
                continue
            if detections.get(obj) and obj not in found_at and kind == "site":
                found_at[obj] = logged_viewpoint(e)  # logs before found_at: a close look sees its own site
            distance = _distance(views.get(vp_name), site_pos.get(site))
            band = band_of(kind, distance)
            hit = bool(detections.get(obj)) and found_at.get(obj) == site
            h, m = det.setdefault(category(obj), {}).get(band, (0.0, 0.0))
            det[category(obj)][band] = (h + 1.0, m) if hit else (h, m + 1.0)

    sensor: dict[str, float] = {}
    slices: dict[tuple[str, int], list[bool]] = {}
    serial: dict[str, int] = {}
    for e in events:
        if e["event"] == "action" and isinstance(e.get("transition"), dict):
            for eff in e["transition"].get("effects") or []:
                if isinstance(eff, dict) and isinstance(eff.get("state"), str):
                    serial[eff["state"]] = serial.get(eff["state"], 0) + 1
        elif e["event"] == "state_reading" and isinstance(e.get("state"), str) \
                and isinstance(e.get("value"), bool):
            key = (e["state"], serial.get(e["state"], 0))
            slices.setdefault(key, []).append(e["value"])
    for values in slices.values():
        if len(values) < 3:
            continue
        for k, value in enumerate(values):
            others = values[:k] + values[k + 1:]
            if all(v == others[0] for v in others):
                name = ("true_positive" if value else "false_negative") if others[0] else \
                       ("false_positive" if value else "true_negative")
                sensor[name] = sensor.get(name, 0.0) + 1.0
    sensors = {COUNTED_SENSOR: {k: sensor.get(k, 0.0) for k in SENSOR_KEYS}} if sensor else {}

    room_of = {s["name"]: s.get("room") for s in start["sites"]}
    rel: dict[str, dict[str, list[float]]] = {}
    names = sorted(found)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            ca, cb = category(a), category(b)
            if ca == cb:
                continue
            (sa, _), (sb, _) = found[a], found[b]
            k = 0 if sa == sb else 1 if room_of.get(sa) is not None and room_of.get(sa) == room_of.get(sb) else 2
            cat_lo, cat_hi = sorted((ca, cb))
            cell = rel.setdefault(cat_lo, {}).setdefault(cat_hi, [0.0, 0.0, 0.0])
            cell[k] += 1.0
    co_location = {a: {b: tuple(v) for b, v in row.items()} for a, row in rel.items()}
    from fg_tea.study.transition_counts import transition_terms

    return Counts(_sorted(site_counts), _sorted(det), sensors, _sorted(co_location),
                  _sorted(transition_terms(events, file)))


def _distance(view: Mapping | None, site_position: Any) -> float:
    if view is None or not site_position:
        return 0.0
    (x, y), (sx, sy) = view["position"][:2], site_position[:2]
    return math.hypot(float(x) - float(sx), float(y) - float(sy))


def learn(logs: Iterable[tuple[Sequence[Mapping], Source]], base: Learning | None = None,
          forgetting: float | None = None) -> Learning:
    """Add the counts of `logs`, one after another, to `base` (eq. 53 between logs).

    Args:
        logs: (events, source) per log, in the order they are added.
        base: the base model's learning (None: no experience, default strengths).
        forgetting: gamma; None keeps the base's.

    Raises:
        InputError: a log was recorded in another house than the counts held so far, or is
            already counted (the same episode: same ``source.sha256``, the content digest of
            :func:`read_log`).
    """
    state = base or Learning()
    if forgetting is not None:
        state = replace(state, forgetting=forgetting)
    gamma = state.forgetting
    counts, house, sources = state.counts, state.house, list(state.sources)
    seen = {s.sha256: s.file for s in sources}
    for events, source in logs:
        log_house = house_of(events, source.file)
        if house and log_house != house:
            raise InputError(source.file, "line 1: $.sites",
                             f"recorded in another house ({len(log_house)} sites) than the "
                             f"counts held so far ({len(house)} sites"
                             f"{', from ' + sources[0].file if sources else ''})")
        if source.sha256 in seen:
            raise InputError(source.file, "$", f"this log is already counted (as {seen[source.sha256]})")
        counts = counts.scaled(gamma).plus(counts_from_events(events, source.file))
        house = log_house
        seen[source.sha256] = source.file
        sources.append(source)
    return replace(state, counts=counts, house=house, sources=tuple(sources))


def _toml_key(key: str) -> str:
    if key and all(ch.isalnum() or ch in "_-" for ch in key):
        return key
    return json.dumps(key)


def _num(x: float) -> str:
    x = float(x)
    return str(int(x)) + ".0" if x.is_integer() else repr(x)


def model_text(learning: Learning, base_ref: str, name: str, base_name: str,
               transitions: Mapping[str, Any] | None = None) -> str:
    """The TOML of a learned model that ``extends`` `base_ref` and holds every count (`transitions`:
    the base model's, whose effects' state templates and declared successes label the rows)."""
    description = (f"{base_name} with location, detector, sensor and co-location counts learned from "
                   f"{len(learning.sources)} episode log(s)")
    lines = [
        "# Written by `fg-tea learn`: the base model plus counts from the agent's own logs",
        "# (docs/design.md §12). Counts are totals over every source log listed below.",
        f"extends = {json.dumps(base_ref)}",
        f"name = {json.dumps(name)}",
        f"description = {json.dumps(description)}",
        "",
        "[learning]",
        f"prior_strength = {_num(learning.prior_strength)}          # S, eq. 50",
        f"detection_strength = {_num(learning.detection_strength)}      # S_d, eq. 51",
        f"sensor_strength = {_num(learning.sensor_strength)}         # S_s, eq. 52",
        f"relation_strength = {_num(learning.relation_strength)}       # S_r, eq. 54",
        f"forgetting = {_num(learning.forgetting)}              # gamma, eq. 53",
        *([f"transition_strength = {_num(learning.transition_strength)}     # S_t, eq. 62"]
          if learning.counts.transitions else []),
        "house = [" + ", ".join(json.dumps(s) for s in learning.house) + "]",
        "sources = [",
        *[f"  {{ file = {json.dumps(s.file)}, sha256 = \"{s.sha256}\" }}," for s in learning.sources],
        "]",
    ]
    c = learning.counts
    for cat, row in c.sites.items():
        lines += ["", f"[learning.sites.{_toml_key(cat)}]   # objects found per site (rule 1)"]
        lines += [f"{_toml_key(site)} = {_num(n)}" for site, n in row.items()]
    for cat, drow in c.detection.items():
        lines += ["", f"[learning.detection.{_toml_key(cat)}]   # looks at the site where it stood (rule 2)"]
        lines += [f"{band} = {{ hits = {_num(h)}, misses = {_num(m)} }}" for band, (h, m) in drow.items()]
    for sensor, srow in c.sensors.items():
        lines += ["", f"[learning.sensors.{_toml_key(sensor)}]   # settled readings (rule 3)"]
        lines += [f"{k} = {_num(srow.get(k, 0.0))}" for k in SENSOR_KEYS]
    for first, rrow in c.co_location.items():
        table = f"[learning.co_location.{_toml_key(first)}]"
        lines += ["", f"{table}   # pairs found together: same site, same room, apart (rule 4)"]
        for second, cell in rrow.items():
            counts = ", ".join(f"{k} = {_num(n)}" for k, n in zip(RELATION_CLASSES, cell))
            lines.append(f"{_toml_key(second)} = {{ {counts} }}")
    lines += _transition_lines(learning, transitions or {})
    return "\n".join(lines) + "\n"


def _transition_lines(learning: Learning, transitions: Mapping[str, Any]) -> list[str]:
    """``[learning.transitions.<name>.effect<k>]`` per row (rule 5): the state template and eq. (61)'s
    terms, with the learned success (eq. 63) and its 95 % interval as a comment."""
    from fg_tea.model import learned_transitions as lt

    lines: list[str] = []
    for key, terms in learning.counts.transitions.items():
        name, _, k = key.rpartition(".effect")
        spec = transitions.get(name)
        if spec is None or int(k) >= len(spec.effects):
            raise InputError("<command line>", "--base", f"the logs ran transition {name!r} effect {k}, "
                             "which the base model does not declare; learn with the model the episodes used")
        effect = spec.effects[int(k)]
        mean = lt.posterior_mean(effect.success, learning.transition_strength, terms)
        lo, hi = lt.interval(effect.success, learning.transition_strength, terms)
        succ, fail = lt.expected_counts(effect.success, learning.transition_strength, terms)
        lines += ["", f"[learning.transitions.{_toml_key(name)}.effect{k}]   # eq. 61 (rule 5): declared "
                  f"{effect.success:g}, learned {mean:.4f} (95 % interval {lo:.3f}-{hi:.3f}); "
                  f"expected {succ:.2f} successes, {fail:.2f} failures",
                  f"state = {json.dumps(effect.state)}",
                  "terms = [" + ", ".join(f"[{_num(a)}, {_num(b)}, {_num(w)}]" for a, b, w in terms) + "]"]
    return lines


def base_reference(base_path: Path, out: Path, bundled_name: str | None) -> str:
    """How `out` names its base in ``extends``: a bundled name, or a path relative to `out`'s
    folder without the ``.toml`` suffix (as the ``extends`` resolver expects)."""
    import os

    if bundled_name is not None:
        return bundled_name
    rel = os.path.relpath(base_path.resolve(), out.resolve().parent)
    return rel[:-5] if rel.endswith(".toml") else rel


def summary(learning: Learning, transitions: Mapping[str, Any] | None = None) -> dict:
    """What was learned, as numbers: per category the learned site shares (without the declared
    prior), per detector cell the posterior interval of the hit rate under a flat prior, and with
    the base model's declared `transitions`, per counted effect the declared and learned success
    (eq. 63) with its 95 % interval and the expected successes and failures (eq. 62)."""
    from fg_tea.model import learned_transitions as lt

    out: dict[str, Any] = {"sources": len(learning.sources), "sites": {}, "detection": {},
                           "co_location": {}, "transitions": {}}
    for key, terms in learning.counts.transitions.items():
        name, _, k = key.rpartition(".effect")
        spec = (transitions or {}).get(name)
        if spec is None or int(k) >= len(spec.effects):
            continue
        p0, strength = spec.effects[int(k)].success, learning.transition_strength
        succ, fail = lt.expected_counts(p0, strength, terms)
        out["transitions"][f"{name}:{spec.effects[int(k)].state}"] = {
            "declared": p0, "learned": round(lt.posterior_mean(p0, strength, terms), 4),
            "interval_95": [round(x, 3) for x in lt.interval(p0, strength, terms)],
            "expected_successes": round(succ, 3), "expected_failures": round(fail, 3)}
    for first, rrow in learning.counts.co_location.items():
        for second, cell in rrow.items():
            total = sum(cell)
            out["co_location"][f"{first}~{second}"] = (
                {k: round(n / total, 3) for k, n in zip(RELATION_CLASSES, cell)} if total else {})
    for cat, row in learning.counts.sites.items():
        total = sum(row.values())
        out["sites"][cat] = {s: round(n / total, 3) for s, n in row.items() if n} if total else {}
    for cat, drow in learning.counts.detection.items():
        out["detection"][cat] = {
            band: {"hits": h, "misses": m, "rate": round(h / (h + m), 3) if h + m else None,
                   "interval_95": [round(x, 3) for x in beta_interval(h + 1, m + 1)]}
            for band, (h, m) in drow.items()}
    return out


def _not_counted_by_bytes(log: str | Path, state: Learning) -> None:
    """Models learned before sources named episodes by content hold the sha256 of a log's bytes:
    the same file is refused against those too."""
    from fg_tea.episode.provenance import sha256_file

    held = {s.sha256: s.file for s in state.sources}
    raw = sha256_file(log)
    if raw in held:
        raise InputError(str(log), "$", f"this log is already counted (as {held[raw]})")


def learn_files(logs: Sequence[str | Path], base: str | Path, out: str | Path,
                name: str | None = None, forgetting: float | None = None,
                prior_strength: float | None = None) -> tuple[Path, Learning]:
    """``fg-tea learn``: write a model that extends `base` and holds the counts of `logs`.

    The out path is checked before any log is read; the file is written atomically, and it is
    loaded (every model check) before it replaces anything.

    Raises:
        InputError: a bad log, base, out path or option (one line: file, field, fault).
    """
    from fg_tea.common.files import atomic_path
    from fg_tea.common.resources import _exists, resolve_model
    from fg_tea.model.spec import load_model

    out = Path(out)
    if name is not None and not name.strip():
        raise InputError("<command line>", "--name", "a model name must not be empty")
    if out.is_dir():
        raise InputError("<command line>", "--out", f"{out} is a folder; name a file")
    if out.suffix != ".toml":
        raise InputError("<command line>", "--out", f"{out} must end in .toml (a model file)")
    if out.exists() and not out.is_file():
        raise InputError("<command line>", "--out", f"{out} is not a regular file")
    folder = out.parent if str(out.parent) else Path(".")
    import os

    if folder.exists() and not folder.is_dir():
        raise InputError("<command line>", "--out", f"{folder} is not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError("<command line>", "--out", f"cannot create folder {folder}: "
                         f"{exc.strerror or exc}") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError("<command line>", "--out", f"cannot write into folder {folder}")
    base_path = Path(resolve_model(base))
    base_model = load_model(base)
    if base_model.program is not None:
        raise InputError("<command line>", "--base", f"{base!r} is a model program; learning writes a TOML "
                         f"model extending its base, so learn from the program's base model "
                         f"({base_model.program.base!r}) (learned programs are not built yet)")
    if base_model.facing_tolerance or base_model.occlusion:
        raise InputError("<command line>", "--base", f"{base_model.name!r} sets [perception] "
                         "facing_tolerance or occlusion, which learned detection probabilities "
                         "(eq. 51) cannot be combined with yet; learn from a base without them")
    try:
        same = out.exists() and out.resolve() == base_path.resolve()
    except OSError:
        same = False
    if same:
        raise InputError("<command line>", "--out", "would overwrite its own base model; "
                         "write the learned model to another file")
    if forgetting is not None and not 0.0 < forgetting <= 1.0:
        raise InputError("<command line>", "--forgetting", f"expected a value in (0, 1], got {forgetting}")
    if prior_strength is not None and not (math.isfinite(prior_strength) and prior_strength > 0):
        raise InputError("<command line>", "--prior-strength", f"expected a positive number, got {prior_strength}")
    state = base_model.learning or Learning()
    read = []
    for log in logs:
        events, sha = read_log(log)
        _not_counted_by_bytes(log, state)
        read.append((events, Source(str(log), sha)))
    if prior_strength is not None:
        state = replace(state, prior_strength=prior_strength)
    learning = learn(read, state, forgetting)
    bare = str(base)
    bundled = bare if (not _exists(Path(bare)) and not Path(bare).suffix
                       and len(Path(bare).parts) == 1) else None
    ref = base_reference(base_path, out, bundled)
    shadow = folder / f"{ref}.toml"
    if bundled is not None and (shadow.exists() or shadow.name == out.name):
        raise InputError("<command line>", "--out", f"{shadow} would shadow the bundled base "
                         f"model {bundled!r} (extends looks beside the file first); write the "
                         "learned model under another name or folder")
    stem = base_model.name if base_model.name.endswith("_learned") else f"{base_model.name}_learned"
    declared = base_model.declared_transitions or base_model.transitions
    text = model_text(learning, ref, name or stem, base_model.name, declared)
    try:
        with atomic_path(out) as tmp:
            tmp.write_text(text, encoding="utf-8")
            try:
                load_model(tmp)
            except InputError as exc:
                raise InputError(out, exc.path, exc.fault) from None
    except OSError as exc:
        raise InputError("<command line>", "--out", f"cannot write {out}: {exc.strerror or exc}") from None
    return out, learning


__all__ = ["base_reference", "counts_from_events", "house_of", "learn", "learn_files", "model_text",
           "read_log", "summary"]
