"""Whole-process ``spectral-cam develop`` against a whole-process rawpy (LibRaw AHD) on the same
DNG, as the frame grows: wall time per megapixel, in the same run (issue 13 #6).

Each DNG is a Bayer mosaic of a smooth random texture with our sensor's colour metadata
(ColorMatrix1/2, AsShotNeutral, NoiseProfile), written by ``write_dng``. Each side is a fresh
Python process from start to the written 8-bit PNG, so imports count as a user meets them:

- ours: ``spectral-cam develop RAW -o OUT.png`` (defaults: the ISP's default demosaic,
  ``ISPConfig.demosaic``, named in the CSV and the README; the DNG matrix), and with
  ``--set isp.demosaic=malvar2004``;
- rawpy: ``rawpy.imread(...).postprocess(demosaic_algorithm=AHD, use_camera_wb=True)`` and an
  OpenCV PNG write, in a ``python -c`` process.

Usage::

    python benchmarks/bench_develop.py docs/bench --readme README.md [--sizes 1,6,24] [--repeats 3]
    python benchmarks/bench_develop.py docs/bench --readme-only     # the README block from the CSV

Writes ``OUTDIR/bench_develop.csv`` and ``OUTDIR/bench_develop.png`` (seconds and the ratio
against rawpy at each size). Medians of interleaved repeats.

References
----------
.. [1] Hirakawa & Parks (2005), IEEE TIP 14(3) (AHD); LibRaw documentation (postprocess).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

RAWPY_SCRIPT = (
    "import sys, cv2, rawpy\n"
    "with rawpy.imread(sys.argv[1]) as raw:\n"
    "    rgb = raw.postprocess(demosaic_algorithm=rawpy.DemosaicAlgorithm.AHD, use_camera_wb=True, output_bps=8)\n"
    "cv2.imwrite(sys.argv[2], rgb[..., ::-1])\n"
)


def make_dng(path: Path, megapixels: float) -> Path:
    """A ``megapixels`` Bayer DNG (3:2) of a smooth texture with our sensor's colour metadata."""
    import cv2

    from spectral_cam import expose, scene_from_dict
    from spectral_cam.radiance_targets import narrow_band_flat
    from spectral_cam.raw import RawImage, write_dng

    width = int(round(np.sqrt(megapixels * 1e6 * 1.5) / 2)) * 2
    height = int(round(width / 1.5 / 2)) * 2
    metadata = expose(narrow_band_flat((32, 32), 0.05), scene_from_dict({"sensor": {"width_px": 32, "height_px": 32},
                                                                       "exposure": {"time_s": 0.01}}))
    coarse = np.random.default_rng(0).uniform(300, 3800, (height // 64 + 2, width // 64 + 2)).astype(np.float32)
    mosaic = cv2.resize(coarse, (width, height), interpolation=cv2.INTER_CUBIC).clip(0, 4095).astype(np.uint16)
    raw = RawImage(mosaic, "RGGB", metadata.black_level, metadata.white_level, color_matrix=metadata.color_matrix,
                   color_matrix_2=metadata.color_matrix_2, as_shot_neutral=metadata.as_shot_neutral,
                   noise_profile=metadata.noise_profile, camera_model=metadata.camera_model, meta=metadata.meta)
    return write_dng(raw, path)


BEGIN, END = "<!-- bench-develop:begin -->", "<!-- bench-develop:end -->"


def default_demosaic() -> str:
    """The demosaic a plain ``spectral-cam develop`` uses: the ISP configuration's default."""
    from spectral_cam.isp.config import ISPConfig

    return ISPConfig().demosaic


def readme_block(rows: list[dict]) -> str:
    """The README's paragraph on develop speed, from the CSV rows (a CSV written before the
    ``default_demosaic`` column names the configuration's default now)."""
    big = max(rows, key=lambda r: float(r["megapixels"]))
    small = min(rows, key=lambda r: float(r["megapixels"]))
    default = big.get("default_demosaic") or default_demosaic()
    return (
        f"{BEGIN}\n"
        "`python benchmarks/bench_develop.py OUT` times `spectral-cam develop` as a user meets it, a fresh\n"
        "process from the DNG to the PNG, against a fresh rawpy process (LibRaw AHD, camera white balance,\n"
        "an OpenCV PNG) on the same file, interleaved in one run ([CSV](docs/bench/bench_develop.csv),\n"
        f"[chart](docs/bench/bench_develop.png)): at {float(big['megapixels']):g} MP "
        f"{float(big['ours_s']):.2f} s with the default {default} and "
        f"{float(big['ours_malvar2004_s']):.2f} s with malvar2004, against rawpy's "
        f"{float(big['rawpy_ahd_s']):.2f} s (×{float(big['ratio']):.2f} and ×{float(big['ratio_malvar2004']):.2f});\n"
        f"at {float(small['megapixels']):g} MP ×{float(small['ratio']):.2f} and "
        f"×{float(small['ratio_malvar2004']):.2f}. A develop imports neither Mitsuba, Dask nor\n"
        f"colour-science (which loads matplotlib); {default} runs on the four CFA planes in row strips\n"
        "on parallel threads; PNGs are deflated in parallel slices (zlib level 1).\n"
        f"{END}"
    )


def update_readme(readme: Path, rows: list[dict]) -> None:
    from spectral_cam.records import replace_block

    replace_block(readme, BEGIN, END, readme_block(rows))


def wall(argv: list[str]) -> float:
    started = time.perf_counter()
    subprocess.run(argv, check=True, capture_output=True)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output")
    parser.add_argument("--sizes", default="1,6,24", help="megapixels, comma-separated")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--readme", default=None, help="README.md whose bench-develop block to regenerate")
    parser.add_argument("--readme-only", action="store_true",
                        help="regenerate the README block from OUTPUT/bench_develop.csv without measuring")
    args = parser.parse_args()
    if args.readme_only:
        import csv

        with open(Path(args.output) / "bench_develop.csv", newline="") as handle:
            update_readme(Path(args.readme or "README.md"), list(csv.DictReader(handle)))
        return

    from spectral_cam.apps.bench.common import write_rows
    from spectral_cam.viz import figure, save_png

    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    cli = str(Path(sys.executable).with_name("spectral-cam"))
    rows = []
    default = default_demosaic()
    with tempfile.TemporaryDirectory() as folder:
        for megapixels in (float(v) for v in args.sizes.split(",")):
            dng = make_dng(Path(folder) / f"{megapixels:g}mp.dng", megapixels)
            ours, malvar, libraw = [], [], []
            develop = [cli, "develop", str(dng), "-o", f"{folder}/ours.png", "--force", "-q"]
            runs = [(ours, develop), (malvar, develop + ["--set", "isp.demosaic=malvar2004"]),
                    (libraw, [sys.executable, "-c", RAWPY_SCRIPT, str(dng), f"{folder}/rawpy.png"])]
            for _, argv in runs:  # one unmeasured run each: file cache and first-touch memory alike
                wall(argv)
            for repeat in range(args.repeats):  # interleaved, the order rotated, so drift hits all alike
                for times, argv in runs[repeat % 3:] + runs[:repeat % 3]:
                    times.append(wall(argv))
            row = {"megapixels": megapixels, "default_demosaic": default, "ours_s": float(np.median(ours)),
                   "ours_malvar2004_s": float(np.median(malvar)), "rawpy_ahd_s": float(np.median(libraw))}
            row["ratio"] = row["ours_s"] / row["rawpy_ahd_s"]
            row["ratio_malvar2004"] = row["ours_malvar2004_s"] / row["rawpy_ahd_s"]
            rows.append(row)
            print(f"{megapixels:g} MP: ours {row['ours_s']:.2f} s (malvar2004 {row['ours_malvar2004_s']:.2f} s), "
                  f"rawpy AHD {row['rawpy_ahd_s']:.2f} s, ×{row['ratio']:.2f} (×{row['ratio_malvar2004']:.2f})",
                  file=sys.stderr)
    write_rows(rows, out / "bench_develop.csv")
    fig = figure(7, 4)
    ax, ratio = fig.subplots(1, 2)
    sizes = [r["megapixels"] for r in rows]
    ax.plot(sizes, [r["ours_s"] for r in rows], "o-", label=f"spectral-cam develop ({default})")
    ax.plot(sizes, [r["ours_malvar2004_s"] for r in rows], "o--", label="spectral-cam develop (malvar2004)")
    ax.plot(sizes, [r["rawpy_ahd_s"] for r in rows], "s-", label="rawpy / LibRaw AHD")
    ax.set_xlabel("frame (MP)"), ax.set_ylabel("whole process, s"), ax.legend(fontsize=8)
    ratio.plot(sizes, [r["ratio"] for r in rows], "o-", label=default)
    ratio.plot(sizes, [r["ratio_malvar2004"] for r in rows], "o--", label="malvar2004")
    ratio.legend(fontsize=8)
    ratio.axhline(1.5, color="grey", ls="--", lw=1)
    ratio.set_xlabel("frame (MP)"), ratio.set_ylabel("ours / rawpy")
    fig.suptitle("Developing one DNG, whole process (same run, medians)", fontsize=10)
    save_png(fig, out / "bench_develop.png")
    if args.readme:
        update_readme(Path(args.readme), rows)


if __name__ == "__main__":
    main()
