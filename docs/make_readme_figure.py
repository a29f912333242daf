"""Render the bundled ColorChecker and depth-of-field scenes and put their developed images
side by side as docs/scenes.png (the README's picture).

    .venv/bin/python docs/make_readme_figure.py
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import cv2
import numpy as np

from spectral_cam import load_scene
from spectral_cam.job import run_render_job

HERE = Path(__file__).parent
SCENES = ("colorchecker.toml", "dof.toml")


def main() -> None:
    tiles = []
    with tempfile.TemporaryDirectory() as folder:
        for name in SCENES:
            out = Path(folder) / name
            run_render_job(load_scene(HERE.parent / "scenes" / name), out)
            tiles.append(cv2.imread(str(out / "image.png")))
    gap = np.full((tiles[0].shape[0], 8, 3), 255, np.uint8)
    cv2.imwrite(str(HERE / "scenes.png"), np.hstack([tiles[0], gap, tiles[1]]))
    print(f"wrote {HERE / 'scenes.png'}")


if __name__ == "__main__":
    main()
