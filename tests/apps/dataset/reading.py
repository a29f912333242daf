"""Reading a dataset folder in tests: EXR channels, PNGs, the manifest, item pixels."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np


def read_exr(path: Path) -> dict[str, np.ndarray]:
    """Every channel of an EXR file by name (R, G, B split out of the bindings' "RGB")."""
    import OpenEXR

    out = {}
    with OpenEXR.File(str(path)) as exr:
        for name, channel in exr.channels().items():
            pixels = np.array(channel.pixels)
            if pixels.ndim == 3:  # the bindings group R, G, B (and A) into one "RGB" entry
                out.update({letter: pixels[..., i] for i, letter in enumerate(name)})
            else:
                out[name] = pixels
    return out


def read_png(path: Path) -> np.ndarray:
    import cv2

    return cv2.imread(str(path), cv2.IMREAD_UNCHANGED)


def read_manifest(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "manifest.jsonl").read_text().splitlines()]


def without_timings(value):
    """meta.json minus what legitimately changes between runs: timings."""
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items()
                if "timing" not in k and not k.endswith("_cpu_s")}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def item_pixels(item: Path) -> dict[str, np.ndarray]:
    """The pixels of every file of an item folder (RAW, images, EXR channels)."""
    import tifffile  # LibRaw refuses frames under 22 px high, so read the DNG's CFA page directly

    out = {"raw": tifffile.imread(item / "raw.dng"), "image": read_png(item / "image.png"),
           "all_in_focus": read_png(item / "all_in_focus.png")}
    for name in ("radiance", "depth", "defocus", "clean_rgb"):
        for channel, pixels in read_exr(item / f"{name}.exr").items():
            out[f"{name}/{channel}"] = pixels
    return out
