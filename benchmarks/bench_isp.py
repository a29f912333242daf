"""ISP speed on a 12 MP RAW: our develop (bilinear, malvar2004) against LibRaw's postprocess
(LINEAR, AHD) of the same DNG, in the same run, as time ratios, with ColorChecker ΔE2000.

The RAW is a synthetic ColorChecker filling a ~12 MP frame (patches 640 px wide, radiance
ρ·E/π under D65) exposed by our sensor at ISO 100 with every noise term on, so the colour
figures include noise. Our pipeline develops the in-memory RawImage (fitted colour matrix)
and the DNG read back (its ColorMatrix1, LibRaw's footing); LibRaw outputs XYZ, converted to
linear sRGB. Target: our malvar2004 faster than LibRaw's AHD with better ΔE2000.

Usage::

    python benchmarks/bench_isp.py OUTDIR [--repeats 3]

Writes ``OUTDIR/bench_isp.csv`` and ``OUTDIR/bench_isp.png``.

References
----------
.. [1] Malvar, He & Cutler (2004), ICASSP; Hirakawa & Parks (2005), IEEE TIP (AHD).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    import rawpy

    from spectral_cam import expose, scene_from_dict
    from spectral_cam.apps.bench.common import pareto_chart, timed, write_rows
    from spectral_cam.apps.bench.isp import libraw_xyz
    from spectral_cam.charts import reflectance_set, synthetic_chart
    from spectral_cam.colorimetry import patch_linear_srgb, xyz_to_linear_srgb
    from spectral_cam.isp import ISPConfig, develop
    from spectral_cam.metrics import colorchecker_delta_e
    from spectral_cam.raw import read_raw, write_dng

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    chart = synthetic_chart(reflectance_set("colorchecker"), "D65", patch_px=640, gap_px=20)
    height, width = chart.radiance.data.shape[:2]
    config = scene_from_dict({"scene": {"preset": "flat_field"},
                              "sensor": {"width_px": width, "height_px": height, "vignetting": False}})
    white = np.zeros((height, width), bool)
    white[chart.patches[chart.white_index].interior(0.2)] = True
    raw = expose(chart.radiance, config, white_mask=white)
    del chart.radiance.data
    patches = chart.patches[:chart.n_set]
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
    pareto_chart(rows, out / "bench_isp.png", x="time_vs_rawpy_ahd", y="delta_e2000", label="pipeline",
                 xlabel=f"develop time / rawpy AHD ({baseline:.2f} s, {width}×{height})",
                 ylabel="mean ΔE2000, ColorChecker, ISO 100 with noise",
                 title="12 MP develop: our ISP vs LibRaw on the same DNG", front=False)
    for row in rows:
        print(f"{row['pipeline']:34s} {row['seconds']:7.3f} s  ×{row['time_vs_rawpy_ahd']:.2f} of AHD  "
              f"ΔE2000 {row['delta_e2000']:.3f}")


if __name__ == "__main__":
    main()
