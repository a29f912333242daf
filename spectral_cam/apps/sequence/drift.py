"""The drift study: a vegetation sequence over a day through a camera in auto and in locked
modes, and what the auto loops do to the plants' colour although the plants never change.

Per frame and mode, over the plant pixels (those nearer than the ground plane, from the render's
depth): the mean chromaticity of the developed 8-bit image, g = G/(R + G + B); the excess-green
index ExG = 2g − r − b (Woebbecke et al. 1995), the vegetation index crop-monitoring pipelines
threshold; ΔE2000 of the plants' mean colour against the noon frame (colour-science); and the
share of plant pixels "flagged" — ExG below the noon frame's 5th percentile, so 5 % at noon by
construction — the number a classifier trained at noon would see drift. The same indices are
also taken on the RAW (linear camera RGB of each 2 × 2 Bayer cell, balanced with the white the
frame was developed with): what a pipeline that records RAW sees, free of the tone curve.

References
----------
.. [1] Woebbecke, D. M., Meyer, G. E., Von Bargen, K., & Mortensen, D. A. (1995). Color indices
   for weed identification under various soil, residue, and lighting conditions. Transactions of
   the ASAE 38(1), 259–269.
.. [2] Sharma, G., Wu, W., & Dalal, E. N. (2005). The CIEDE2000 color-difference formula. Color
   Research & Application 30(1), 21–30.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Sequence

import numpy as np

__all__ = ["plant_mask", "drift_metrics", "plot_drift", "FLAG_PERCENTILE"]

#: ExG percentile of the noon frame's plants below which a plant pixel counts as flagged.
FLAG_PERCENTILE = 5.0


def plant_mask(config, depth_m: np.ndarray) -> np.ndarray:
    """Pixels nearer than the ground plane (by 0.1 %): the plants of a vegetation scene."""
    from ...optics import ThinLens
    from ...presets import outdoor

    lens = ThinLens.from_config(config.lens, config.sensor)
    height, width = depth_m.shape
    rows, columns = np.mgrid[0:height, 0:width] + 0.5
    scale = lens.pixel_pitch_m / lens.image_distance_m
    rays = np.stack([-(columns - width / 2) * scale, -(rows - height / 2) * scale, np.ones(depth_m.shape)], axis=-1)
    normal = outdoor.GroundView.from_config(config).rotation @ np.array([0.0, 0.0, 1.0])
    with np.errstate(divide="ignore"):
        plane = (normal @ np.array([0.0, 0.0, config.scene.distance_m])) / (rays @ normal)
    plane = np.where(plane > 0, plane, np.inf)
    return np.isfinite(depth_m) & (depth_m < plane * (1 - 1e-3))


def _chromaticities(image: np.ndarray) -> np.ndarray:
    rgb = image.astype(np.float64)
    return rgb / np.clip(rgb.sum(axis=-1, keepdims=True), 1e-9, None)


def drift_metrics(output: str | Path, modes: Sequence[str], noon_frame: int | None = None) -> dict:
    """Per mode, per frame: hour, g, ExG, ΔE2000 vs noon, flagged share, exposure and white."""
    import colour
    import cv2

    from ...raw import read_raw
    from ...scene import load_scene
    from .run import bayer_stats

    output = Path(output)
    frames = sorted((output / "render").iterdir())
    masks = []
    for folder in frames:
        config = load_scene(folder / "scene.toml")
        masks.append(plant_mask(config, np.load(folder / "radiance.npz")["depth"]))
    plants_in_view = config.scene.preset == "vegetation" and not config.scene.mitsuba_xml
    if not plants_in_view or not any(mask.any() for mask in masks):  # issue 25 #6: 4.5–6.25 % of nothing
        from ...errors import ConfigError

        raise ConfigError(f"--drift measures plants, and no frame of this sequence shows one (scene.preset = "
                          f"{config.scene.preset!r}): use the vegetation preset with scene.object_count > 0")
    truth = plant_truth(load_scene(frames[0] / "scene.toml"))
    noon = len(frames) // 2 if noon_frame is None else noon_frame
    result = {}
    for mode in modes:
        with (output / mode / "frames.csv").open() as handle:
            camera_rows = list(csv.DictReader(handle))
        images = [cv2.imread(str(output / mode / f.name / "image.png"))[..., ::-1] for f in frames]
        lab = []
        for image, mask in zip(images, masks):
            mean = image[mask].astype(np.float64).mean(axis=0) / 255.0
            lab.append(colour.XYZ_to_Lab(colour.sRGB_to_XYZ(mean)))
        raws, cells = [], []
        for f, mask, row in zip(frames, masks, camera_rows):
            stats = bayer_stats(read_raw(output / mode / f.name / "raw.dng"))
            white = np.array([float(row["white_r"]), 1.0, float(row["white_b"])])
            raws.append(stats / white)  # balanced as the frame was developed
            h, w = stats.shape[:2]
            cells.append(mask[:2 * h, :2 * w].reshape(h, 2, w, 2).all(axis=(1, 3)))
        threshold = np.percentile(_exg(images[noon], masks[noon]), FLAG_PERCENTILE)
        raw_threshold = np.percentile(_exg(raws[noon], cells[noon]), FLAG_PERCENTILE)
        health = None
        if truth is not None:  # per plant: ExG on the developed image and on the RAW cells
            owner, plants = truth
            unhealthy = np.array([p["state"] != "healthy" for p in plants])
            h, w = raws[0].shape[:2]
            owner_cells = owner[:2 * h:2, :2 * w:2]
            exg_dev = [_plant_exg(image, owner, len(plants)) for image in images]
            exg_raw = [_plant_exg(raw, owner_cells, len(plants)) for raw in raws]
            fit = min(HEALTH_FIT_FRAME, len(frames) - 1)
            health = (unhealthy, exg_dev, exg_raw, fit_threshold(exg_dev[fit], unhealthy),
                      fit_threshold(exg_raw[fit], unhealthy))
        rows = []
        for k, (image, mask, row) in enumerate(zip(images, masks, camera_rows)):
            chroma = _chromaticities(image[mask])
            exg = 2 * chroma[:, 1] - chroma[:, 0] - chroma[:, 2]
            exg_raw = _exg(raws[k], cells[k])
            rows.append({"frame": k, "hour": float(row["hour"]), "g": float(chroma[:, 1].mean()),
                         "exg": float(exg.mean()), "delta_e_vs_noon": float(colour.delta_E(lab[k], lab[noon],
                                                                                            method="CIE 2000")),
                         "flagged_percent": float(100.0 * np.mean(exg < threshold)),
                         "exg_raw": float(exg_raw.mean()),
                         "flagged_raw_percent": float(100.0 * np.mean(exg_raw < raw_threshold)),
                         "exposure_s": float(row["exposure_s"]), "iso": float(row["iso"]),
                         "white_r": float(row["white_r"]), "white_b": float(row["white_b"])})
            if health is not None:
                unhealthy, exg_dev, exg_raw, t_dev, t_raw = health
                flagged, accuracy = _classify(exg_dev[k], unhealthy, t_dev)
                flagged_raw, accuracy_raw = _classify(exg_raw[k], unhealthy, t_raw)
                rows[-1].update({"health_flagged_percent": flagged, "health_accuracy_percent": accuracy,
                                 "health_flagged_raw_percent": flagged_raw,
                                 "health_accuracy_raw_percent": accuracy_raw,
                                 "unhealthy_percent": float(100.0 * unhealthy[np.isfinite(exg_dev[k])].mean())})
        result[mode] = rows
    return result


#: The frame the health classifier is fitted on: the morning (the second frame of the day).
HEALTH_FIT_FRAME = 2
#: Plants smaller than this in the frame are not classified.
HEALTH_MIN_PIXELS = 6


def plant_truth(config) -> tuple[np.ndarray, list[dict]] | None:
    """Which plant each pixel shows and each plant's health record: the dataset's health label
    (:func:`spectral_cam.apps.dataset.labels.plant_map`) through the sequence's still camera."""
    from ...optics import ThinLens
    from ..dataset.labels import plant_map

    return plant_map(config, ThinLens.from_config(config.lens, config.sensor))


