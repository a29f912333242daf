"""ISP speed on a 12 MP RAW: our develop (bilinear, malvar2004) against LibRaw's postprocess
(LINEAR, AHD) of the same DNG, in the same run, as time ratios, with ColorChecker ΔE2000.

The RAW is a synthetic ColorChecker filling a ~12 MP frame (patches 640 px wide, radiance
ρ·E/π under D65) exposed by our sensor at ISO 100 with every noise term on, so the colour
figures include noise. Our pipeline develops the in-memory RawImage (fitted colour matrix)
and the DNG read back (its ColorMatrix1, LibRaw's footing); LibRaw outputs XYZ, converted to
linear sRGB. Target: our malvar2004 faster than LibRaw's AHD with better ΔE2000.

Usage::

    python benchmarks/bench_isp.py OUTDIR [--repeats 3]
    python benchmarks/bench_isp.py OUTDIR --from-csv   # redraw the chart from OUTDIR/bench_isp.csv

Writes ``OUTDIR/bench_isp.csv`` and ``OUTDIR/bench_isp.png`` (time ratio and ΔE2000 as bars,
the ΔE2000 axis from 0).

References
----------
.. [1] Malvar, He & Cutler (2004), ICASSP; Hirakawa & Parks (2005), IEEE TIP (AHD).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np


def chart(rows: list[dict], path: Path) -> Path:
    """Two bar panels on one row per pipeline: develop time as a ratio to rawpy AHD, and
    ColorChecker ΔE2000 on an axis from 0 (the pipelines differ by under 0.01, a hundredth of
    a just-noticeable difference, which an axis fitted to the data would magnify), each bar
    with its value."""
    from spectral_cam.viz import figure, save_png

    baseline = next(r["seconds"] for r in rows if r["pipeline"] == "rawpy AHD")
    names = [r["pipeline"] for r in rows]
    colours = ["0.55" if name.startswith("rawpy") else "C0" for name in names]
    fig = figure(8, 3.2, dpi=110)
    time_ax, error_ax = fig.subplots(1, 2, sharey=True)
    for ax, key, label, digits in ((time_ax, "time_vs_rawpy_ahd", f"develop time / rawpy AHD ({baseline:.2f} s)", 2),
                                   (error_ax, "delta_e2000", "mean ΔE2000, ColorChecker, ISO 100 with noise", 3)):
        values = [r[key] for r in rows]
        bars = ax.barh(range(len(rows)), values, color=colours, height=0.6)
        ax.bar_label(bars, [f"{v:.{digits}f}" for v in values], padding=3, fontsize=7)
        ax.set_xlim(0, max(values) * 1.2)
        ax.set_xlabel(label, fontsize=8)
        ax.grid(True, axis="x", alpha=0.3)
    time_ax.axvline(1.0, color="k", lw=0.6, ls=":")
    time_ax.set_yticks(range(len(rows)), names, fontsize=8)
    time_ax.invert_yaxis()
    errors = [r["delta_e2000"] for r in rows]
    fig.suptitle(f"{rows[0]['megapixels']:.1f} MP develop: our ISP vs LibRaw on the same DNG (ΔE2000 "
                 f"{min(errors):.3f}–{max(errors):.3f}; 1 ≈ just noticeable)", fontsize=9)
    return save_png(fig, path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--from-csv", action="store_true", help="redraw the chart from OUTDIR/bench_isp.csv")
    args = parser.parse_args()
    out = Path(args.output)
    if args.from_csv:
        from spectral_cam.apps.bench.common import read_rows

        print(f"wrote {chart(read_rows(out / 'bench_isp.csv'), out / 'bench_isp.png')}")
        return

    import rawpy

    from spectral_cam import expose, scene_from_dict
    from spectral_cam.apps.bench.common import timed, write_rows
    from spectral_cam.apps.bench.isp import libraw_xyz
    from spectral_cam.radiance_targets import reflectance_set, synthetic_chart
    from spectral_cam.colour_ground_truth import patch_linear_srgb, xyz_to_linear_srgb
    from spectral_cam.isp import ISPConfig, develop
    from spectral_cam.metrics import colorchecker_delta_e
    from spectral_cam.raw import read_raw, write_dng

    out.mkdir(parents=True, exist_ok=True)
    target = synthetic_chart(reflectance_set("colorchecker"), "D65", patch_px=640, gap_px=20)
    height, width = target.radiance.data.shape[:2]
    config = scene_from_dict({"scene": {"preset": "flat_field"},
                              "sensor": {"width_px": width, "height_px": height, "vignetting": False}})
    white = np.zeros((height, width), bool)
    white[target.patches[target.white_index].interior(0.2)] = True
    raw = expose(target.radiance, config, white_mask=white)
    del target.radiance.data
    patches = target.patches[:target.n_set]
    truth = patch_linear_srgb("D65")

    rows = []
    with tempfile.TemporaryDirectory() as folder:
        dng = Path(folder) / "chart.dng"
        write_dng(raw, dng)
        from_dng = read_raw(dng)
        develop(raw, ISPConfig())  # warm-up: OpenCV's and NumPy's first calls set up thread pools
        for name, algorithm in (("rawpy LINEAR", rawpy.DemosaicAlgorithm.LINEAR),
                                ("rawpy AHD", rawpy.DemosaicAlgorithm.AHD)):
            xyz, seconds = timed(libraw_xyz, dng, algorithm, repeats=args.repeats)
            linear = xyz_to_linear_srgb(xyz / 65535.0)
            del xyz
            rows.append({"pipeline": name, "seconds": seconds,
                         "delta_e2000": colorchecker_delta_e(linear, truth, patches)["mean"]})
        for method in ("bilinear", "malvar2004"):
            for label, source, matrix in (("fitted", raw, "auto"), ("dng", from_dng, "dng")):
                isp = ISPConfig(demosaic=method, colour_matrix=matrix, tone="srgb")
                developed, seconds = timed(develop, source, isp, repeats=args.repeats)
                rows.append({"pipeline": f"ours {method} ({label} matrix)", "seconds": seconds,
                             "delta_e2000": colorchecker_delta_e(developed.linear, truth, patches)["mean"]})
    baseline = next(r["seconds"] for r in rows if r["pipeline"] == "rawpy AHD")
    for row in rows:
        row["time_vs_rawpy_ahd"] = row["seconds"] / baseline
        row["megapixels"] = width * height / 1e6
    write_rows(rows, out / "bench_isp.csv")
    chart(rows, out / "bench_isp.png")
    for row in rows:
        print(f"{row['pipeline']:34s} {row['seconds']:7.3f} s  ×{row['time_vs_rawpy_ahd']:.2f} of AHD  "
              f"ΔE2000 {row['delta_e2000']:.3f}")


if __name__ == "__main__":
    main()
