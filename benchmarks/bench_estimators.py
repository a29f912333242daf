"""Error against samples per pixel for each way of turning passes into a pixel (issue 39 #15):
the plain mean, and the adaptive median of means (``render.estimator = "amon"``, Buisine et al.
2021) with the pass count K the renderer picks for that spp, and what ``auto`` chooses.

Scenes: the tabletop under the sun (glass, metal, rough plastic in saturated CIE 2017 colours)
and the glass and copper spheres under a small lamp (caustics), both of which ``auto`` treats
as able to make fireflies. Each estimator renders the scene at spp ∈ {16, 32, 64, 128} with
``TRIALS`` seeds; the reference is the mean of ``REFERENCE_SPP`` spp with its own seed.

Error: the root-mean-square difference of each pixel's luminance (the camera film's Y) from
the reference, over the reference's mean luminance (noise and bias together; a firefly weighs
heavily), with the ideal 1/√spp slope through the mean's first point, leaving out the pixels
where the reference holds a firefly of its own (:func:`reference_outliers`; else they floor every
curve alike); and the firefly share (:func:`spectral_cam.metrics.realism.firefly_share`). The reference's own noise adds
(16/REFERENCE_SPP)^½ ≈ 9 % in quadrature at 16 spp and less above, the same to every estimator.

Writes ``OUT/estimators.csv`` and ``OUT/estimators.png``.

Usage::

    python benchmarks/bench_estimators.py docs/bench [--size 192x128] [--trials 2]

References
----------
.. [1] Buisine, J., Delepoulle, S., & Renaud, C. (2021). Firefly removal in Monte Carlo
   rendering with adaptive Median of meaNs. EGSR 2021, 121–132.
.. [2] Pharr, Jakob & Humphreys (2023). Physically Based Rendering, 4th ed., §2.1 (Monte-Carlo
   error falls as 1/√spp).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

SCENES = {"tabletop": "scenes/tabletop.toml", "glass_sphere": "scenes/glass_sphere.toml"}
SPPS = (16, 32, 64, 128)
REFERENCE_SPP = 2048
Y = 4  # the camera film's channels: R, G, B of the camera, then X, Y, Z


def config(path: str, width: int, height: int, spp: int, seed: int, estimator: str):
    from spectral_cam import load_scene

    return load_scene(path, overrides={"sensor.width_px": width, "sensor.height_px": height, "render.spp": spp,
                                       "render.seed": seed, "render.estimator": estimator, "render.bands": "camera",
                                       "render.spectral_output": False, "render.diffraction": "off"})


def luminance(cfg) -> tuple[np.ndarray, dict]:
    from spectral_cam import render

    image = render(cfg, with_depth=False)
    return np.asarray(image.data, np.float64)[..., Y], image.meta["model_decisions"]["estimator"]


def reference_outliers(reference: np.ndarray) -> np.ndarray:
    """Pixels of the reference that hold a firefly of its own (above 4× their 5 × 5 median and
    above the frame's median, as :func:`spectral_cam.metrics.realism.firefly_share` counts them) and
    their 8 neighbours: left out of the RMS error, whose floor they would otherwise set for every
    estimator alike (the glass sphere's caustics at 2048 spp)."""
    import cv2

    lum = np.ascontiguousarray(reference, dtype=np.float32)
    spikes = (lum > 4 * cv2.medianBlur(lum, 5)) & (lum > np.median(lum))
    return cv2.dilate(spikes.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)


def measure(name: str, path: str, width: int, height: int, trials: int) -> list[dict]:
    """One row per (estimator, spp): relative RMS error, firefly share and passes, mean over
    trials; ``auto``'s row is the row of what it chooses (the same render)."""
    from spectral_cam.metrics.realism import firefly_share
    from spectral_cam.render.decisions import decide_estimator

    reference, _ = luminance(config(path, width, height, REFERENCE_SPP, 99991, "mean"))
    scale = float(reference.mean())
    kept = ~reference_outliers(reference)
    rows = []
    for spp in SPPS:
        measured = {}
        for estimator in ("mean", "amon"):
            errors, fireflies, record = [], [], {}
            for trial in range(trials):
                lum, record = luminance(config(path, width, height, spp, 1000 * trial + spp, estimator))
                errors.append(float(np.sqrt(np.mean((lum - reference)[kept] ** 2))) / scale)
                fireflies.append(firefly_share(lum))
            measured[estimator] = {"scene": name, "estimator": estimator, "spp": spp,
                                   "passes": record.get("passes", 1), "chosen": record["choice"],
                                   "rel_rmse": float(np.mean(errors)), "rel_rmse_spread": float(np.std(errors)),
                                   "firefly_share": float(np.mean(fireflies)),
                                   "reference_firefly_share": firefly_share(reference),
                                   "reference_pixels_left_out": float(1.0 - kept.mean()), "trials": trials,
                                   "width": width, "height": height, "reference_spp": REFERENCE_SPP}
        _, record = decide_estimator(config(path, width, height, spp, 0, "auto"), spp)
        measured["auto"] = {**measured[record["choice"]], "estimator": "auto"}
        rows += list(measured.values())
        print(*rows[-3:], sep="\n", file=sys.stderr)
    return rows


def chart(rows: list[dict], out: Path) -> None:
    """Top: RMS error against spp; bottom: the firefly share; one column per scene."""
    from matplotlib.ticker import FormatStrFormatter

    from spectral_cam.viz import figure, save_png

    fig = figure(10, 7.2)
    axes = fig.subplots(2, len(SCENES), sharex=True)
    styles = {"mean": dict(marker="o", linestyle="-", color="tab:blue", label="mean of all samples"),
              "amon": dict(marker="s", linestyle="--", color="tab:red", label="adaptive median of K pass means"),
              "auto": dict(marker="x", linestyle=":", color="black", markersize=10, linewidth=2,
                           label="auto (what render.estimator = auto picks)")}
    spps = np.array(SPPS, float)
    for column, name in enumerate(SCENES):
        mine = [r for r in rows if r["scene"] == name]
        top, bottom = axes[0, column], axes[1, column]
        for estimator, style in styles.items():
            line = [r for r in mine if r["estimator"] == estimator]
            top.plot([r["spp"] for r in line], [100 * r["rel_rmse"] for r in line], **style)
            bottom.plot([r["spp"] for r in line], [100 * r["firefly_share"] for r in line], **style)
            if estimator == "amon":
                for r in line:
                    top.annotate(f"K={r['passes']}×{r['spp'] // r['passes']}", (r["spp"], 100 * r["rel_rmse"]),
                                 textcoords="offset points", xytext=(4, 5), fontsize=7, color="tab:red")
        first = next(r for r in mine if r["estimator"] == "mean")
        top.plot(spps, 100 * first["rel_rmse"] * np.sqrt(spps[0] / spps), color="grey", linewidth=0.8,
                 label="1/√spp through the mean's first point")
        bottom.axhline(100 * first["reference_firefly_share"], color="grey", linewidth=0.8,
                       label=f"the {first['reference_spp']}-spp reference's own")
        top.set_yscale("log")
        top.yaxis.set_major_formatter(FormatStrFormatter("%g"))
        top.yaxis.set_minor_formatter(FormatStrFormatter("%g"))
        top.tick_params(axis="y", which="minor", labelsize=7)
        top.set_ylabel(f"RMS error of luminance vs {first['reference_spp']} spp\n(% of the mean; "
                       f"{100 * first['reference_pixels_left_out']:.2g} % of pixels left out)")
        bottom.set_ylabel("firefly share (% of pixels)")
        bottom.set_xscale("log", base=2)
        bottom.set_xticks(list(SPPS), [str(s) for s in SPPS])
        bottom.set_xlabel("samples per pixel")
        top.set_title(f"{name} ({first['width']}×{first['height']}, mean of {first['trials']} seeds)", fontsize=9)
        for ax in (top, bottom):
            ax.grid(True, which="both", alpha=0.3)
        top.legend(fontsize=7), bottom.legend(fontsize=7)
    fig.suptitle("The mean against the adaptive median of K pass means (K×spp per pass marked)", fontsize=10)
    save_png(fig, out / "estimators.png")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("--size", default="192x128")
    parser.add_argument("--trials", type=int, default=2)
    parser.add_argument("--chart-only", action="store_true", help="redraw the chart from OUT/estimators.csv")
    args = parser.parse_args()

    from spectral_cam.apps.bench.common import read_rows, write_rows

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    if args.chart_only:
        chart(read_rows(out / "estimators.csv"), out)
        return
    width, height = (int(v) for v in args.size.split("x"))
    rows = [row for name, path in SCENES.items() for row in measure(name, path, width, height, args.trials)]
    write_rows(rows, out / "estimators.csv")
    chart(rows, out)


if __name__ == "__main__":
    main()
