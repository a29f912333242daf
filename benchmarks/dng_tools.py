"""Our DNG developed by the raw developers photographers use, against colour-science's ground
truth and against our own ISP (issue 13, "Real references in the suite").

The scene is the synthetic ColorChecker (colour-science's 24 reflectances, noise off, white
auto-exposed) under CIE D65 and under CIE Standard Illuminant A, exposed on the Nikon D850 curves
and written by ``write_dng`` (ColorMatrix1 = A, ColorMatrix2 = D65, AsShotNeutral). Each tool that
is installed develops the same file with camera white balance and no automatic brightening, to
linear sRGB where it can:

- ours: ``develop(read_raw(path), ISPConfig(colour_matrix="dng", tone="linear"))``;
- LibRaw via rawpy: ``postprocess(use_camera_wb=True, no_auto_bright=True, gamma=(1, 1),
  output_color=sRGB, output_bps=16)``;
- dcraw: ``-w -W -4 -T -o 1`` (camera WB, no auto-bright, linear 16-bit, sRGB);
- RawTherapee (``rawtherapee-cli``): its built-in neutral profile with white balance "Camera",
  the input profile "(camera)" (the DNG's colour matrix), AMaZE and the bundled ``RTv4_sRGB``
  output profile, 16-bit TIFF, decoded with the IEC 61966-2-1 sRGB curve (the profile's TRC is
  ICC ``para`` type 4 with γ 2.4, 1/1.055, 0.055/1.055, 1/12.92);
- Adobe's DNG SDK via dngpy: dngpy reads the stage-1 mosaic (bit-exact, see
  ``tests/raw/test_real_tools.py``) and a stage-3 image only where the file holds one (ours do
  not); it has no rendering call, so it develops nothing here and is listed as not run.

Patches are averaged over their interiors and matched in exposure on the white patch
(:func:`spectral_cam.metrics.colorchecker_delta_e`); out-of-gamut values are clipped by the
tools' integer outputs as a user would get them. The chart is 296 × 200 pixels because
RawTherapee 5.9 refuses raw files under 100 000 bytes (``identify()`` in its ``dcraw.cc``).

Usage::

    python benchmarks/dng_tools.py [--csv docs/bench/dng_tools.csv] [--readme README.md]

Writes the CSV (tool, version, settings, illuminant, ΔE2000 mean and max against the ground
truth, mean and max against our ISP) and regenerates the block between ``<!-- dng-tools:begin
-->`` and ``<!-- dng-tools:end -->`` in the README from that CSV. Tool versions are read from the
tools themselves.

References
----------
.. [1] Adobe (2023). Digital Negative (DNG) Specification 1.7.1.0, ch. 6 (mapping camera
   colour space to CIE XYZ).
.. [2] Sharma, Wu & Dalal (2005). The CIEDE2000 colour-difference formula. Color Res. Appl. 30(1).
.. [3] IEC 61966-2-1:1999 (sRGB).
"""

from __future__ import annotations

import argparse
import csv
import io
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
ILLUMINANTS = ("D65", "A")
PATCH_PX, GAP_PX = 40, 8  # 296 × 200 px: a DNG over the 100 000 bytes RawTherapee 5.9 needs
BEGIN, END = "<!-- dng-tools:begin -->", "<!-- dng-tools:end -->"
FIELDS = ["tool", "version", "settings", "illuminant", "delta_e_mean", "delta_e_max",
          "vs_ours_mean", "vs_ours_max"]
