"""Render the outdoor scenes at their defaults — the crop field from a drone, plants to the
horizon, plants close up, the tabletop — through the whole chain (spectral render, sensor, DNG,
ISP) and put them side by side as docs/world.png (the README's picture of issue 24's content).

    .venv/bin/python docs/make_world_figure.py
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import cv2
import numpy as np

from spectral_cam import load_scene
from spectral_cam.job import run_render_job

HERE = Path(__file__).parent
SCENES = ("field.toml", "meadow.toml", "vegetation.toml", "tabletop.toml")


def main() -> None:
    tiles = []
    with tempfile.TemporaryDirectory() as folder:
        for name in SCENES:
            out = Path(folder) / name
            run_render_job(load_scene(HERE.parent / "scenes" / name), out, spectral_output=False)
            image = cv2.imread(str(out / "image.png"))
            cv2.putText(image, name, (8, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (255, 255, 255), 2, cv2.LINE_AA)
            tiles.append(image)
    gap_v = np.full((tiles[0].shape[0], 8, 3), 255, np.uint8)
    rows = [np.hstack([tiles[0], gap_v, tiles[1]]), np.hstack([tiles[2], gap_v, tiles[3]])]
    gap_h = np.full((8, rows[0].shape[1], 3), 255, np.uint8)
    cv2.imwrite(str(HERE / "world.png"), np.vstack([rows[0], gap_h, rows[1]]))
    print(f"wrote {HERE / 'world.png'}")


if __name__ == "__main__":
    main()
