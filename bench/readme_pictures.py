"""The README's pictures, made again from today's code: each bundled demo scene run through the
demo command (Cycles renders as fitted and as DeformRT resolves it) and the jellyfish job, the
panels put side by side with a caption over each saying what it shows.

    .venv/bin/python -m bench.readme_pictures            # about 8 minutes on 2 cores
    .venv/bin/python -m bench.readme_pictures makehuman  # one picture (makehuman, fig_4_12,
                                                         # makehuman_animated, jellyfish)
    .venv/bin/python -m bench.readme_pictures --compose-only  # captions again, from the last renders

Writes docs/img/<picture>.png; the demo's own output stays in out/pictures/<scene>.
"""

import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from bench.blender import load_package

ROOT = Path(__file__).resolve().parent.parent
CAPTION_SCALE = 3  # the 3 x 5 font, three pixels a dot: 15 px letters
BAND = 8 * CAPTION_SCALE  # the caption band's height over each panel
INK, PAPER = (0.95, 0.95, 0.95), (0.16, 0.16, 0.18)

# per picture: the command's arguments (demo size as width, height), and the panels it is made of:
# (file the command writes, caption), or a sheet whose two rows are captioned (fitted above, resolved below)
PICTURES = {
    "makehuman": ("makehuman_before_after.png", ["demo", "--scene", "makehuman", "--width", "480", "--height", "640"],
                  [("before.png", "as fitted"), ("after.png", "resolved by deformrt")]),
    "fig_4_12": ("fig_4_12_before_after.png", ["demo", "--scene", "fig_4_12", "--width", "540", "--height", "720"],
                 [("before.png", "fig 4.12 as fitted"), ("after.png", "resolved by deformrt")]),
    "makehuman_animated": ("makehuman_animated_frames.png",
                           ["demo", "--scene", "makehuman_animated", "--width", "180", "--height", "240"],
                           ("frames.png", "frames 1-96 as fitted",
                            "the same frames played with resolve on frame change")),
    "jellyfish": ("jellyfish_contact_sheet.png", ["jellyfish"],
                  [("contact_sheet.png", "the baked bell at the start of cycles 1 to 8, bars where its top began")]),
}


def _run(name, out):
    cmd = [sys.executable, str(ROOT), *PICTURES[name][1], "--out", str(out)]
    print(f"{name}: {' '.join(cmd[1:])}", flush=True)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, cwd=ROOT)
    print(f"{name}: {time.perf_counter() - t0:.0f} s", flush=True)


def captioned(tile, caption):
    """``tile`` (h, w, 4) with a band over it holding ``caption`` in the middle."""
    from bench.png_text import draw_text, text_width
    band = np.empty((BAND, tile.shape[1], 3))
    band[:] = PAPER
    # the largest letters up to CAPTION_SCALE that fit the tile's width
    scale = next((s for s in range(CAPTION_SCALE, 0, -1) if text_width(caption, s) <= tile.shape[1] - 8), 1)
    x = max(0, (tile.shape[1] - text_width(caption, scale)) // 2)
    draw_text(band, x, (BAND - 5 * scale) // 2, caption, INK, scale)
    return np.concatenate([np.dstack([band, np.ones(band.shape[:2])]), tile], axis=0)


def picture(name, out):
    """The README picture ``name`` from what its command wrote in ``out``."""
    from deformrt.addon.io.image_io import read_png
    panels = PICTURES[name][2]
    if isinstance(panels, tuple):  # a sheet: fitted above, resolved below
        sheet = read_png(out / panels[0])
        half = sheet.shape[0] // 2
        return np.concatenate([captioned(sheet[:half], panels[1]), captioned(sheet[half:], panels[2])])
    return np.concatenate([captioned(read_png(out / file), caption) for file, caption in panels], axis=1)


def main(args):
    load_package()
    from deformrt.addon.io.image_io import write_png
    again = "--compose-only" not in args  # --compose-only: from what the commands wrote last time
    for name in [a for a in args if not a.startswith("--")] or PICTURES:
        out = ROOT / "out" / "pictures" / name
        if again:
            _run(name, out)
        path = ROOT / "docs" / "img" / PICTURES[name][0]
        write_png(picture(name, out), path)
        print(f"wrote {path.relative_to(ROOT)}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
