"""A sweep row's key back to its job (docs/design.md §11): every committed row names its episode
completely in its ``key``, so a row can be run again, checked or traced from the key alone."""

from __future__ import annotations

import re
from typing import Any

from fg_tea.common.errors import InputError
from fg_tea.study.sweep import Job


def job_from_key(key: str, **fields: Any) -> Job:
    """The job a row's `key` names (`fields`, e.g. ``gtsam_check``, are not in keys).

    Raises:
        InputError: the key does not spell a job, or the job's key would not be `key`.
    """
    try:
        parts = dict(p.split("=", 1) for p in key.split("|"))
        job = Job(world=parts["world"], world_seed=int(parts["ws"]), model=parts["model"],
                  planner=parts["planner"], seed=int(parts["seed"]), knobs=_pairs(parts.get("knobs")),
                  model_overrides=_pairs(parts.get("mo")), env_overrides=_pairs(parts.get("eo")),
                  env=parts.get("env", "pybullet"), camera=parts.get("camera", ""),
                  max_frames=int(parts.get("frames", 50_000)), max_steps=int(parts.get("steps", 2_000)),
                  task=parts.get("task", "make_tea"), **fields)
    except (ValueError, KeyError) as exc:
        raise InputError("<episodes>", "key", f"{key!r} does not name a job ({exc})") from None
    if job.key != key:
        raise InputError("<episodes>", "key", f"{key!r} names the job {job.key!r}, not itself")
    return job


def _pairs(text: str | None) -> tuple[tuple[str, Any], ...]:
    """``name=value,...`` of a key back to pairs: booleans and numbers as keys spell them, and a
    value may hold commas (``unfindable=mug,teabag``): a new pair starts only at ``,name=``."""
    items = (item.partition("=") for item in re.split(r",(?=[A-Za-z_]\w*=)", text or "") if "=" in item)
    return tuple((name, value == "True" if value in ("True", "False") else _number(value))
                 for name, _, value in items)


def _number(text: str) -> Any:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text
