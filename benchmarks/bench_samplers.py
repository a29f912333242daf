"""Mitsuba's samplers on the bundled ColorChecker: Monte-Carlo noise and time at equal spp, to
choose ``render.sampler`` by the data (issue 14 #5).

For each sampler and spp, the scene is rendered with four seeds; the noise is the spread of the
four renders in noise-free photo-electron rates through the camera's CFA (what the sensor
sees), relative to their mean, over the pixels brighter than 10 % of the maximum (the pixels
``spp = "auto"`` judges). Randomised quasi-Monte-Carlo samplers (stratified, multijitter,
ldsampler) give independent estimates per seed, so the spread is their error as for
independent sampling. Orthogonal arrays are left out: Mitsuba rounds their sample count to a
prime square (64 → 121), so a pass could not hold the samples asked for.

Writes ``OUT/samplers.csv`` and ``OUT/samplers.png`` (p90 relative noise vs spp, and vs time).

Usage::

    python benchmarks/bench_samplers.py docs/bench [--spp 16,64,256] [--seeds 4]

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3 plugin docs: ``independent``, ``stratified``,
   ``multijitter`` (Kensler 2013), ``ldsampler`` (Sobol, Owen scrambling).
.. [2] Kensler, A. (2013). Correlated multi-jittered sampling. Pixar Technical Memo 13-01.
.. [3] Owen, A. B. (1997). Monte Carlo variance of scrambled net quadrature. SIAM J. Numer. Anal. 34(5).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "colorchecker.toml"
SAMPLERS = ("independent", "stratified", "multijitter", "ldsampler")


def measure(sampler: str, spp: int, seeds: int) -> dict:
    import spectral_cam as sc
    from spectral_cam.sensor import expected_electrons

    base = sc.load_scene(SCENE, overrides={"render.spp": spp, "render.sampler": sampler,
                                           "sensor.width_px": 240, "sensor.height_px": 160})
    rates, seconds = [], []
    for seed in range(seeds):
        started = time.perf_counter()
        image = sc.render(base.replace(**{"render.seed": seed}), with_depth=False)
        seconds.append(time.perf_counter() - started)
        rate, _ = expected_electrons(image, base, exposure_s=1.0)
        rates.append(rate.astype(np.float64))
    rates = np.array(rates)
    mean, spread = rates.mean(axis=0), rates.std(axis=0, ddof=1)
    bright = mean > 0.1 * mean.max()
    relative = spread[bright] / mean[bright]
    return {"sampler": sampler, "spp": spp, "seconds": float(np.median(seconds[1:] or seconds)),
            "noise_p50": float(np.median(relative)), "noise_p90": float(np.percentile(relative, 90))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("--spp", default="16,64,256")
    parser.add_argument("--seeds", type=int, default=4)
    args = parser.parse_args()

    from spectral_cam.apps.bench.common import write_rows
    from spectral_cam.viz import figure, save_png

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for spp in (int(v) for v in args.spp.split(",")):
        for sampler in SAMPLERS:
            rows.append(measure(sampler, spp, args.seeds))
            print(rows[-1], file=sys.stderr)
    write_rows(rows, out / "samplers.csv")
    fig = figure(8, 3.5)
    left, right = fig.subplots(1, 2)
    for sampler in SAMPLERS:
        mine = [r for r in rows if r["sampler"] == sampler]
        left.loglog([r["spp"] for r in mine], [r["noise_p90"] for r in mine], "o-", label=sampler)
        right.loglog([r["seconds"] for r in mine], [r["noise_p90"] for r in mine], "o-", label=sampler)
    left.set_xlabel("spp"), left.set_ylabel("p90 relative noise (camera e⁻)"), left.legend(fontsize=8)
    right.set_xlabel("seconds per render (240 × 160)"), right.set_ylabel("p90 relative noise")
    fig.suptitle("Mitsuba samplers on the bundled ColorChecker (4 seeds each)", fontsize=10)
    save_png(fig, out / "samplers.png")


if __name__ == "__main__":
    main()
