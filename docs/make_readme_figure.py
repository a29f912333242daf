"""Render the bundled ColorChecker and depth-of-field scenes and put their developed images
side by side as docs/scenes.png (the README's picture).

    .venv/bin/python docs/make_readme_figure.py           # writes docs/scenes.png
    .venv/bin/python docs/make_readme_figure.py --check   # compares a fresh figure with it

The render is pinned to Mitsuba's ``llvm_ad_spectral`` variant (CPU, the one that made the
committed figure): ``render.variant = "auto"`` picks ``cuda_ad_spectral`` where a GPU works,
or ``scalar_spectral`` without libLLVM, and each variant draws its own Monte-Carlo samples
for the same seed, so their noise differs pixel by pixel (scalar: a mean of 2 grey levels
from the LLVM figure). With the variant pinned the figure is the same on every run and thread
count; it needs libLLVM >= 16.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
SCENES = ("colorchecker.toml", "dof.toml")
#: Scene overrides of the figure: the Monte-Carlo noise depends on the variant.
OVERRIDES = {"render.variant": "llvm_ad_spectral"}
#: Mean absolute difference, in 8-bit grey levels, that --check accepts (float rounding
#: between CPUs; another variant's noise gives about 2).
TOLERANCE = 0.25


def make_figure() -> np.ndarray:
    """The figure as a BGR uint8 array: the scenes' developed images, 8 white pixels apart."""
    import cv2

    from spectral_cam import load_scene
    from spectral_cam.job import run_render_job

    tiles = []
    with tempfile.TemporaryDirectory() as folder:
        for name in SCENES:
            out = Path(folder) / name
            run_render_job(load_scene(HERE.parent / "scenes" / name, overrides=OVERRIDES), out)
            tiles.append(cv2.imread(str(out / "image.png")))
    gap = np.full((tiles[0].shape[0], 8, 3), 255, np.uint8)
    return np.hstack([tiles[0], gap, tiles[1]])


def difference(figure: np.ndarray, path: Path = HERE / "scenes.png") -> float:
    """Mean absolute difference, in grey levels, between ``figure`` and the PNG at ``path``."""
    import cv2

    committed = cv2.imread(str(path))
    if committed is None or committed.shape != figure.shape:
        return float("inf")
    return float(np.abs(committed.astype(np.int16) - figure.astype(np.int16)).mean())


def main(argv: list[str] | None = None) -> int:
    import cv2

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare a fresh figure with docs/scenes.png")
    args = parser.parse_args(argv)
    figure = make_figure()
    if args.check:
        diff = difference(figure)
        print(f"mean difference from {HERE / 'scenes.png'}: {diff:.4f} grey levels (tolerance {TOLERANCE})")
        return 0 if diff <= TOLERANCE else 1
    cv2.imwrite(str(HERE / "scenes.png"), figure)
    print(f"wrote {HERE / 'scenes.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
