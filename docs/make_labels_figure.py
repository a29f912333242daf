"""One dataset item's labels side by side, as docs/dataset_labels.png (the README's "Datasets"):
the bundled tabletop (sun and sky, 8 mm at f/8 focused on object 0, 1/500 s at ISO 100: sunny-16
exposure) with object 0 moving left at 3 m/s, written by the dataset's own item writer, then each label drawn from its
file through the package's loader.

    .venv/bin/python docs/make_labels_figure.py
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import cv2
import numpy as np

from spectral_cam import load_scene
from spectral_cam.apps.dataset import read_item, write_item
from spectral_cam.viz import figure, save_png

HERE = Path(__file__).parent
OUTPUTS = ["image", "depth", "defocus", "segmentation", "coverage", "flow", "clean_rgb", "albedo", "illuminant_map",
           "camera"]


def _flow_colours(flow: np.ndarray) -> np.ndarray:
    """Flow as the usual colour wheel: hue the direction, value the length (largest = 1)."""
    length = np.hypot(flow[..., 0], flow[..., 1])
    hsv = np.zeros(flow.shape[:2] + (3,), np.uint8)
    hsv[..., 0] = (np.degrees(np.arctan2(flow[..., 1], flow[..., 0])) % 360 / 2).astype(np.uint8)
    hsv[..., 1] = 255
    hsv[..., 2] = np.clip(255 * length / max(float(length.max()), 1e-9), 0, 255).astype(np.uint8)
    return cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)


def _instance_colours(ids: np.ndarray) -> np.ndarray:
    rng = np.random.default_rng(3)
    palette = rng.integers(40, 255, (int(ids.max()) + 1, 3), dtype=np.uint8)
    palette[0] = 0
    return palette[ids]


def _soft_instances(ids: np.ndarray, coverage: np.ndarray) -> np.ndarray:
    """The coverage label as colour: each pixel's instances' colours mixed by their fractions."""
    rng = np.random.default_rng(3)
    palette = rng.integers(40, 255, (int(ids.max()) + 1, 3), dtype=np.uint8).astype(np.float64)
    palette[0] = 0
    mixed = (palette[ids] * coverage[..., None]).sum(axis=2)
    return np.clip(mixed, 0, 255).astype(np.uint8)


def _clipped(values: np.ndarray) -> np.ndarray:
    """Values clipped to their 1st–99th percentiles (a few specular pixels set no scale)."""
    low, high = np.nanpercentile(values, [1, 99])
    return np.clip(values, low, high)


def _display(rgb: np.ndarray) -> np.ndarray:
    """Linear RGB for the eye: scaled to its 99.5th percentile, gamma 1/2.2."""
    return np.clip(rgb / max(float(np.percentile(rgb, 99.5)), 1e-9), 0, 1) ** (1 / 2.2)


def main() -> None:
    config = load_scene(HERE.parent / "scenes" / "tabletop.toml",
                        overrides={"sensor.width_px": 360, "sensor.height_px": 240, "render.spp": 32,
                                   "lens.f_number": 8.0, "exposure.time_s": 1 / 500,
                                   "motion.object": "object_0", "motion.object_velocity_mps": [3.0, 0.0, 0.0]})
    with tempfile.TemporaryDirectory() as folder:
        write_item(config, Path(folder) / "item", outputs=OUTPUTS)
        item = read_item(Path(folder) / "item")
    flow = item["flow"]
    lights = [light["name"] for light in item["meta"]["illuminant_map"]["lights"]]
    sun = lights.index("sky.sun")
    illuminant = item["illuminant_map"]
    panels = [
        ("image.png (sRGB)", item["image"], None),
        ("depth.exr (m)", np.where(np.isfinite(item["depth"]), item["depth"], np.nan), "viridis"),
        ("defocus.exr: signed CoC (px)", item["defocus"], "coolwarm"),
        ("segmentation.png: instances", _instance_colours(item["segmentation"]), None),
        ("coverage.exr: instances under defocus", _soft_instances(item["coverage"], item["coverage_fraction"]), None),
        (f"flow.exr: over the exposure (largest {np.hypot(flow[..., 0], flow[..., 1]).max():.1f} px)",
         _flow_colours(flow), None),
        ("clean_rgb.exr: noise-free camera RGB", _display(item["clean_rgb"]), None),
        ("albedo.exr: reflectance, linear sRGB", np.clip(item["albedo_srgb"], 0, 1) ** (1 / 2.2), None),
        ("shading.exr: illuminance (klux)", item["illuminance_lux"] / 1e3, "gray"),
        ("illuminant_map.exr: the light's B/G (camera)", _clipped(np.where(illuminant[..., 1] > 0, illuminant[..., 2],
                                                                           np.nan)), "coolwarm_r"),
        ("illuminant_map.exr: the sun's share", item["light_shares"][..., sun], "magma"),
        ("clean RGB / illuminant: balanced per pixel",
         _display(item["clean_rgb"] / np.where(illuminant > 0, illuminant, np.inf)), None),
    ]
    fig = figure(13.0, 7.6)
    for index, (title, data, cmap) in enumerate(panels):
        ax = fig.add_subplot(3, 4, index + 1)
        shown = ax.imshow(data, cmap=cmap)
        if cmap is not None:
            fig.colorbar(shown, ax=ax, fraction=0.035)
        ax.set_title(title, fontsize=8.5)
        ax.set_axis_off()
    k = item["camera"]["K"]
    fig.suptitle(f"One dataset item's labels (tabletop, f/8, 1/500 s, object 0 moving at 3 m/s; camera.json: "
                 f"fx = {k[0, 0]:.0f} px, cx = {k[0, 2]:.1f}, cy = {k[1, 2]:.1f})", fontsize=10)
    save_png(fig, HERE / "dataset_labels.png", dpi=110)
    print(f"wrote {HERE / 'dataset_labels.png'}")


if __name__ == "__main__":
    main()
