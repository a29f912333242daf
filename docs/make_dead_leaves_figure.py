"""Render the bundled dead-leaves scene at three apertures (f/1.4, f/4, f/16, thin lens focused at
2 m on discs between 1 and 4 m) and put the developed images side by side as
docs/dead_leaves_dof.png, the README's depth-of-field sweep.

    .venv/bin/python docs/make_dead_leaves_figure.py
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import cv2
import numpy as np

from spectral_cam import load_scene
from spectral_cam.job import run_render_job

HERE = Path(__file__).parent
F_NUMBERS = (1.4, 4.0, 16.0)


def main() -> None:
    tiles = []
    with tempfile.TemporaryDirectory() as folder:
        for f_number in F_NUMBERS:
            out = Path(folder) / f"f{f_number:g}"
            config = load_scene(HERE.parent / "scenes" / "dead_leaves.toml", overrides={"lens.f_number": f_number})
            run_render_job(config, out, spectral_output=False)
            image = cv2.imread(str(out / "image.png"))
            cv2.putText(image, f"f/{f_number:g}", (10, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.9, (255, 255, 255), 4)
            cv2.putText(image, f"f/{f_number:g}", (10, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.9, (0, 0, 0), 2)
            tiles.append(image)
    gap = np.full((tiles[0].shape[0], 8, 3), 255, np.uint8)
    row = [tiles[0]]
    for tile in tiles[1:]:
        row += [gap, tile]
    cv2.imwrite(str(HERE / "dead_leaves_dof.png"), np.hstack(row))
    print(f"wrote {HERE / 'dead_leaves_dof.png'}")


if __name__ == "__main__":
    main()
