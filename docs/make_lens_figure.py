"""What each lens model adds, through the whole chain (render, sensor, ISP), as docs/lenses.png:
(1) an N-BK7 singlet's longitudinal colour against an N-BK7 + F2 achromat on a slanted edge,
(2) round against six-bladed bokeh of defocused point sources, (3) a ColorChecker through a wide
lens with barrel distortion (k1 = -0.5), (4) the 50 mm double Gauss prescription against a
thin lens of its focal length and traced f-number on the depth-of-field targets, (5) a slanted
edge still and with the camera panning (motion blur).

    .venv/bin/python docs/make_lens_figure.py
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import cv2
import numpy as np

from spectral_cam import scene_from_dict
from spectral_cam.job import run_render_job

HERE = Path(__file__).parent
SENSOR = {"width_px": 240, "height_px": 160, "pixel_pitch_um": 6.0}

PANELS = [
    ("N-BK7 singlet f/2", {"scene": {"preset": "slanted_edge", "distance_m": 2.0},
                           "lens": {"model": "spectral_thin", "glass": "N-BK7", "focal_length_mm": 25.0,
                                    "f_number": 2.0, "focus_distance_m": 2.0}}),
    ("N-BK7+F2 achromat f/2", {"scene": {"preset": "slanted_edge", "distance_m": 2.0},
                               "lens": {"model": "spectral_thin", "glass": "N-BK7+F2", "focal_length_mm": 25.0,
                                        "f_number": 2.0, "focus_distance_m": 2.0}}),
    ("round aperture", {"scene": {"preset": "point_sources", "depths_m": [4.0, 6.0, 8.0], "source_radius_m": 0.006},
                        "lens": {"model": "spectral_thin", "glass": "ideal", "focal_length_mm": 25.0, "f_number": 1.4,
                                 "focus_distance_m": 1.5}}),
    ("6 blades", {"scene": {"preset": "point_sources", "depths_m": [4.0, 6.0, 8.0], "source_radius_m": 0.006},
                  "lens": {"model": "spectral_thin", "glass": "ideal", "focal_length_mm": 25.0, "f_number": 1.4,
                           "focus_distance_m": 1.5, "blades": 6}}),
    ("no distortion", {"scene": {"preset": "colorchecker", "distance_m": 1.0, "fill": 0.95},
                       "lens": {"model": "spectral_thin", "glass": "ideal", "focal_length_mm": 2.0, "f_number": 8.0,
                                "focus_distance_m": 1.0}}),
    ("barrel k1 = -0.5", {"scene": {"preset": "colorchecker", "distance_m": 1.0, "fill": 0.95},
                           "lens": {"model": "spectral_thin", "glass": "ideal", "focal_length_mm": 2.0,
                                    "f_number": 8.0, "focus_distance_m": 1.0,
                                    "distortion": [-0.5, 0.0, 0.0, 0.0, 0.0]}}),
    ("still, 1/250 s", {"scene": {"preset": "slanted_edge", "distance_m": 2.0},
                       "lens": {"model": "pinhole", "focal_length_mm": 25.0}, "exposure": {"time_s": 1 / 250}}),
    ("panning 3.3 m/s, 1/250 s", {"scene": {"preset": "slanted_edge", "distance_m": 2.0},
                                 "lens": {"model": "pinhole", "focal_length_mm": 25.0}, "exposure": {"time_s": 1 / 250},
                                 "motion": {"camera_velocity_mps": [3.3, 0.0, 0.0]}}),
    ("thin lens 50.4 mm f/2.02", {"scene": {"preset": "dof_targets", "depths_m": [1.5, 2.0, 3.0]},
                                  "lens": {"model": "thin", "focal_length_mm": 50.358, "f_number": 2.018,
                                           "focus_distance_m": 2.0}}),
    ("double Gauss prescription", {"scene": {"preset": "dof_targets", "depths_m": [1.5, 2.0, 3.0]},
                                   "lens": {"model": "prescription", "prescription": "dgauss_50mm",
                                            "focus_distance_m": 2.0}}),
]


def main() -> None:
    tiles = []
    with tempfile.TemporaryDirectory() as folder:
        for index, (title, table) in enumerate(PANELS):
            spp = 1024 if table["scene"]["preset"] == "point_sources" else 128  # small sources: few hits
            # bokeh is shot metering the highlights (an average meter on a black frame blows the discs out)
            exposure = {"metering": "highlight"} if table["scene"]["preset"] == "point_sources" else {}
            config = scene_from_dict({**table, "sensor": SENSOR, "render": {"spp": spp}, "exposure": exposure})
            out = Path(folder) / f"panel{index}"
            run_render_job(config, out, spectral_output=False)
            image = cv2.imread(str(out / "image.png"))
            (text_w, text_h), _ = cv2.getTextSize(title, cv2.FONT_HERSHEY_SIMPLEX, 0.45, 1)
            cv2.rectangle(image, (2, 2), (10 + text_w, 10 + text_h), (255, 255, 255), -1)
            cv2.putText(image, title, (6, 6 + text_h), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
            tiles.append(image)
    gap_v = np.full((tiles[0].shape[0], 6, 3), 255, np.uint8)
    rows = [np.hstack([tiles[i], gap_v, tiles[i + 1]]) for i in range(0, len(tiles), 2)]
    gap_h = np.full((6, rows[0].shape[1], 3), 255, np.uint8)
    sheet = rows[0]
    for row in rows[1:]:
        sheet = np.vstack([sheet, gap_h, row])
    cv2.imwrite(str(HERE / "lenses.png"), sheet)
    print(f"wrote {HERE / 'lenses.png'}")


if __name__ == "__main__":
    main()
