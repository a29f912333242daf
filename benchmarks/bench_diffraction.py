"""Diffraction OTF speed and memory: the float64 NumPy implementation it replaced against
``ThinLens.apply_diffraction`` (float32 scipy FFTs on fast sizes, bands gathered a group at a
time, threads), on 31-band cubes of 0.15, 1.4 and 5.5 MP, in the same run (issue 14 #4).

Each size runs the legacy code, the new code on every usable CPU and the new code on one
thread, interleaved, the order rotated each repeat. Wall time and process CPU time (all
threads) are taken without tracing; the peak of Python-tracked allocations (NumPy and
scipy's arrays, the output cube included, the input cube not) in one further traced run of
each. The new result is compared with the legacy one (they differ only at the border: the
fast sizes reflect a few more pixels, see tests/optics/test_thin_lens_mtf.py) and its bytes with the
one-thread result.

Usage::

    python benchmarks/bench_diffraction.py docs/bench [--sizes 480x320,1440x960,2864x1920]
        [--repeats 3] [--f-number 16] [--pitch-um 4]

Writes ``OUTDIR/diffraction.csv`` (one row per size and variant) and ``OUTDIR/diffraction.png``
(time and peak memory against megapixels), and prints a summary.

References
----------
.. [1] Goodman, J. W. (2005). Introduction to Fourier Optics, 3rd ed., §6.3 (the OTF).
.. [2] Frigo, M., & Johnson, S. G. (2005). The design and implementation of FFTW3. Proc. IEEE
   93(2) (real-input transforms, fast sizes 2^a·3^b·5^c·7^d).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

BANDS = 31


def legacy_apply_diffraction(lens, data: np.ndarray, wavelengths_nm) -> np.ndarray:
    """ThinLens.apply_diffraction before issue 14 #4, verbatim: the whole cube padded by 3 Airy
    radii, then per band (a strided slice) NumPy FFTs with a float64 OTF."""
    from spectral_cam.optics import diffraction_mtf

    height, width = data.shape[:2]
    longest = float(np.max(wavelengths_nm))
    reach = 3.0 * 1.22 * longest * 1e-9 * lens.working_f_number / lens.pixel_pitch_m  # 3 Airy radii, px
    pad = int(min(max(8, np.ceil(reach)), max(height, width)))
    padded = np.pad(data.astype(np.float32), ((pad, pad), (pad, pad), (0, 0)), mode="symmetric")
    fy = np.fft.fftfreq(padded.shape[0])[:, None]
    fx = np.fft.rfftfreq(padded.shape[1])[None, :]
    radial = np.hypot(fx, fy) / lens.pixel_pitch_m  # cycles per metre on the sensor
    out = np.empty(data.shape, dtype=np.float32)
    for band, wavelength in enumerate(wavelengths_nm):
        otf = diffraction_mtf(radial, float(wavelength), lens.working_f_number)
        blurred = np.fft.irfft2(np.fft.rfft2(padded[..., band]) * otf, s=padded.shape[:2])
        clipped = np.maximum(blurred[pad:pad + height, pad:pad + width], 0.0)
        total_before = float(data[..., band].sum(dtype=np.float64))
        total_after = float(clipped.sum(dtype=np.float64))
        out[..., band] = clipped * (total_before / total_after) if total_after > 0 else clipped
    return out


def build_cube(width: int, height: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A 31-band radiance cube (float32, (H, W, 31)): D65-lit ColorChecker spectra in random
    16-px blocks under a smooth gradient, and the band centres (nm)."""
    from spectral_cam.radiance_targets import lambertian_radiance, reflectance_set
    from spectral_cam.spectra import parse_bands

    bands = parse_bands("400:700:10")
    palette = lambertian_radiance("D65", reflectance_set("colorchecker").sds, illuminance_lux=1000.0,
                                  bands=bands).astype(np.float32)
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, len(palette), size=(height // 16 + 1, width // 16 + 1))
    labels = np.repeat(np.repeat(labels, 16, axis=0), 16, axis=1)[:height, :width]
    cube = palette[labels]
    cube *= np.linspace(0.6, 1.0, width, dtype=np.float32)[None, :, None]
    return cube, np.asarray(bands.centres_nm, dtype=float)


def run_timed(func, *args):
    """(result, wall seconds, CPU seconds of the whole process, every thread)."""
    cpu, wall = time.process_time(), time.perf_counter()
    result = func(*args)
    return result, time.perf_counter() - wall, time.process_time() - cpu


def peak_traced_bytes(func, *args) -> int:
    """Peak bytes of Python-tracked allocations while ``func`` runs (NumPy reports its data)."""
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        result = func(*args)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    del result
    return peak


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("outdir", type=Path)
    parser.add_argument("--sizes", default="480x320,1440x960,2864x1920", help="WIDTHxHEIGHT,…")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--f-number", type=float, default=16.0)
    parser.add_argument("--pitch-um", type=float, default=4.0)
    args = parser.parse_args(argv)

    from spectral_cam import viz
    from spectral_cam.apps.bench.common import write_rows
    from spectral_cam.optics import ThinLens

    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    pitch = args.pitch_um * 1e-6
    variants = {
        "legacy float64 NumPy": legacy_apply_diffraction,
        f"new, {cpus} threads": lambda lens, cube, wl: lens.apply_diffraction(cube, wl),
        "new, 1 thread": lambda lens, cube, wl: lens.apply_diffraction(cube, wl, workers=1),
    }
    names = list(variants)
    warm_lens = ThinLens(0.05, args.f_number, 3.0, 64 * pitch, 48 * pitch, 64, 48)
    warm_cube, wavelengths = build_cube(64, 48)
    for func in variants.values():  # imports, FFT plans
        func(warm_lens, warm_cube, wavelengths)

    rows = []
    for size in args.sizes.split(","):
        width, height = (int(v) for v in size.lower().split("x"))
        lens = ThinLens(0.05, args.f_number, 3.0, width * pitch, height * pitch, width, height)
        cube, wavelengths = build_cube(width, height)
        walls: dict[str, list[float]] = {name: [] for name in names}
        cpus_s: dict[str, list[float]] = {name: [] for name in names}
        results = {}
        for run in range(args.repeats):
            order = names[run % len(names):] + names[:run % len(names)]
            for name in order:
                result, wall, cpu = run_timed(variants[name], lens, cube, wavelengths)
                walls[name].append(wall)
                cpus_s[name].append(cpu)
                results[name] = result
                del result
        peaks = {name: peak_traced_bytes(variants[name], lens, cube, wavelengths) for name in names}
        legacy, threaded, single = (results[name] for name in names)
        difference = float(np.abs(threaded - legacy).max() / legacy.max())
        same_bytes = threaded.tobytes() == single.tobytes()
        (rows_p, columns_p), _ = lens.diffraction_padding(height, width, wavelengths)
        legacy_wall = min(walls[names[0]])
        for name in names:
            rows.append({
                "variant": name, "width": width, "height": height, "bands": BANDS,
                "megapixels": round(width * height / 1e6, 4), "cpus": cpus,
                "wall_s_min": min(walls[name]), "wall_s_median": statistics.median(walls[name]),
                "cpu_s_median": statistics.median(cpus_s[name]),
                "speedup_vs_legacy": legacy_wall / min(walls[name]),
                "peak_traced_mib": peaks[name] / 2 ** 20, "cube_mib": cube.nbytes / 2 ** 20,
                "fft_size": f"{rows_p}x{columns_p}" if name != names[0] else "",
                "max_diff_vs_legacy_rel": difference if name != names[0] else 0.0,
                "bytes_equal_1_vs_all_threads": same_bytes,
                "repeats": args.repeats,
            })
        del results, legacy, threaded, single, cube

    args.outdir.mkdir(parents=True, exist_ok=True)
    csv_path = write_rows(rows, args.outdir / "diffraction.csv")

    figure = viz.figure(10, 4.2)
    time_ax, memory_ax = figure.subplots(1, 2)
    for number, name in enumerate(names):
        subset = [r for r in rows if r["variant"] == name]
        mp = [r["megapixels"] for r in subset]
        time_ax.plot(mp, [r["wall_s_min"] for r in subset], "o-", color=f"C{number}", label=name)
        memory_ax.plot(mp, [r["peak_traced_mib"] for r in subset], "o-", color=f"C{number}", label=name)
    memory_ax.plot(mp, [r["cube_mib"] for r in subset], "k:", label="one float32 cube")
    for r in rows:
        if r["variant"] == names[1]:
            time_ax.annotate(f"{r['speedup_vs_legacy']:.1f}× faster", (r["megapixels"], r["wall_s_min"]),
                             textcoords="offset points", xytext=(6, 6), fontsize=8)
    from matplotlib.ticker import NullFormatter

    for ax, label in ((time_ax, "wall seconds (best of repeats)"), (memory_ax, "peak traced MiB (output included)")):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(mp, labels=[f"{m:.2g}" for m in mp])
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel(f"megapixels ({BANDS} bands)")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    figure.suptitle(f"Diffraction OTF per band, f/{args.f_number:g}, {args.pitch_um:g} µm pixels, "
                    f"{cpus} CPUs ({platform.machine()})", fontsize=10)
    png_path = viz.save_png(figure, args.outdir / "diffraction.png", dpi=110)

    print(f"machine: {platform.processor() or platform.machine()}, {cpus} usable CPUs "
          f"({os.cpu_count()} online), python {sys.version.split()[0]}, numpy {np.__version__}")
    for r in rows:
        print(f"{r['width']}x{r['height']} ({r['megapixels']:.2f} MP) {r['variant']:22s} wall min "
              f"{r['wall_s_min']:7.3f} s  median {r['wall_s_median']:7.3f} s  cpu {r['cpu_s_median']:7.3f} s  "
              f"x{r['speedup_vs_legacy']:.1f}  peak {r['peak_traced_mib']:7.0f} MiB  "
              f"diff {r['max_diff_vs_legacy_rel']:.1e}  same bytes {r['bytes_equal_1_vs_all_threads']}")
    print(f"wrote {csv_path} and {png_path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
