"""Fireflies (issue 23 #3): what each way of turning passes into a pixel costs and how far it
lands from a converged reference.

Scenes: the bundled glass and copper spheres under a small lamp (``scenes/glass_sphere.toml``:
caustics) and the tabletop under the sun (``scenes/tabletop.toml``: glass, metal, plastic), at
480 × 320 px (their defaults), camera film (6 channels). Each estimator sees the same 8 passes of 8 spp (64 spp,
the default): the plain mean (unbiased), the median of the 8 pass means (MoN, Buisine et al.
2021's estimator without adaptation), the adaptive rule at Gini thresholds 0.25, 0.4 and 0.6,
and the renderer's default: the adaptive rule at 0.4 with the light it removed given back,
spread (:func:`spectral_cam.render.robust.spread_removed_light`, after Zirr et al. 2018). The
reference is the mean of 1024 spp (16× the samples, its own seed).

Per estimator: the firefly share (:func:`spectral_cam.metrics.realism.firefly_share` on the
luminance), the bias of the frame's mean luminance against the reference (light lost), the
mean |Δ| over 4 × 4 blocks against the reference (noise + bias), and the share of pixels that
took the median. Cost: the render time with ``render.estimator = "amon"`` against ``"mean"`` at
64 spp (median of 3, interleaved, after a warm-up).

Writes ``OUT/fireflies.csv`` and ``OUT/fireflies.png``; ``--readme README.md`` rewrites its paragraph.

Usage::

    python benchmarks/bench_fireflies.py docs/bench [--size 480x320]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

SCENES = {"glass_sphere": "scenes/glass_sphere.toml", "tabletop": "scenes/tabletop.toml"}
PASSES, PASS_SPP, REFERENCE_SPP = 8, 8, 1024
RULES = {"mean": np.inf, "MoN (median of 8 means)": 0.0, "adaptive, G > 0.25": 0.25,
         "adaptive, G > 0.4": 0.4, "adaptive, G > 0.6": 0.6, "adaptive, G > 0.4, spread (default)": 0.4}
#: The rules whose removed light is given back (spread_removed_light).
SPREAD = {"adaptive, G > 0.4, spread (default)"}


def config(path: str, width: int, height: int, spp: int, seed: int, estimator: str = "mean"):
    from spectral_cam import load_scene

    return load_scene(path, overrides={"sensor.width_px": width, "sensor.height_px": height, "render.spp": spp,
                                       "render.seed": seed, "render.estimator": estimator, "render.bands": "camera",
                                       "render.spectral_output": False, "render.diffraction": "off"})


def radiance(cfg) -> tuple[np.ndarray, float]:
    from spectral_cam import render

    started = time.perf_counter()
    image = render(cfg, with_depth=False)
    return np.asarray(image.data, np.float32), time.perf_counter() - started


def blocks(image: np.ndarray, side: int = 4) -> np.ndarray:
    h, w = (image.shape[0] // side) * side, (image.shape[1] // side) * side
    return image[:h, :w].reshape(h // side, side, w // side, side).mean(axis=(1, 3))


BEGIN, END = "<!-- fireflies:begin -->", "<!-- fireflies:end -->"


def readme_block(rows: list[dict]) -> str:
    """The README's paragraph on fireflies, from the CSV rows."""
    from spectral_cam.render.robust import SPREAD_PEAK

    def row(scene, estimator):
        return next(r for r in rows if r["scene"] == scene and r["estimator"].startswith(estimator))

    def pct(value, digits=2):
        return f"{100 * float(value):.{digits}f} %"

    glass_mean, glass_amon = row("glass_sphere", "mean"), row("glass_sphere", "adaptive, G > 0.4, spread")
    glass_mon, table_amon = row("glass_sphere", "MoN"), row("tabletop", "adaptive, G > 0.4, spread")
    glass_median = next(r for r in rows if r["scene"] == "glass_sphere" and r["estimator"] == "adaptive, G > 0.4")
    return (
        f"{BEGIN}\n"
        "`python benchmarks/bench_fireflies.py docs/bench` ([CSV](docs/bench/fireflies.csv),\n"
        "[chart](docs/bench/fireflies.png)) renders each scene at its defaults (480 × 320, 64 spp) as 8 passes\n"
        "and a 1024-spp reference: on `scenes/glass_sphere.toml` the mean leaves "
        f"{pct(glass_mean['firefly_share'], 3)} fireflies, the adaptive\n"
        f"median {pct(glass_amon['firefly_share'], 3)} (it changed {pct(glass_amon['median_share'])} of the pixels). "
        "Caustic light under the glass sphere is real and rare:\n"
        f"the median alone loses {pct(-float(glass_median['bias_of_mean']))} of the frame's mean luminance "
        f"(the plain median of means {pct(-float(glass_mon['bias_of_mean']))}),\n"
        "so the renderer gives the removed light back, spread until it adds at most "
        f"{SPREAD_PEAK:g}× the light around it: bias {pct(glass_amon['bias_of_mean'])}\n"
        f"(the mean's {pct(glass_mean['bias_of_mean'])}), the caustic's field a glow. Its 4 × 4-block error "
        f"against the reference is {pct(glass_amon['block_error'])}\n"
        f"(median alone {pct(glass_median['block_error'])}, mean {pct(glass_mean['block_error'])}).\n"
        f"On the tabletop it changes {pct(table_amon['median_share'], 3)} of the pixels (bias "
        f"{pct(table_amon['bias_of_mean'], 3)}). It costs ×{float(glass_amon['amon_time_ratio']):.2f} and "
        f"×{float(table_amon['amon_time_ratio']):.2f}\n"
        "the mean's render time (8 Mitsuba calls instead of one).\n"
        f"{END}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("--size", default="480x320")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--readme", help="rewrite the fireflies paragraph in this README")
    args = parser.parse_args()

    from spectral_cam.apps.bench.common import write_rows
    from spectral_cam.metrics.realism import firefly_share
    from spectral_cam.render.robust import adaptive_median_of_means, spread_removed_light
    from spectral_cam.viz import figure, save_png

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    width, height = (int(v) for v in args.size.split("x"))
    rows = []
    for name, path in SCENES.items():
        reference, _ = radiance(config(path, width, height, REFERENCE_SPP, seed=99))
        ref_lum = reference[..., 4]  # the camera film's Y channel
        passes = np.stack([radiance(config(path, width, height, PASS_SPP, seed=1000 + k))[0] for k in range(PASSES)])
        for label, threshold in RULES.items():
            if np.isinf(threshold):
                estimate, share = passes.mean(axis=0), 0.0
            else:
                estimate, share = adaptive_median_of_means(passes, threshold=threshold)
                if label in SPREAD:
                    estimate = spread_removed_light(passes.mean(axis=0), estimate)
            lum = estimate[..., 4]
            rows.append({"scene": name, "estimator": label, "gini_threshold": threshold, "spp": PASSES * PASS_SPP,
                         "firefly_share": firefly_share(lum), "median_share": share,
                         "bias_of_mean": float(lum.mean() / ref_lum.mean() - 1.0),
                         "block_error": float(np.mean(np.abs(blocks(lum) - blocks(ref_lum))) / ref_lum.mean()),
                         "reference_firefly_share": firefly_share(ref_lum)})
            print(rows[-1], file=sys.stderr)
        radiance(config(path, width, height, 8, seed=0, estimator="amon"))  # warm-up
        seconds = {"mean": [], "amon": []}
        for repeat in range(args.repeats):
            for estimator in (("mean", "amon") if repeat % 2 == 0 else ("amon", "mean")):
                seconds[estimator].append(radiance(config(path, width, height, 64, repeat, estimator))[1])
        ratio = float(np.median(seconds["amon"]) / np.median(seconds["mean"]))
        for row in rows:
            if row["scene"] == name:
                row["render_s_mean"] = float(np.median(seconds["mean"]))
                row["render_s_amon"] = float(np.median(seconds["amon"]))
                row["amon_time_ratio"] = ratio
    write_rows(rows, out / "fireflies.csv")
    if args.readme:
        import csv

        from spectral_cam.records import replace_block

        with open(out / "fireflies.csv", newline="") as handle:
            replace_block(args.readme, BEGIN, END, readme_block(list(csv.DictReader(handle))))

    fig = figure(10, 3.8)
    left, right = fig.subplots(1, 2)
    for name in SCENES:
        mine = [r for r in rows if r["scene"] == name]
        marker = "o" if name == "glass_sphere" else "s"
        for r in mine:
            left.scatter(100 * abs(r["bias_of_mean"]) + 1e-3, 100 * r["firefly_share"] + 1e-4, marker=marker)
            left.annotate(r["estimator"].split(" (")[0], (100 * abs(r["bias_of_mean"]) + 1e-3,
                                                         100 * r["firefly_share"] + 1e-4), fontsize=6)
        ordered = sorted((r for r in mine if r["estimator"] not in SPREAD), key=lambda r: min(r["gini_threshold"], 1.0))
        for r in mine:
            if r["estimator"] in SPREAD:
                right.plot([r["gini_threshold"]], [100 * r["block_error"]], marker, color="k", mfc="none", ms=9)
        right.plot([min(r["gini_threshold"], 1.0) for r in ordered], [100 * r["block_error"] for r in ordered],
                   marker + "-", label=f"{name} (amon ×{mine[0]['amon_time_ratio']:.2f} the mean's time)")
    left.set_xscale("log"), left.set_yscale("log")
    left.set_xlabel("|bias| of the frame's mean vs 1024 spp (%)"), left.set_ylabel("firefly share (%)")
    left.set_title("○ glass_sphere  □ tabletop, 64 spp", fontsize=8)
    right.set_xlabel("Gini threshold (0 = MoN everywhere, 1 = the mean)")
    right.set_ylabel("mean |Δ| of 4×4 blocks vs 1024 spp (%)"), right.legend(fontsize=7)
    fig.suptitle("Firefly removal: adaptive median of 8 pass means against the mean "
                 "(open black: with the removed light spread, the default)", fontsize=10)
    save_png(fig, out / "fireflies.png")


if __name__ == "__main__":
    main()