QUIET = {"shot_noise": False, "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0}

#: The RawTherapee 5.9 settings of the table and of tests/raw/test_real_tools.py: camera white
#: balance, AMaZE, the camera's input profile, RTv4_sRGB out; every key not given keeps the built-in
#: neutral value ("Neutral" profile).
RAWTHERAPEE_PROFILE = Path(__file__).resolve().parent.parent / "plans" / "rawtherapee_neutral.pp3"  # the plan's too


#: Pixels of the chart's surround outside the DNG's default crop (sensor.crop_margin_px's default).
CROP_MARGIN_PX = 8


class NotRun(Exception):
    """A tool that is absent or cannot develop; the message says why."""


def chart_dng(directory: Path, illuminant: str):
    """The noise-free synthetic ColorChecker under ``illuminant`` as our DNG (as the suite's
    ``_chart_dng`` builds it, with larger patches); returns ``(chart, path)``."""
    from spectral_cam import expose, scene_from_dict
    from spectral_cam.radiance_targets import reflectance_set, synthetic_chart
    from spectral_cam.raw import write_dng

    chart = synthetic_chart(reflectance_set("colorchecker"), illuminant, patch_px=PATCH_PX, gap_px=GAP_PX,
                            margin_px=CROP_MARGIN_PX)  # the chart's surround as the DNG's crop margin
    height, width = chart.radiance.frame[2:]
    config = scene_from_dict({"scene": {"preset": "flat_field"}, "illuminant": {"spd": illuminant},
                              "lens": {"focal_length_mm": 35.0, "f_number": 5.6},
                              "sensor": {"width_px": width, "height_px": height, "vignetting": False, **QUIET},
                              "exposure": {"iso": 400}})
    mask = np.zeros((height, width), bool)
    mask[chart.patches[chart.white_index].interior(0.2)] = True
    raw = expose(chart.radiance, config, white_mask=mask)
    return chart, write_dng(raw, Path(directory) / f"chart_{illuminant}.dng")


def centred(image: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``image`` on the chart's pixel grid: tools crop (RawTherapee: 4 px a side for
    demosaicing) or keep (a DNG border outside the default crop) symmetric margins, so the
    chart sits in the middle; a smaller image is centred on a NaN canvas."""
    image = np.asarray(image, float)
    dy, dx = image.shape[0] - shape[0], image.shape[1] - shape[1]
    if dy % 2 or dx % 2:
        raise ValueError(f"an image of {image.shape[:2]} is not a symmetric margin around {shape}")
    if dy >= 0 and dx >= 0:
        return image[dy // 2:dy // 2 + shape[0], dx // 2:dx // 2 + shape[1]]
    canvas = np.full((*shape, image.shape[2]), np.nan)
    canvas[-dy // 2:-dy // 2 + image.shape[0], -dx // 2:-dx // 2 + image.shape[1]] = image
    return canvas


def _which(name: str, apt: str) -> str:
    path = shutil.which(name)
    if not path:
        raise NotRun(f"{name} is absent (apt-get install {apt})")
    return path


# ----------------------------------------------------------------------------- the tools
def _ours_version() -> str:
    from importlib.metadata import version

    return version("spectral_cam")


def _ours(path: Path, work: Path) -> np.ndarray:
    from spectral_cam.isp import ISPConfig, develop
    from spectral_cam.raw import read_raw

    return develop(read_raw(path), ISPConfig(colour_matrix="dng", tone="linear")).linear


def _libraw_version() -> str:
    import rawpy

    return f"LibRaw {'.'.join(map(str, rawpy.libraw_version))} (rawpy {rawpy.__version__})"


def _libraw(path: Path, work: Path) -> np.ndarray:
    import rawpy

    with rawpy.imread(str(path)) as handle:
        rgb = handle.postprocess(use_camera_wb=True, no_auto_bright=True, gamma=(1, 1), output_bps=16,
                                 output_color=rawpy.ColorSpace.sRGB, user_flip=0)
    return rgb.astype(float) / 65535.0


def _dcraw_version() -> str:
    usage = subprocess.run([_which("dcraw", "dcraw")], capture_output=True, text=True, check=False)
    match = re.search(r'"dcraw" v(\S+)', usage.stdout + usage.stderr)
    if not match:
        raise NotRun("dcraw printed no version")
    return match.group(1)


def _dcraw(path: Path, work: Path) -> np.ndarray:
    import tifffile

    out = subprocess.run([_which("dcraw", "dcraw"), "-w", "-W", "-4", "-T", "-o", "1", "-c", str(path)],
                         capture_output=True, check=True).stdout
    return tifffile.imread(io.BytesIO(out)).astype(float) / 65535.0


def _rawtherapee_env(work: Path) -> dict:
    """RawTherapee keeps options and a cache under the XDG folders: a private pair per run."""
    return {**os.environ, "XDG_CONFIG_HOME": str(work / "rt-config"), "XDG_CACHE_HOME": str(work / "rt-cache")}


def _rawtherapee_version() -> str:
    with tempfile.TemporaryDirectory() as work:
        usage = subprocess.run([_which("rawtherapee-cli", "rawtherapee"), "-v"], capture_output=True, text=True,
                               env=_rawtherapee_env(Path(work)), check=False)
    match = re.search(r"RawTherapee, version (\S+?),", usage.stdout + usage.stderr)
    if not match:
        raise NotRun("rawtherapee-cli printed no version")
    return match.group(1)


def _rawtherapee(path: Path, work: Path) -> np.ndarray:
    import colour
    import tifffile

    out = work / f"{path.stem}_rt.tif"
    run = subprocess.run([_which("rawtherapee-cli", "rawtherapee"), "-q", "-Y", "-t", "-b16", "-p", str(RAWTHERAPEE_PROFILE),
                          "-o", str(out), "-c", str(path)], capture_output=True, text=True,
                         env=_rawtherapee_env(work), check=False)
    if run.returncode or not out.exists():
        raise RuntimeError(f"rawtherapee-cli failed on {path}: {run.stdout}{run.stderr}")
    return colour.cctf_decoding(tifffile.imread(out).astype(float) / 65535.0, "sRGB")


def _dngpy_version() -> str:
    try:
        import dngpy
    except ImportError as error:
        raise NotRun("dngpy is absent (pip install dngpy)") from error
    return f"dngpy {dngpy.__version__}"


def _dngpy(path: Path, work: Path) -> np.ndarray:
    import dngpy

    try:
        stage3 = dngpy.Dng(str(path)).enhanced_pixels
    except RuntimeError as error:  # "Stage 3 (enhanced) image data is not available in this DNG."
        raise NotRun("it reads the stage-1 mosaic, has no rendering call, and our DNGs hold no stage-3 "
                     "image") from error
    raise NotRun(f"its stage-3 image ({stage3.shape}) is the camera's colour space, not a rendering")


@dataclass(frozen=True)
class Tool:
    name: str
    settings: str
    version: Callable[[], str]
    develop: Callable[[Path, Path], np.ndarray]


TOOLS = (
    Tool("spectral_cam", 'ISPConfig(colour_matrix="dng", tone="linear")', _ours_version, _ours),
    Tool("LibRaw (rawpy)", "use_camera_wb, no_auto_bright, gamma (1, 1), sRGB, 16-bit", _libraw_version, _libraw),
    Tool("dcraw", "-w -W -4 -T -o 1", _dcraw_version, _dcraw),
    Tool("RawTherapee", "neutral, WB camera, input (camera), RTv4_sRGB, 16-bit TIFF", _rawtherapee_version,
         _rawtherapee),
    Tool("Adobe DNG SDK", "Dng(path).enhanced_pixels", _dngpy_version, _dngpy),
)


# ----------------------------------------------------------------------------- the run
def measure(work: Path, log=print) -> tuple[list[dict], list[str]]:
    """Every installed tool on both charts: the CSV rows and one line per tool not run."""
    from spectral_cam.colour_ground_truth import patch_linear_srgb
    from spectral_cam.metrics import colorchecker_delta_e

    charts = {ill: chart_dng(work, ill) for ill in ILLUMINANTS}
    ours = {ill: centred(_ours(path, work), tuple(chart.radiance.frame[2:])) for ill, (chart, path) in charts.items()}
    rows, not_run = [], []
    for tool in TOOLS:
        version = None
        try:
            version = tool.version()
            images = {ill: tool.develop(path, work) for ill, (_, path) in charts.items()}
        except NotRun as why:
            not_run.append(f"{tool.name}{f' ({version})' if version else ''}: {why}")
            log(f"not run: {not_run[-1]}")
            continue
        for ill, (chart, _) in charts.items():
            patches = chart.patches[:24]
            image = centred(images[ill], tuple(chart.radiance.frame[2:]))
            truth = colorchecker_delta_e(image, patch_linear_srgb(ill), patches)
            against = colorchecker_delta_e(image, ours[ill], patches)
            rows.append({"tool": tool.name, "version": version, "settings": tool.settings, "illuminant": ill,
                         "delta_e_mean": f"{truth['mean']:.4f}", "delta_e_max": f"{truth['max']:.4f}",
                         "vs_ours_mean": f"{against['mean']:.4f}", "vs_ours_max": f"{against['max']:.4f}"})
            log(f"{tool.name} {version} {ill}: mean {truth['mean']:.3f} max {truth['max']:.3f} "
                f"(vs ours {against['mean']:.3f})")
    return rows, not_run


def write_csv(rows: list[dict], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=FIELDS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)


def readme_block(csv_path: Path, not_run: list[str] = ()) -> str:
    """The README block, from the CSV alone (plus the tools that did not run)."""
    with open(csv_path, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    cell = {(r["tool"], r["illuminant"]): f"{float(r['delta_e_mean']):.2f} (max {float(r['delta_e_max']):.1f})"
            for r in rows}
    shown = Path(os.path.relpath(csv_path, REPO)).as_posix()
    lines = [BEGIN,
             "Our DNG of the synthetic ColorChecker (noise off) developed by the real tools: mean ΔE2000",
             "(max) of the 24 patches against colour-science's ground truth, under D65 and under Standard A",
             f"(`python benchmarks/dng_tools.py` writes `{shown}` and this table).",
             "",
             "| tool | version | settings | D65 | A |",
             "|---|---|---|---|---|"]
    for row in rows:
        if row["illuminant"] != ILLUMINANTS[0]:
            continue
        lines.append(f"| {row['tool']} | {row['version']} | `{row['settings']}` | "
                     + " | ".join(cell.get((row["tool"], ill), "—") for ill in ILLUMINANTS) + " |")
    if not_run:
        lines += ["", "Not run: " + "; ".join(not_run) + "."]
    lines.append(END)
    return "\n".join(lines)


def update_readme(readme: Path, block: str) -> None:
    from spectral_cam.records import replace_block

    replace_block(readme, BEGIN, END, block)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--csv", type=Path, default=REPO / "docs" / "bench" / "dng_tools.csv")
    parser.add_argument("--readme", type=Path, default=REPO / "README.md")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as work:
        rows, not_run = measure(Path(work))
    write_csv(rows, args.csv)
    update_readme(args.readme, readme_block(args.csv.resolve(), not_run))
    print(f"wrote {args.csv} and the {BEGIN} block of {args.readme}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
