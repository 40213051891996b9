"""Regenerate the documentation's pictures of the default episode from named commands.

Each picture is one frame of a video, written by ``fg-tea render LOG --still FRAME`` from the log of
a named ``fg-tea run``; the frame's caption (the overlay's first line) is what the picture's alt
text in the README and docs says it shows. ``python docs/tools/pictures.py`` rewrites the pictures;
``python docs/tools/pictures.py --check`` runs the same commands into a temporary folder and exits
1 if a caption is no longer the one the docs promise (``tests/test_docs_pictures.py``).
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
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
