"""Regenerate the documentation's pictures from named commands.

Two kinds. A *video still* is one frame of a video, written by ``fg-tea render LOG --still FRAME``
from the log of a named ``fg-tea run``; the frame's caption (the overlay's first line) is what the
picture's alt text in the README and docs says it shows. A *plot* is the PNG a named command writes
(``fg-tea preview``'s floor plan, an experiment's figure); what its alt text counts (rooms, sites,
room vantages) is checked against the scenario it draws. A figure that an experiment writes into
``experiments/results/`` is not here: a ``<!-- figure -->`` marker copies it
(docs/tools/render_numbers.py).

``python docs/tools/pictures.py`` rewrites the pictures; ``python docs/tools/pictures.py --check``
runs the same commands into a temporary folder and exits 1 if a caption is no longer the one the
docs promise or a command no longer writes its picture (``tests/test_docs_pictures.py``).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

#: picture -> (the run's arguments, the frame, what the frame's caption says).
PICTURES = {
    "docs/video_still.png": (["run", "--no-video"], 360,
                             "room glance: kitchen (2 sites): found kettle on kitchen_counter"),
}


#: picture -> (the command, ``{out}`` standing for a folder; the file it writes there; the scenario
#: the picture draws and what its alt text counts in it, or None).
PLOTS = {
    "docs/floorplan_default_apartment.png": (
        ["fg-tea", "preview", "default_apartment", "--out", "{out}/preview.png"], "preview_plan.png", None),
    "docs/floorplan_generated_medium.png": (
        ["fg-tea", "preview", "scenarios/generated_medium.json", "--out", "{out}/preview.png"],
        "preview_plan.png", ("scenarios/generated_medium.json", {"sites": 27, "room vantages": 9})),
    "docs/inspect_marginals_prior_violation.png": (
        ["python", "experiments/inspect_marginals.py", "--scenario", "prior_violation", "--out",
         "{out}/marginals.png"], "marginals.png", None),
}


def counts(scenario: str) -> dict[str, int]:
    """What a floor plan's alt text may count: the scenario's sites and room vantages."""
    import json

    data = json.loads((ROOT / scenario).read_text(encoding="utf-8"))
    vantages = data.get("room_vantages", [])
    return {"sites": len(data["sites"]),
            "room vantages": sum(len(v) for v in vantages.values()) if isinstance(vantages, dict)
            else len(vantages)}


def plot(picture: str, folder: Path) -> Path:
    """Run the plot's command in `folder`; return the PNG it wrote."""
    import subprocess

    command, written, _ = PLOTS[picture]
    folder.mkdir(parents=True, exist_ok=True)
    argv = [a.replace("{out}", str(folder)) for a in command]
    argv = ([sys.executable, "-m", "fg_tea.cli", *argv[1:]] if argv[0] == "fg-tea"
            else [sys.executable, *argv[1:]])
    done = subprocess.run(argv, cwd=ROOT, capture_output=True, text=True, stdin=subprocess.DEVNULL)
    png = folder / written
    if done.returncode != 0 or not png.is_file() or png.stat().st_size == 0:
        raise RuntimeError(f"{picture}: {' '.join(command)} wrote no {written}: "
                           f"{done.stderr.strip()[-300:]}")
    return png


def make(picture: str, folder: Path) -> tuple[Path, str]:
    """Run the picture's commands in `folder`; return the PNG written and the frame's caption."""
    import contextlib
    import io

    from fg_tea.cli.main import main

    run, frame, _ = PICTURES[picture]
    out = folder / Path(picture).stem
    with contextlib.redirect_stdout(io.StringIO()):
        if main([*run, "--out", str(out)]) != 0:
            raise RuntimeError(f"{picture}: fg-tea {' '.join(run)} failed")
    printed = io.StringIO()
    png = out / "still.png"
    with contextlib.redirect_stdout(printed):
        if main(["render", str(out / "episode.jsonl"), "--still", str(frame), "--out", str(png)]) != 0:
            raise RuntimeError(f"{picture}: fg-tea render --still {frame} failed")
    caption = printed.getvalue().split(": ", 2)[-1].strip().rstrip(")")
    return png, caption


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="pictures.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--check", action="store_true",
                   help="change nothing; exit 1 if a frame no longer shows what its caption says")
    args = p.parse_args(argv)
    failed = 0
    with tempfile.TemporaryDirectory() as tmp:
        for picture, (_, frame, promised) in PICTURES.items():
            png, caption = make(picture, Path(tmp))
            if promised not in caption:
                print(f"{picture}: frame {frame} shows {caption!r}, the docs say {promised!r}")
                failed += 1
            elif not args.check:
                shutil.copyfile(png, ROOT / picture)
                print(f"wrote: {picture} ({caption})")
        for picture, (_, _, claims) in PLOTS.items():
            try:
                png = plot(picture, Path(tmp))
            except RuntimeError as exc:
                print(exc)
                failed += 1
                continue
            if claims is not None and counts(claims[0]) != claims[1]:
                print(f"{picture}: {claims[0]} has {counts(claims[0])}, the docs say {claims[1]}")
                failed += 1
            elif not args.check:
                shutil.copyfile(png, ROOT / picture)
                print(f"wrote: {picture}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
