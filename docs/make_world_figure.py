"""Render the world's scenes at their defaults — the crop field from a drone, plants to the
horizon, plants close up, the tabletop, the room, and the meadow under a partly cloudy sky —
through the whole chain (spectral render, sensor, DNG, ISP) and put them side by side as
docs/world.png (the README's picture of issues 24 and 37's content).

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
#: (scene file, overrides, label) of each tile, two to a row.
SCENES = (("field.toml", {}, "field.toml"), ("meadow.toml", {}, "meadow.toml"),
          ("vegetation.toml", {}, "vegetation.toml"), ("tabletop.toml", {}, "tabletop.toml"),
          ("room.toml", {}, "room.toml"),
          ("meadow.toml", {"sky.cloud_cover": 0.4, "scene.layout_seed": 5}, "meadow.toml, sky.cloud_cover = 0.4"))


def main() -> None:
    tiles = []
    with tempfile.TemporaryDirectory() as folder:
        for index, (name, overrides, label) in enumerate(SCENES):
            out = Path(folder) / str(index)
            run_render_job(load_scene(HERE.parent / "scenes" / name, overrides=overrides), out, spectral_output=False)
            image = cv2.imread(str(out / "image.png"))
            cv2.putText(image, label, (8, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (255, 255, 255), 2, cv2.LINE_AA)
            tiles.append(image)
    gap_v = np.full((tiles[0].shape[0], 8, 3), 255, np.uint8)
    rows = [np.hstack([tiles[k], gap_v, tiles[k + 1]]) for k in range(0, len(tiles), 2)]
    gap_h = np.full((8, rows[0].shape[1], 3), 255, np.uint8)
    stacked = [part for row in rows for part in (row, gap_h)][:-1]
    cv2.imwrite(str(HERE / "world.png"), np.vstack(stacked))
    print(f"wrote {HERE / 'world.png'}")


if __name__ == "__main__":
    main()
