"""ISP forensics: the same scene developed twice — once with a different white balance, once with a
different exposure — and which differences software can undo afterwards.

White balance does not touch the RAW: developing the RAW again with the first gains gives the
first image bit for bit. From the developed file it can only be undone approximately: the gains
act on camera channels before demosaicing and the colour matrix, so a 3 × 3 transform of the
developed image, M·diag(1/r)·M⁻¹, undoes most of it, but highlight clipping and 8-bit rounding do
not invert. Exposure is different: a frame three stops brighter clipped in the sensor — those
pixels lost their information in the RAW itself and stay wrong after scaling back — and a frame
three stops darker, brightened afterwards, keeps only every 8th 8-bit level (its histogram
combs).

Prints the error left after undoing each change (in 8-bit levels) and writes the per-channel
histograms as a PNG.

    python examples/isp_forensics.py [-o OUT_DIR]
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np


def develop_twice(size=(96, 64)):
    """(as shot, white balance shifted, 3 stops brighter, 3 stops darker, the RAW's re-development
    with the first gains) of a ColorChecker."""
    from spectral_cam import develop, expose, render, scene_from_dict

    config = scene_from_dict({"scene": {"preset": "colorchecker", "surround": 0}, "illuminant": {"spd": "D65"},
                              "sensor": {"width_px": size[0], "height_px": size[1]}, "render": {"spp": 16},
                              # exposed for the white patch, as a chart is shot for measurement
                              "exposure": {"metering": "etr", "iso_definition": "saturation"},
                              "isp": {"tone": "linear", "white_balance": "as_shot", "demosaic": "bilinear"}})
    radiance = render(config, with_depth=False)
    raw = expose(radiance, config, frame_seed=1)
    base = develop(raw, config.isp)
    shifted_isp = replace(config.isp, white_balance="manual",
                          wb_gains=tuple(g * f for g, f in zip(base.meta["white_balance_gains"], (1.2, 1.0, 0.8))))
    shifted = develop(raw, shifted_isp)
    redeveloped = develop(raw, replace(config.isp, white_balance="manual",
                                       wb_gains=tuple(base.meta["white_balance_gains"])))
    time_s = raw.meta["exposure_s"]
    bright = develop(expose(radiance, config.replace(**{"exposure.time_s": time_s * 8}), frame_seed=1), config.isp)
    dark = develop(expose(radiance, config.replace(**{"exposure.time_s": time_s / 8}), frame_seed=1), config.isp)
    return base, shifted, bright, dark, redeveloped


def analyse(base, shifted, bright, dark, redeveloped) -> dict:
    """Undo each change on the 8-bit files a pipeline writes (white balance also on the float
    image, where it is exact) and measure what is left, in 8-bit levels."""
    from spectral_cam.isp.encode import quantise

    ref, ref8 = base.image.astype(np.float64), quantise(base.image, bits=8).astype(np.float64)
    # the gains scale the camera channels before the colour matrix M: out' = M·diag(r)·M⁻¹·out
    matrix = np.asarray(base.meta["colour_transform_matrix"], dtype=np.float64)
    shifted_matrix = np.asarray(shifted.meta["colour_transform_matrix"], dtype=np.float64)  # adapted to its white
    applied = np.asarray(shifted.meta["white_balance_gains"]) / np.asarray(base.meta["white_balance_gains"])
    undo = matrix @ np.diag(1.0 / applied) @ np.linalg.inv(shifted_matrix)  # gains as applied (smallest = 1)
    inside = (shifted.image < 0.8).all(axis=-1) & (base.image < 0.8).all(axis=-1)  # away from the highlight clip
    wb_float = float(np.median(np.abs(shifted.image.astype(np.float64) @ undo.T - ref)[inside]) * 255)
    raw_again = float(np.abs(redeveloped.image.astype(np.float64) - ref).max() * 255)
    shifted8 = quantise(shifted.image, bits=8).astype(np.float64)
    inside8 = inside & (shifted8 > 0).all(axis=-1) & (ref8 > 0).all(axis=-1)
    wb_8bit = float(np.abs(shifted8 @ undo.T - ref8)[inside8].mean())
    bright8 = quantise(bright.image, bits=8).astype(np.float64)
    clipped = (bright8 >= 255).any(axis=-1)
    undone = bright8 / 8.0
    dark8 = quantise(dark.image, bits=8).astype(np.float64)
    return {"wb_from_raw_error_levels": raw_again, "wb_from_image_median_error_levels": wb_float,
            "wb_from_8bit_file_mean_error_levels": wb_8bit,
            "bright_clipped_percent": 100 * float(clipped.mean()),
            "bright_error_unclipped_levels": float(np.abs(undone - ref8)[~clipped].mean()),
            "bright_error_clipped_levels": float(np.abs(undone - ref8)[clipped].mean()) if clipped.any() else 0.0,
            "levels_as_shot": float(len(np.unique(ref8))),
            "levels_dark_brightened": float(len(np.unique(np.clip(dark8 * 8.0, 0, 255)))),
            "dark_error_levels": float(np.abs(np.clip(dark8 * 8.0, 0, 255) - ref8).mean())}


def histograms(images: dict, path: Path) -> Path:
    from spectral_cam.viz import figure, save_png

    fig = figure(12, 2.8)
    axes = fig.subplots(1, len(images))
    for ax, (name, image) in zip(axes, images.items()):
        for c, colour in enumerate(("tab:red", "tab:green", "tab:blue")):
            ax.hist(image[..., c].ravel(), bins=64, range=(0, 255), color=colour, alpha=0.5, histtype="stepfilled")
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("8-bit value")
    return save_png(fig, path)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default=".", help="folder for isp_forensics.png")
    args = parser.parse_args(argv)
    base, shifted, bright, dark, redeveloped = develop_twice()
    result = analyse(base, shifted, bright, dark, redeveloped)
    for key, value in result.items():
        print(f"{key:>26}: {value:.3f}")
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    from spectral_cam.isp.encode import quantise

    print("wrote", histograms({name: quantise(image, bits=8) for name, image in (
        ("as shot", base.image), ("white balance off ±20 %", shifted.image), ("3 stops brighter", bright.image),
        ("3 stops darker", dark.image))}, out / "isp_forensics.png"))
    undoable = (result["wb_from_raw_error_levels"] == 0.0 and result["wb_from_image_median_error_levels"] < 2.0
                and result["bright_error_unclipped_levels"] < 1.0)
    lost = (result["bright_clipped_percent"] > 1.0
            and result["bright_error_clipped_levels"] > 10 * result["bright_error_unclipped_levels"]
            and result["levels_dark_brightened"] < result["levels_as_shot"] / 3)
    print("white balance undone (exactly from the RAW, approximately from the image) and unclipped exposure undone:",
          undoable, "| clipping and quantisation lost:", lost)
    return 0 if undoable and lost else 1


if __name__ == "__main__":
    raise SystemExit(main())
