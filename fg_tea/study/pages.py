"""A comparison's worlds in the browser: ``index.html`` beside its CSV, one row per world, linking
to the side-by-side explorer page of that world's pair of configurations (docs/design.md §9.2).

The pair is the first two models under the first planner (factorised against joint, as
``fg-tea compare`` runs them by default), or, with one model, its first two planners. Episodes are
deterministic, so a world's pair is re-run with its logs written (``explore/logs/``) rather than
every sweep episode keeping a log; a re-run whose search travel differs from its CSV row is
flagged on the page, never silently shown.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping, Sequence

from fg_tea.common.files import atomic_write_text
from fg_tea.render.page import content_security_policy, fill, html_text
from fg_tea.study.rows import sweep_progress
from fg_tea.study.sweep import Job, run_job

#: Column of the CSV the index compares.
MEASURE = "search_distance"


def _config(row: Mapping[str, Any]) -> str:
    return f"{row['model']} · {row['planner']}"


def pick_pair(jobs: Sequence[Job]) -> tuple[tuple[str, str], tuple[str, str]] | None:
    """The (model ref, planner) of the two configurations the side-by-side pages show, or None
    when the comparison has only one configuration."""
    models = list(dict.fromkeys(j.model for j in jobs))
    planners = list(dict.fromkeys(j.planner for j in jobs))
    if len(models) >= 2:
        return (models[0], planners[0]), (models[1], planners[0])
    if len(planners) >= 2:
        return (models[0], planners[0]), (models[0], planners[1])
    return None


def _number(value: Any) -> float | None:
    try:
        x = float(value)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def write_compare_pages(jobs: Sequence[Job], rows: Sequence[Mapping[str, Any]], out: Path,
                        pages: int, title: str, progress: bool = False) -> dict[str, Any]:
    """Write ``out/index.html`` and the side-by-side pages of the `pages` worlds whose pair
    differs most in search travel (with `progress`, re-run episodes are counted on stderr);
    returns {"index", "pages", "mismatches"}.
    """
    from fg_tea.render.explore import page_data, read_episode, write_page

    pair = pick_pair(jobs)
    configs = list(dict.fromkeys(_config(r) for r in rows))
    by_world: dict[int, dict[str, Mapping[str, Any]]] = {}
    for r in rows:
        by_world.setdefault(int(r["world_seed"]), {})[_config(r)] = r
    job_of = {(j.world_seed, j.model, j.planner): j for j in jobs}
    name_of: dict[tuple[str, str], str | None] = {(j.model, j.planner): None for j in jobs}
    for r in rows:  # the model's name in the rows, for the job's model reference
        name_of[(str(r["model_ref"]), str(r["planner"]))] = _config(r)
    entries: list[dict[str, Any]] = []
    for seed, cells in sorted(by_world.items()):
        diff = None
        if pair is not None:
            a, b = (cells.get(name_of.get(p) or "") for p in pair)
            if a is not None and b is not None:
                va, vb = _number(a.get(MEASURE)), _number(b.get(MEASURE))
                diff = vb - va if va is not None and vb is not None else None
        entries.append({"seed": seed, "cells": cells, "diff": diff})
    entries.sort(key=lambda e: (-(abs(e["diff"]) if e["diff"] is not None else -1.0), e["seed"]))
    explore = out / "explore"
    written: dict[int, dict[str, Any]] = {}
    mismatches: list[int] = []
    chosen = [e for e in entries if e["diff"] is not None][:pages] if pair is not None else []
    shown = sweep_progress(2 * len(chosen), label="explorer pages") if progress and chosen else None
    for entry in chosen:
        seed = entry["seed"]
        logs = []
        for model, planner in pair or ():
            job = job_of[(seed, model, planner)]
            log = explore / "logs" / f"world{seed:06d}-{Path(model).stem}-{planner.replace(':', '_')}.jsonl"
            row = run_job(job, log)
            if shown is not None:
                shown.update()
            logged = _number(row.get(MEASURE))
            recorded = _number(entry["cells"].get(name_of.get((model, planner)) or "", {}).get(MEASURE))
            if logged is not None and recorded is not None and abs(logged - recorded) > 1e-6:
                mismatches.append(seed)
            logs.append((log.name, read_episode(log)))
        data = page_data(logs, labels=[name_of.get(p) or "" for p in pair or ()])
        page = explore / f"world{seed:06d}.html"
        write_page(page, data, f"world {seed}: " + " vs ".join(name_of.get(p) or "" for p in pair or ()))
        written[seed] = {"page": page.relative_to(out).as_posix(),
                         "differ": data["divergence"]["decision"] + 1 if data.get("divergence") else None}
    index = out / "index.html"
    atomic_write_text(index, _index_html(entries, configs, pair and [name_of.get(p) or "" for p in pair],
                                         written, mismatches, title, len(entries), pages))
    return {"index": index, "pages": len(written), "mismatches": mismatches}


#: The index page; :func:`fg_tea.render.page.fill` fills its slots once, each escaped for its place.
INDEX = """<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<meta http-equiv="Content-Security-Policy" content="{{CSP}}">
<title>{{TITLE}}</title>
<style>
body { font: 14px/1.4 system-ui, sans-serif; margin: 1.5em; color: #222; }
table { border-collapse: collapse; } th, td { padding: 3px 10px; border-bottom: 1px solid #ddd; }
th { text-align: left; background: #f3f3f3; position: sticky; top: 0; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
tr.mismatch { background: #fde8e8; } .note { color: #555; }
</style></head><body>
<h1>{{TITLE}}</h1>
<p>{{WORLDS}} worlds; search travel (m) of every configuration, one row per world, sorted by the size
of the difference of the pair shown side by side. Each link opens that world's two episodes in the
explorer (a page that works from disk).</p>
{{NOTES}}
<table id="worlds"><thead><tr><th>world</th>{{HEAD}}</tr></thead>
<tbody>
{{ROWS}}
</tbody></table>
</body></html>
"""


def _index_html(entries: list[dict], configs: list[str], pair: list[str] | None, written: dict,
                mismatches: list[int], title: str, worlds: int, pages: int) -> str:
    """The index page: every value escaped as HTML text (:func:`html_text`) before it is
    assembled into its slot; the page runs no script."""
    e = html_text
    houses = any(r.get("house_sites") for x in entries for r in x["cells"].values())
    head = ("<th>sites</th>" if houses else "") + "".join(f"<th>{e(c)}</th>" for c in configs)
    if pair:
        head += f"<th>{e(pair[1])} − {e(pair[0])} (m)</th><th>first differing decision</th>"
    body = []
    for entry in entries:
        cells = "".join(
            f"<td class=num>{x:.2f}</td>" if (x := _number(entry['cells'].get(c, {}).get(MEASURE))) is not None
            else "<td>—</td>" for c in configs)
        seed = e(entry["seed"])
        page = written.get(entry["seed"])
        link = f"<a href=\"{e(page['page'])}\">world {seed}</a>" if page else f"world {seed}"
        house = next((r.get("house_sites") for r in entry["cells"].values() if r.get("house_sites")), "")
        extra = ""
        if pair:
            d = entry["diff"]
            differ = ("—" if page is None else
                      f"decision {e(page['differ'])}" if page["differ"] else "same choices")
            extra = (f"<td class=num>{d:+.2f}</td>" if d is not None else "<td>—</td>") + f"<td>{differ}</td>"
        flag = " class=mismatch" if entry["seed"] in mismatches else ""
        sites = f"<td class=num>{e(house)}</td>" if houses else ""
        body.append(f"<tr{flag}><td>{link}</td>{sites}{cells}{extra}</tr>")
    notes = []
    if pair and pages < sum(1 for x in entries if x["diff"] is not None):
        notes.append(f"Side-by-side pages are written for the {pages} worlds whose pair differs most "
                     f"(--pages); the rest are listed without a link.")
    if mismatches:
        notes.append("A re-run's search travel differed from its CSV row in worlds "
                     + ", ".join(map(str, mismatches)) + " (marked): the CSV is from other code.")
    if not pair:
        notes.append("One configuration only: there is no pair to show side by side.")
    return fill(INDEX, {"CSP": e(content_security_policy()), "TITLE": e(title), "WORLDS": e(worlds),
                        "NOTES": "".join(f"<p class=note>{e(n)}</p>" for n in notes),
                        "HEAD": head, "ROWS": "\n".join(body)})