def _plant_exg(image, owner, count) -> np.ndarray:
    """Mean ExG of each plant's pixels (NaN where a plant has too few)."""
    values = np.full(count, np.nan)
    chroma = _chromaticities(image)
    exg = 2 * chroma[..., 1] - chroma[..., 0] - chroma[..., 2]
    for k in range(count):
        here = owner == k
        if here.sum() >= HEALTH_MIN_PIXELS:
            values[k] = exg[here].mean()
    return values


def fit_threshold(exg: np.ndarray, unhealthy: np.ndarray) -> float:
    """The ExG threshold (unhealthy below it) with the best balanced accuracy on one frame: the
    simplest vegetation-index classifier, fitted on labelled plants."""
    valid = np.isfinite(exg)
    values, truth = exg[valid], unhealthy[valid]
    best, best_score = float(np.median(values)), -1.0
    for t in np.unique(values):
        flagged = values <= t
        score = 0.5 * (np.mean(flagged[truth]) if truth.any() else 1.0) + \
            0.5 * (np.mean(~flagged[~truth]) if (~truth).any() else 1.0)
        if score > best_score:
            best, best_score = float(t), score
    return best


def _classify(exg, unhealthy, threshold) -> tuple[float, float]:
    """(flagged share %, accuracy %) of the plants with a value."""
    valid = np.isfinite(exg)
    flagged = exg[valid] <= threshold
    return float(100.0 * flagged.mean()), float(100.0 * np.mean(flagged == unhealthy[valid]))


