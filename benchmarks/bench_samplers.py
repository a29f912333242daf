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
    python benchmarks/bench_samplers.py docs/bench --from-csv   # redraw the chart from samplers.csv

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
            "noise_p50": float(np.median(relative)), "noise_p90": float(np.percentile(relative, 90)),
            "seeds": seeds}


def chart(rows: list[dict], path: Path, *, seeds: int = 4) -> Path:
    """p90 relative noise against spp (left) and against seconds per render (right), log axes
    ticked at 1, 2 and 5 per decade (spp at the values measured) in plain numbers: a log axis
    spanning about a decade otherwise labels its minor ticks too, and they collide."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, LogLocator, NullFormatter

    from spectral_cam.viz import figure, save_png

    plain = FuncFormatter(lambda value, _: f"{value:g}")
    fig = figure(8, 3.5)
    left, right = fig.subplots(1, 2)
    for sampler in SAMPLERS:
        mine = [r for r in rows if r["sampler"] == sampler]
        left.loglog([r["spp"] for r in mine], [r["noise_p90"] for r in mine], "o-", label=sampler)
        right.loglog([r["seconds"] for r in mine], [r["noise_p90"] for r in mine], "o-", label=sampler)
    left.xaxis.set_major_locator(FixedLocator(sorted({r["spp"] for r in rows})))
    right.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    for ax in (left, right):
        ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_formatter(plain)
            axis.set_minor_formatter(NullFormatter())
        ax.grid(True, which="major", alpha=0.3)
    left.set_xlabel("spp"), left.set_ylabel("p90 relative noise (camera e⁻)"), left.legend(fontsize=8)
    right.set_xlabel("seconds per render (240 × 160)"), right.set_ylabel("p90 relative noise")
    seeds = rows[0].get("seeds", seeds)
    fig.suptitle(f"Mitsuba samplers on the bundled ColorChecker ({seeds} seeds each)", fontsize=10)
    return save_png(fig, path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("--spp", default="16,64,256")
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--from-csv", action="store_true", help="redraw the chart from OUT/samplers.csv")
    args = parser.parse_args()

    from spectral_cam.apps.bench.common import read_rows, write_rows

    out = Path(args.output)
    if args.from_csv:  # the committed CSV has no seeds column: --seeds says how many it used
        print(f"wrote {chart(read_rows(out / 'samplers.csv'), out / 'samplers.png', seeds=args.seeds)}")
        return
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for spp in (int(v) for v in args.spp.split(",")):
        for sampler in SAMPLERS:
            rows.append(measure(sampler, spp, args.seeds))
            print(rows[-1], file=sys.stderr)
    write_rows(rows, out / "samplers.csv")
    chart(rows, out / "samplers.png")


if __name__ == "__main__":
    main()
