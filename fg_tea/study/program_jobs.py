"""A sweep's model programs, checked once before any episode (docs/design.md §4.8).

A model program (``.py``, ``module:attr`` or entry point) is built over the first house each of
its worlds gives and turned into the belief engine's graph, so a program that cannot run — a
factor's fault, or exact inference over the budget (:mod:`fg_tea.beliefs.budget`) — is refused
in one line before the first episode of any model starts, as a TOML model's faults are.
"""

from __future__ import annotations

from typing import Any, Callable, Sequence


def check_program_graphs(jobs: Sequence[Any], world_of: Callable[[str, Any], Any],
                         model_of: Callable[[str, Any], Any]) -> None:
    """Build the belief graph of every model program the jobs name, over the house of the first
    world seed each (world, knobs, model) is run on.

    Args:
        jobs: the sweep's jobs (:class:`fg_tea.study.sweep.Job`).
        world_of: the world distribution of (world, knobs) (:func:`fg_tea.study.sweep.job_world`).
        model_of: the model of (model, overrides) (:func:`fg_tea.study.sweep.job_model`).

    Raises:
        InputError: the program's one-line fault (naming the program file and the factor).
    """
    from fg_tea.beliefs.graph import build_graph
    from fg_tea.common.resources import is_program_ref

    seen: set[tuple[Any, ...]] = set()
    for job in jobs:
        key = (job.world, job.knobs, job.model, job.model_overrides)
        if key in seen or not is_program_ref(job.model):
            continue
        seen.add(key)
        build_graph(world_of(job.world, job.knobs).house(job.world_seed), model_of(job.model, job.model_overrides))


__all__ = ["check_program_graphs"]