def _exg(image, mask):
    chroma = _chromaticities(image[mask])
    return 2 * chroma[:, 1] - chroma[:, 0] - chroma[:, 2]


def write_drift(result: dict, output: str | Path) -> list[str]:
    """drift.csv (every mode's rows) and drift_summary.json (the spread over the day)."""
    output = Path(output)
    rows = [{"mode": mode, **row} for mode, table in result.items() for row in table]
    with (output / "drift.csv").open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: f"{v:.6g}" if isinstance(v, float) else v for k, v in row.items()})
    summary = {mode: {"flagged_percent_min": min(r["flagged_percent"] for r in table),
                      "flagged_percent_max": max(r["flagged_percent"] for r in table),
                      "flagged_raw_percent_min": min(r["flagged_raw_percent"] for r in table),
                      "flagged_raw_percent_max": max(r["flagged_raw_percent"] for r in table),
                      "delta_e_vs_noon_max": max(r["delta_e_vs_noon"] for r in table),
                      "exg_range": max(r["exg"] for r in table) - min(r["exg"] for r in table),
                      **_health_summary(table)}
               for mode, table in result.items()}
    (output / "drift_summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return ["drift.csv", "drift_summary.json"]


def _health_summary(table: list[dict]) -> dict:
    """The spread of the health classifier's flagged share and accuracy over the day."""
    if "health_accuracy_percent" not in table[0]:
        return {}
    out = {"unhealthy_percent": table[0]["unhealthy_percent"]}
    for key in ("health_flagged_percent", "health_accuracy_percent", "health_flagged_raw_percent",
                "health_accuracy_raw_percent"):
        out[f"{key}_min"] = min(r[key] for r in table)
        out[f"{key}_max"] = max(r[key] for r in table)
    return out


def plot_drift(result: dict, output: str | Path, *, strip_every: int = 1) -> list[str]:
    """drift.png (g, ExG, ΔE vs noon, flagged share, exposure and white against the hour, auto
    vs locked) and drift_strip.png (the frames of each mode side by side)."""
    import cv2

    from ...viz import figure, save_png

    output = Path(output)
    fig = figure(12, 7)
    axes = fig.subplots(2, 3).ravel()
    first = next(iter(result.values()))
    reference = first[len(first) // 2]["hour"]  # the reference ("noon") frame: the middle one
    panels = [("exg", "excess green 2g − r − b (developed image)"),
              ("delta_e_vs_noon", f"ΔE2000 of the plants vs the {reference:g} h frame"),
              ("flagged_percent", "plants flagged (%): developed image"),
              ("flagged_raw_percent", "plants flagged (%): RAW, linear"),
              ("exposure_s", "exposure time (s)"), ("white_b", "white B/G the ISP balanced for")]
    for ax, (key, title) in zip(axes, panels):
        for mode, table in result.items():
            ax.plot([r["hour"] for r in table], [r[key] for r in table], "o-", label=mode)
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("hour")
        if key == "exposure_s":
            ax.set_yscale("log")
        ax.legend(fontsize=7)
    fig.suptitle("The same plants over a day: auto exposure and white balance vs locked", fontsize=10)
    files = [save_png(fig, output / "drift.png").name]
    strips = []
    for mode in result:
        tiles = [cv2.imread(str(output / mode / f"{r['frame']:04d}" / "image.png")) for r in result[mode][::strip_every]]
        labelled = []
        for tile, row in zip(tiles, result[mode][::strip_every]):
            tile = cv2.resize(tile, (160, round(160 * tile.shape[0] / tile.shape[1])), interpolation=cv2.INTER_AREA)
            cv2.putText(tile, f"{mode} {row['hour']:.1f} h", (3, 12), cv2.FONT_HERSHEY_SIMPLEX, 0.35, (255, 255, 255), 1,
                        cv2.LINE_AA)
            labelled.append(tile)
        strips.append(np.hstack(labelled))
    cv2.imwrite(str(output / "drift_strip.png"), np.vstack(strips))
    files.append("drift_strip.png")
    return files
