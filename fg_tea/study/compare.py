"""A comparison from Python: models x planners over sampled worlds, paired (docs/design.md §11).

The same sweep and report as ``fg-tea compare``, for scripts: every (model, planner) solves the
same world seeds, rows go to ``episodes.csv`` as they finish (a rerun resumes), and the report
(summary, paired differences, plots) is written beside it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

from fg_tea.study.report import comparison_report
from fg_tea.study.seeds import check_resumable
from fg_tea.study.sweep import check_jobs, plan_sweep, run_sweep


def compare(world: str, models: Sequence[str] = ("factorised", "joint"),
            planners: Sequence[str] = ("efe",), *, worlds: int = 10, first_seed: int = 0,
            env: str = "pybullet", out: str | Path = "runs/compare", executor: str = "process",
            workers: int | None = None, address: str | None = None, resume: bool = True,
            progress: bool = True, episode_seeds: str = "independent") -> dict[str, Any]:
    """Run a paired comparison and write its report; return the rows and the files written.

    Args:
        world: a world distribution (bundled name such as ``"correlated"``, or a path).
        models: model names or paths.
        planners: planner specs (``"efe"``, ``"lookahead"``, ``"optimal"``...).
        worlds: how many world seeds, from `first_seed`.
        env: ``"pybullet"`` (the default, as ``fg-tea compare``'s) or ``"fake"`` (fast, same
            geometry and truth, no rendering: ``--env fake``).
        out: the output folder (``episodes.csv``, ``summary.md``, plots).
        executor, workers, address, resume, progress: as ``fg-tea compare``'s options.
        episode_seeds: ``"independent"`` or ``"world"``, as ``fg-tea compare --episode-seeds``
            (:func:`fg_tea.study.sweep.plan_sweep`).

    Returns:
        ``{"rows": [...], "files": {name: path}}``.

    Raises:
        InputError: an unknown world, model or planner, or an ``episodes.csv`` in `out` whose
            episodes ran under the other episode-seed scheme (checked before any episode).
        SweepError: an episode failed; finished rows stay in ``episodes.csv`` for a resume.
    """
    jobs = plan_sweep([world], worlds, list(models), list(planners), first_seed=first_seed, env=env,
                      episode_seeds=episode_seeds)
    check_jobs(jobs)
    out = Path(out)
    check_resumable(jobs, out / "episodes.csv", resume)
    rows = run_sweep(jobs, out / "episodes.csv", executor, workers=workers, address=address,
                     resume=resume, progress=progress, label="compare")
    files = comparison_report(rows, out, title=f"Factorised vs joint beliefs on `{world}` worlds",
                              command=f"fg.compare({world!r}, {list(models)!r}, {list(planners)!r}, "
                                      f"worlds={worlds}, first_seed={first_seed}, env={env!r}, "
                                      f"episode_seeds={episode_seeds!r})")
    return {"rows": rows, "files": files}
