"""Cost against accuracy of the lens models (issue 16 #6): the ideal thin lens (Mitsuba's own
``thinlens``, the baseline), our spectral thin lens (ideal glass, and an N-BK7 singlet) and the
double-Gauss prescription, on the depth-of-field targets (planes at 1.5, 2 and 3 m, focus 2 m,
50.36 mm f/2.02, the prescription's focal length and traced f-number) at growing frame sizes.

Cost: seconds of the radiance render per megapixel at 64 spp (median of 3, interleaved, after a
warm-up), and its ratio to the thin lens at the same size in the same run. Accuracy: the relative
mean absolute difference of each model's noise-free camera luminance from the prescription's,
rendered at 1024 spp (the reference: real surfaces), next to each model's own Monte-Carlo noise
at 64 spp (the difference of two seeds, /√2) — the thin lens's difference beyond its noise is what
it does not model (aberrations, the prescription's vignetting and focus).

Writes ``OUT/lenses.csv`` and ``OUT/lenses.png``.

Usage::

    python benchmarks/bench_lenses.py docs/bench [--sizes 240x160,480x320,960x640]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

MODELS = {"thin (Mitsuba thinlens)": {"model": "thin", "focal_length_mm": 50.358, "f_number": 2.018},
          "spectral_thin, ideal glass": {"model": "spectral_thin", "glass": "ideal", "focal_length_mm": 50.358,
                                         "f_number": 2.018},
          "spectral_thin, N-BK7 singlet": {"model": "spectral_thin", "glass": "N-BK7", "focal_length_mm": 50.358,
                                           "f_number": 2.018},
          "prescription dgauss_50mm": {"model": "prescription", "prescription": "dgauss_50mm"}}
SPP, REFERENCE_SPP = 64, 1024


def scene(lens: dict, width: int, height: int, spp: int, seed: int = 0):
    from spectral_cam import scene_from_dict

    return scene_from_dict({"scene": {"preset": "dof_targets", "depths_m": [1.5, 2.0, 3.0]},
                            "lens": {"focus_distance_m": 2.0, **lens},
                            "sensor": {"width_px": width, "height_px": height, "pixel_pitch_um": 6.0},
                            "render": {"spp": spp, "seed": seed, "bands": "camera", "spectral_output": False,
                                       "diffraction": "off"}})


def luminance(config) -> tuple[np.ndarray, float]:
    from spectral_cam import render
    from spectral_cam.apps.dataset.labels import clean_camera_rgb

    image = render(config, with_depth=False)
    seconds = image.meta["timings_s"]["radiance"]  # the render stage alone (the models differ there only)
    return clean_camera_rgb(image, config, exposure_s=0.01).sum(axis=-1).astype(np.float64), seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("--sizes", default="240x160,480x320,960x640")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    from spectral_cam.apps.bench.common import write_rows
    from spectral_cam.viz import figure, save_png

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    sizes = [tuple(int(v) for v in size.split("x")) for size in args.sizes.split(",")]
    rows = []
    for width, height in sizes:
        megapixels = width * height / 1e6
        reference, _ = luminance(scene(MODELS["prescription dgauss_50mm"], width, height, REFERENCE_SPP, seed=99))
        for lens in MODELS.values():  # warm-up: JIT kernels of every model at this size
            luminance(scene(lens, width, height, 4))
        seconds = {name: [] for name in MODELS}
        images = {}
        for repeat in range(args.repeats):
            order = list(MODELS.items())[repeat % len(MODELS):] + list(MODELS.items())[:repeat % len(MODELS)]
            for name, lens in order:
                image, took = luminance(scene(lens, width, height, SPP, seed=repeat))
                seconds[name].append(took)
                images.setdefault(name, []).append(image)
        baseline = float(np.median(seconds["thin (Mitsuba thinlens)"]))
        scale = float(reference.mean())
        for name in MODELS:
            first, second = images[name][0], images[name][1]
            rows.append({"model": name, "width_px": width, "height_px": height, "megapixels": megapixels,
                         "spp": SPP, "seconds": float(np.median(seconds[name])),
                         "seconds_per_mp": float(np.median(seconds[name])) / megapixels,
                         "ratio_to_thin": float(np.median(seconds[name])) / baseline,
                         "difference_from_prescription": float(np.mean(np.abs(first - reference)) / scale),
                         "own_noise": float(np.mean(np.abs(first - second)) / scale / np.sqrt(2))})
            print(rows[-1], file=sys.stderr)
    write_rows(rows, out / "lenses.csv")
    fig = figure(10, 3.8)
    left, right = fig.subplots(1, 2)
    for name in MODELS:
        mine = [r for r in rows if r["model"] == name]
        left.plot([r["megapixels"] for r in mine], [r["ratio_to_thin"] for r in mine], "o-", label=name)
        right.loglog([r["seconds_per_mp"] for r in mine], [r["difference_from_prescription"] for r in mine], "o-",
                     label=name)
        right.loglog([r["seconds_per_mp"] for r in mine], [r["own_noise"] for r in mine], ":", color="gray")
    left.axhline(1.0, color="k", lw=0.6)
    left.set_xlabel("frame (MP)"), left.set_ylabel("render time / thin lens (same run)"), left.legend(fontsize=7)
    right.set_xlabel("seconds per MP (64 spp)"), right.set_ylabel("mean |Δ| / mean vs prescription (1024 spp)")
    right.set_title("dotted: each model's own noise at 64 spp", fontsize=8)
    fig.suptitle("Lens models on the depth-of-field targets, 50.4 mm f/2.02 focused at 2 m", fontsize=10)
    save_png(fig, out / "lenses.png")


if __name__ == "__main__":
    main()
