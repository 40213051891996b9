"""The explorer's pages, their sizes and how fast they open (docs/design.md §9.2).

Runs the episodes a user explores first, writes their pages with ``fg-tea explore`` (and the index
of a ``compare --quick`` run), opens each in headless Chromium (the system's, through Playwright),
and records each page's size, its steps and the time until it is drawn and interactive; takes a
screenshot of each for the docs.

- ``one``: the default episode (``fg-tea run``);
- ``two``: the default episode, factorised beside joint (they part at decision 2);
- ``houses27``: a 27-site generated house, factorised beside joint: the first world seed from 0
  whose two episodes make different choices (the rule is fixed here, before any run);
- ``milk``: a 27-site milk-and-sugar episode (five objects);
- ``index``: the index of ``fg-tea compare --quick``.

    python experiments/explorer_pages.py --out experiments/results/explorer
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

from fg_tea.common.files import atomic_write_text, out_folder
from fg_tea.common.tables import table_lines
from fg_tea.study.rows import write_csv_atomic

#: Chromium's flags on a machine with no network and no display.
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run", "--disable-dev-shm-usage"]


def cli(*args, cwd: Path) -> str:
    proc = subprocess.run([sys.executable, "-m", "fg_tea.cli", *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, stdin=subprocess.DEVNULL)
    if proc.returncode != 0:
        raise SystemExit(f"explorer_pages: fg-tea {' '.join(map(str, args))} failed: {proc.stderr.strip()[-500:]}")
    return proc.stdout


def diverging_world(work: Path, world: str, task: str, first: int = 0, tries: int = 20) -> tuple[int, list[Path]]:
    """The first world seed from `first` whose factorised and joint episodes choose differently."""
    from fg_tea.render.explore import align, episode_data, read_episode
    from fg_tea.study.sweep import Job, run_job

    for seed in range(first, first + tries):
        logs = []
        for model in ("factorised", "joint"):
            log = work / f"{world}-{seed}-{model}.jsonl"
            run_job(Job(world, seed, model, "efe", task=task), log)
            logs.append(log)
        a, b = (episode_data(read_episode(p)) for p in logs)
        if align(a, b)["divergence"] is not None:
            return seed, logs
    raise SystemExit(f"explorer_pages: no world of {world} in seeds {first}..{first + tries - 1} diverges")


def build_parser() -> argparse.ArgumentParser:
    from fg_tea.common.options import experiment_parser

    p = experiment_parser(__doc__, __file__, "§9.2")
    p.add_argument("--out", type=out_folder, default="runs/experiments/explorer_pages",
                   help="folder for pages.csv, pages.md and the screenshots (default: %(default)s)")
    p.add_argument("--chromium", default=shutil.which("chromium") or "/usr/bin/chromium",
                   help="the Chromium binary (default: the one on PATH)")
    return p


def main(argv=None) -> int:
    p = build_parser()
    args = p.parse_args(argv)
    out = Path(args.out).resolve()
    if not Path(args.chromium).is_file():
        p.error(f"--chromium: {args.chromium} not found (Debian: apt-get install chromium)")
    work = out / "work"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    from fg_tea.study.sweep import Job, run_job

    for model in ("factorised", "joint"):
        cli("run", "--no-video", "--model", model, "--out", work / model, cwd=ROOT)
    pages: dict[str, tuple[list[Path], str]] = {
        "one": ([work / "factorised" / "episode.jsonl"], "the default episode"),
        "two": ([work / "factorised" / "episode.jsonl", work / "joint" / "episode.jsonl"],
                "the default episode, factorised beside joint"),
    }
    seed, logs = diverging_world(work, "generated_medium", "make_tea")
    pages["houses27"] = (logs, f"generated_medium world {seed}, factorised beside joint")
    milk = work / "milk.jsonl"
    run_job(Job("generated_medium_milk_sugar", 3, "factorised", "efe", task="make_tea_milk_sugar"), milk)
    pages["milk"] = ([milk], "generated_medium_milk_sugar world 3, five objects")
    for name, (logs, _) in pages.items():
        cli("explore", *logs, "--out", work / f"{name}.html", cwd=ROOT)
    cli("compare", "--quick", "--out", work / "compare", cwd=ROOT)

    from playwright.sync_api import sync_playwright

    from fg_tea.render.explore import read_episode

    rows = []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=args.chromium, args=ARGS)
        targets = [(name, work / f"{name}.html", what, logs) for name, (logs, what) in pages.items()]
        targets.append(("index", work / "compare" / "index.html", "fg-tea compare --quick", []))
        for name, path, what, logs in targets:
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            errors: list[str] = []
            page.on("pageerror", lambda e, errors=errors: errors.append(str(e)))
            t0 = time.perf_counter()
            page.goto(path.as_uri())
            if name != "index":
                page.wait_for_function("document.body.dataset.ready === '1'", timeout=30_000)
            ready = (time.perf_counter() - t0) * 1e3
            if name != "index":  # the step shown in the docs: the divergence, or a mid-episode look
                index = page.evaluate("explorer.data.divergence ? explorer.data.divergence.pair : "
                                      "explorer.data.pairs.findIndex((p, i) => i > 0 && "
                                      "explorer.data.episodes[0].steps[p[0]].event === 'observation')")
                page.evaluate(f"explorer.go({max(index, 0)})")
            page.screenshot(path=str(out / f"{name}.png"))
            starts = [read_episode(log)[0] for log in logs]
            rows.append({"page": name, "what": what, "episodes": len(logs),
                         "sites": len(starts[0]["sites"]) if starts else "",
                         "objects": len(starts[0]["objects"]) if starts else "",
                         "steps": sum(len(read_episode(log)) for log in logs) if logs else "",
                         "bytes": path.stat().st_size, "ready_ms": round(ready, 1),
                         "errors": len(errors)})
            page.close()
        browser.close()
    write_csv_atomic(out / "pages.csv", rows)
    lines = ["# Explorer pages", "",
             "Written by `python experiments/explorer_pages.py --out " + str(args.out) + "`: each page's "
             "size and the time from opening it in headless Chromium until it is drawn and "
             "interactive (this machine, one run).", ""]
    lines += table_lines(["page", "what", "episodes", "sites", "objects", "steps", "size (kB)", "ready (ms)",
                          "page errors"],
                         [[r["page"], r["what"], r["episodes"], r["sites"], r["objects"], r["steps"],
                           f"{r['bytes'] / 1e3:.0f}", f"{r['ready_ms']:.0f}", r["errors"]] for r in rows], align="left")
    atomic_write_text(out / "pages.md", "\n".join(lines) + "\n")
    shutil.rmtree(work, ignore_errors=True)
    for r in rows:
        print(f"{r['page']}: {r['bytes'] / 1e6:.2f} MB, ready in {r['ready_ms']:.0f} ms, {r['errors']} page errors")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
