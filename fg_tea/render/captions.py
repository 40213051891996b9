"""What each logged event says in one line: the captions of the episode explorer's steps
(:mod:`fg_tea.render.explore`), from the event's own fields (docs/log-format.md)."""

from __future__ import annotations

from typing import Any, Mapping

from fg_tea.world.interface import logged_viewpoint


#: The caption of each event kind that names only its own fields.
CAPTIONS = {"action": "action {action} done", "action_failed": "action {action} failed: {reason}",
            "skip": "skip {action}: its goal already holds", "activate": "start {action}",
            "confirm_search": "{object} found on {site}", "episode_end": "end: {reason}",
            "give_up": "give up on the {object}"}


def caption(e: Mapping[str, Any]) -> str:
    """One line saying what the event was."""
    kind = e.get("event", "")
    if kind == "episode_start":
        return f"start: {e.get('scenario')} · {e.get('model')} model · {e.get('planner')} · seed {e.get('seed')}"
    if kind == "decision":
        return (f"decide: look for the {e.get('object')} from {logged_viewpoint(e)} "
                f"({e.get('viewpoint_kind', 'site')}; {e.get('planner')})")
    if kind == "observation":
        seen = [o for o, v in (e.get("detections") or {}).items() if v]
        found = e.get("found_at") or {}
        what = ", ".join(f"{o} on {found.get(o, logged_viewpoint(e))}" for o in seen) or "nothing"
        return f"look from {logged_viewpoint(e)}: found {what}"
    if kind == "state_reading":
        return f"read {e.get('state')}: {'true' if e.get('value') else 'false'} ({e.get('purpose')})"
    if kind == "metrics":
        return metrics_caption(e)
    if kind == "alternative_method":
        return f"another way to {e.get('action')}: {e.get('description') or (e.get('after') or {}).get('verb')}"
    if kind == "substitute":
        used_up = "used-up " if e.get("cause") == "used_up" else ""
        again = f", {len(e['reopened'])} reopened" if e.get("reopened") else ""
        return (f"substitute: the {e.get('substitute')} stands in for the {used_up}{e.get('object')} "
                f"({_count(len(e.get('retargeted') or []), 'action')} retargeted{again})")
    if kind in CAPTIONS:
        return CAPTIONS[kind].format_map({k: e.get(k) for k in ("action", "reason", "object", "site")})
    if kind in ("fail", "reopen", "stuck", "alternative_site"):
        what = " ".join(str(e[k]) for k in ("action", "object", "site") if e.get(k))
        return kind.replace("_", " ") + (f" {what}" if what else "") + (f": {e['reason']}" if e.get("reason") else "")
    return kind.replace("_", " ")


def _count(n: Any, what: str) -> str:
    return f"{n} {what}{'' if n == 1 else 's'}"


def metrics_caption(e: Mapping[str, Any]) -> str:
    """The episode's metrics in one line (the last step's caption)."""
    outcome = "complete" if e.get("success") else f"not complete ({e.get('reason')})"
    parts = [outcome, f"{e.get('actions_complete')} of {e.get('actions_total')} actions complete, "
             f"{e.get('actions_skipped')} skipped"]
    if e.get("inspections") is not None:
        parts.append(_count(e["inspections"], "inspection") + f" ({e.get('repeated_sites', 0)} repeated)")
    if isinstance(e.get("total_distance"), (int, float)):
        parts.append(f"{e['total_distance']:.1f} m travelled")
    if isinstance(e.get("spl"), (int, float)):
        parts.append(f"SPL {e['spl']:.3f}")
    for key, what in (("state_readings", "state reading"), ("failures", "failed action")):
        if e.get(key) is not None:
            parts.append(_count(e[key], what))
    if e.get("frames") is not None:
        parts.append(_count(e["frames"], "simulation frame"))
    return "metrics: " + " · ".join(parts)
