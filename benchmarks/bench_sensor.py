"""Sensor simulation speed: a 12 MP frame from 31 bands against the memory-bandwidth floor.

The floor is one NumPy pass over the same in-memory radiance cube (``cube.sum()``), timed
in the same run, alternating with the sensor so both see the same machine state. The
sensor must read the cube once (the band integration) and then run the per-pixel noise
chain; the target is within 5× of the floor with the fixed patterns cached (the first,
"cold" frame also draws the sensor's PRNU/DSNU patterns and is reported separately).

Usage::

    python benchmarks/bench_sensor.py OUTDIR [--repeats 5] [--width 4000 --height 3000]

Writes ``OUTDIR/bench_sensor.csv`` (one row per timed run) and ``OUTDIR/bench_sensor.png``
(per-stage times of the median warm frame against the floor), and prints a summary.

References
----------
.. [1] McCalpin, J. D. (1995). Memory bandwidth and machine balance in current high
   performance computers. IEEE TCCA Newsletter (the bandwidth floor of a streaming pass).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np


def build_cube(width: int, height: int, seed: int = 0):
    """A 31-band radiance cube: D65-lit ColorChecker-like spectra, randomly placed, with a
    smooth illumination gradient (float32, W·m⁻²·sr⁻¹ per band)."""
    from spectral_cam.radiance_targets import lambertian_radiance, reflectance_set
    from spectral_cam.image import SpectralImage
    from spectral_cam.spectra import parse_bands

    bands = parse_bands("400:700:10")
    palette = lambertian_radiance("D65", reflectance_set("colorchecker").sds, illuminance_lux=1000.0,
                                  bands=bands).astype(np.float32)  # (24, 31)
    rng = np.random.default_rng(seed)
    block = 16
    labels = rng.integers(0, len(palette), size=(height // block + 1, width // block + 1))
    labels = np.repeat(np.repeat(labels, block, axis=0), block, axis=1)[:height, :width]
    cube = palette[labels]  # (H, W, 31) float32, C-contiguous
    shade = np.linspace(0.6, 1.0, width, dtype=np.float32)[None, :, None]
    cube *= shade
    return SpectralImage(cube, np.asarray(bands.centres_nm), np.asarray(bands.edges_nm))


def time_floor(cube: np.ndarray) -> float:
    """Seconds of one NumPy pass over the cube (the memory-bandwidth floor)."""
    from spectral_cam.apps.bench.common import timed

    return timed(cube.sum)[1]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("outdir", type=Path)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--width", type=int, default=4000)
    parser.add_argument("--height", type=int, default=3000)
    args = parser.parse_args(argv)

    from spectral_cam import sensor as S
    from spectral_cam import viz
    from spectral_cam.apps.bench.common import write_rows
    from spectral_cam.scene import scene_from_dict

    radiance = build_cube(args.width, args.height)
    cube = radiance.data
    config = scene_from_dict({"sensor": {"width_px": args.width, "height_px": args.height, "pixel_pitch_um": 3.76,
                                         "cfa": "RGGB", "model": "nikon_d850"},
                              "exposure": {"time_s": "auto"}})
    rows = []
    floor_times = [time_floor(cube) for _ in range(2)]  # warm the pages

    t0 = time.perf_counter()
    cold = S.expose(radiance, config, frame_seed=0)
    rows.append({"variant": "cold (patterns drawn)", "workers": "auto", "method": "hybrid", "run": 0,
                 "seconds": time.perf_counter() - t0, "floor_s": float("nan")})

    variants = [("warm", None, "hybrid"), ("warm, 1 thread", 1, "hybrid"), ("warm, exact Poisson", None, "poisson")]
    stage_samples: dict[str, list[dict]] = {name: [] for name, _, _ in variants}
    for run in range(args.repeats):
        for name, workers, method in variants:
            floor = time_floor(cube)
            floor_times.append(floor)
            t0 = time.perf_counter()
            raw = S.expose(radiance, config, frame_seed=run + 1, workers=workers, shot_noise_method=method)
            seconds = time.perf_counter() - t0
            rows.append({"variant": name, "workers": workers or "auto", "method": method, "run": run + 1,
                         "seconds": seconds, "floor_s": floor})
            stage_samples[name].append({**raw.meta["timings_s"], "seconds": seconds, "floor": floor})

    floor_median = statistics.median(floor_times)
    summary = []
    for name, _, _ in variants:
        runs = [r for r in rows if r["variant"] == name]
        median = statistics.median(r["seconds"] for r in runs)
        paired = statistics.median(r["seconds"] / r["floor_s"] for r in runs)
        summary.append((name, median, median / floor_median, paired))
    for row in rows:
        row["ratio_to_floor"] = row["seconds"] / row["floor_s"] if row["floor_s"] == row["floor_s"] else ""

    args.outdir.mkdir(parents=True, exist_ok=True)
    write_rows(rows, args.outdir / "bench_sensor.csv")

    figure = viz.figure(9, 4.5)
    ax = figure.subplots()
    stages = ["electron_rates", "auto_exposure", "noise_chain", "colour", "setup"]
    names = [name for name, _, _ in variants]
    bottoms = np.zeros(len(names))
    for stage in stages:
        values = np.array([statistics.median(s[stage] for s in stage_samples[name]) for name in names])
        ax.bar(names, values, bottom=bottoms, label=stage)
        bottoms += values
    ax.axhline(floor_median, color="k", lw=1, label=f"cube.sum() floor {floor_median * 1e3:.0f} ms")
    ax.axhline(5 * floor_median, color="k", lw=1, ls="--", label="5× floor (target)")
    ax.set_ylabel("seconds per frame (median)")
    ax.set_title(f"Sensor simulation, {args.width}×{args.height} px × 31 bands "
                 f"({cube.nbytes / 2 ** 30:.2f} GiB cube), {os.cpu_count()} CPUs")
    ax.legend(fontsize=8)
    viz.save_png(figure, args.outdir / "bench_sensor.png", dpi=110)

    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, python {sys.version.split()[0]}")
    print(f"cube {args.width}x{args.height}x31 float32 = {cube.nbytes / 2 ** 30:.2f} GiB; "
          f"cube.sum() floor: median {floor_median * 1e3:.1f} ms (min {min(floor_times) * 1e3:.1f} ms)")
    print(f"cold first frame (draws the fixed patterns): {rows[0]['seconds']:.3f} s; exposure {cold.meta['exposure_s']:.4g} s")
    for name, median, ratio, paired in summary:
        print(f"{name:24s} median {median:.3f} s  = {ratio:.2f}x floor (median of per-run ratios {paired:.2f}x)")
    print(f"wrote {args.outdir / 'bench_sensor.csv'} and {args.outdir / 'bench_sensor.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
