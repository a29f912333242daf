"""What a camera's colour calibration scores in and out of sample: docs/validate/calibration.csv and
calibration.png (the README's "Validating colour pipelines").

Each correction (white-balanced camera RGB → XYZ D65: a white-preserving 3 × 3 matrix, a degree-2
root-polynomial, spectral_cam.sensor.colour_calibration.camera_to_xyz_d65, or the 3 × 3 as a DNG
forward matrix followed by a DNG hue/sat map, colour_calibration.fit_hue_sat_map, applied as the DNG
specification defines) is fitted on one
training set (the ColorChecker's 24 patches, or the 190 rawtoaces training reflectances) and scored
noise-free on every set: CIEDE2000 against each reflectance's CIE 1931 XYZ under the illuminant,
Bradford-adapted to D65. The camera responses, the XYZ and the ΔE are colour-science's own
(``sd_to_XYZ``, ``chromatic_adaptation``, ``delta_E``), independent of the fits.

The hue/sat map's smoothness is chosen by 5-fold cross-validation on the rawtoaces training set
alone (both cameras, D65 and A): hue_sat_map_cv.csv.

    .venv/bin/python docs/make_calibration_figure.py
"""

from __future__ import annotations

import csv
from pathlib import Path

import colour
import numpy as np

from spectral_cam.cie import D50_WHITE_XYZ, bradford_adaptation
from spectral_cam.isp.hue_sat_map import PROPHOTO_TO_XYZ_D50, XYZ_D50_TO_PROPHOTO, apply_hue_sat_map
from spectral_cam.reflectance_sets import reflectance_set
from spectral_cam.sensor.colour_calibration import camera_to_xyz_d65, fit_hue_sat_map, forward_matrix_d50
from spectral_cam.spectra import camera_sensitivities
from spectral_cam.viz import figure, save_png

HERE = Path(__file__).parent / "validate"
CAMERAS = ("nikon_d850", "sony_ilce_7m3")
ILLUMINANTS = ("D65", "A", "FL2", "LED-B3")
TRAINING = ("colorchecker", "rawtoaces")
SCORED = ("colorchecker", "cie2017", "rawtoaces")
METHODS = ("linear", "root_polynomial", "hue_sat_map")
#: Smoothness values the cross-validation tries (colour_calibration.HUE_SAT_MAP_SMOOTHNESS is its pick).
SMOOTHNESS = (0.03, 0.1, 0.3, 1.0, 3.0, 10.0)
FOLDS = 5
SHAPE = colour.SpectralShape(380, 780, 1)


def _illuminant(name: str):
    return colour.SDS_ILLUMINANTS[name].copy().align(SHAPE)


def _camera_rgb(camera, illuminant, sds) -> np.ndarray:
    """Camera responses ∫ρ·E·S dλ (colour-science's spectral arithmetic on 1 nm), white = 1."""
    curves = camera_sensitivities(camera).to_colour().copy().align(SHAPE, extrapolator_kwargs={"method": "Constant",
                                                                                                "left": 0, "right": 0})
    power = illuminant.values
    rho = np.stack([sd.copy().align(SHAPE).values for sd in sds])
    rgb = (rho * power) @ curves.values
    return rgb / (power @ curves.values)


def _truth_lab(illuminant, sds) -> np.ndarray:
    """CIELAB (D65) of the reflectances' XYZ under the illuminant, Bradford to D65."""
    xyz = np.stack([colour.sd_to_XYZ(sd.copy().align(SHAPE), illuminant=illuminant) for sd in sds]) / 100
    white = colour.sd_to_XYZ(colour.sd_ones(SHAPE), illuminant=illuminant) / 100
    d65 = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])
    adapted = colour.adaptation.chromatic_adaptation(xyz, white, d65, method="Von Kries", transform="Bradford")
    return colour.XYZ_to_Lab(adapted, colour.XYZ_to_xy(d65))


def plt_patch(colour_name: str):
    """A plain legend swatch (the hatching of in-sample bars is explained in the title)."""
    from matplotlib.patches import Patch

    return Patch(facecolor=colour_name)


def _correction(camera, illuminant, method, training, smoothness=None):
    """White-balanced camera RGB (N, 3) → XYZ D65, fitted on ``training``."""
    if method != "hue_sat_map":
        fitted = camera_to_xyz_d65(camera, illuminant, method=method, reflectances=training)
        return (lambda rgb: rgb @ np.asarray(fitted).T) if method == "linear" else fitted
    d65 = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])
    forward = forward_matrix_d50(camera, illuminant, reflectances=training)  # the DNG's ForwardMatrix
    kwargs = {} if smoothness is None else {"smoothness": smoothness}
    hue_sat = fit_hue_sat_map(camera, illuminant, forward_matrix=forward, reflectances=training, **kwargs)
    back = bradford_adaptation(D50_WHITE_XYZ, d65) @ PROPHOTO_TO_XYZ_D50
    return lambda rgb: apply_hue_sat_map(rgb @ (XYZ_D50_TO_PROPHOTO @ forward).T, hue_sat) @ back.T


def _cross_validation(training) -> list[dict]:
    """Mean ΔE2000 of each smoothness on held-out folds of the training set (both cameras, D65 and A)."""
    d65_xy = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    folds = np.arange(len(training)) % FOLDS
    errors = {value: [] for value in SMOOTHNESS}
    for camera in CAMERAS:
        for name in ("D65", "A"):
            illuminant = _illuminant(name)
            rgb, truth = _camera_rgb(camera, illuminant, training), _truth_lab(illuminant, training)
            for fold in range(FOLDS):
                fit_on = [sd for sd, f in zip(training, folds) if f != fold]
                held = folds == fold
                for value in SMOOTHNESS:
                    xyz = _correction(camera, name, "hue_sat_map", fit_on, value)(rgb[held])
                    errors[value].extend(colour.delta_E(colour.XYZ_to_Lab(xyz, d65_xy), truth[held]))
    return [{"smoothness": value, "delta_e_mean": float(np.mean(errors[value]))} for value in SMOOTHNESS]


def main() -> None:
    sets = {name: [sd.to_colour() if hasattr(sd, "to_colour") else sd for sd in reflectance_set(name).sds]
            for name in set(TRAINING) | set(SCORED)}
    d65_xy = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    rows = []
    for camera in CAMERAS:
        for name in ILLUMINANTS:
            illuminant = _illuminant(name)
            for training in TRAINING:
                for method in METHODS:
                    correction = _correction(camera, illuminant if method != "hue_sat_map" else name, method,
                                             sets[training])
                    for scored in SCORED:
                        rgb = _camera_rgb(camera, illuminant, sets[scored])
                        xyz = correction(rgb)
                        delta = colour.delta_E(colour.XYZ_to_Lab(xyz, d65_xy), _truth_lab(illuminant, sets[scored]),
                                               method="CIE 2000")
                        rows.append({"camera": camera, "illuminant": name, "training": training, "method": method,
                                     "scored": scored, "sample": "in" if scored == training else "out",
                                     "delta_e_mean": float(delta.mean()), "delta_e_p95": float(np.percentile(delta, 95)),
                                     "delta_e_max": float(delta.max())})
    HERE.mkdir(parents=True, exist_ok=True)
    with open(HERE / "calibration.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows({k: (f"{v:.4f}" if isinstance(v, float) else v) for k, v in row.items()} for row in rows)

    cv = _cross_validation(sets["rawtoaces"])
    with open(HERE / "hue_sat_map_cv.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(cv[0]))
        writer.writeheader()
        writer.writerows({k: f"{v:.4f}" if k == "delta_e_mean" else f"{v:g}" for k, v in row.items()} for row in cv)

    fig = figure(13.0, 4.6)
    for index, scored in enumerate(SCORED):
        ax = fig.add_subplot(1, len(SCORED), index + 1)
        labels, width = [], 0.8 / (len(TRAINING) * len(METHODS))
        for k, (training, method) in enumerate((t, m) for t in TRAINING for m in METHODS):
            means = [np.mean([r["delta_e_mean"] for r in rows if r["illuminant"] == name and r["training"] == training
                              and r["method"] == method and r["scored"] == scored]) for name in ILLUMINANTS]
            ax.bar(np.arange(len(ILLUMINANTS)) + (k - (len(TRAINING) * len(METHODS) - 1) / 2) * width, means, width,
                   label=f"fitted on {training}, {method.replace('_', '-')}", hatch="//" if training == scored else None,
                   color=f"C{k}")
            labels.append(training)
        ax.set_xticks(np.arange(len(ILLUMINANTS)), ILLUMINANTS)
        ax.set_title(f"scored on {scored}", fontsize=10)
        ax.set_ylabel("mean ΔE2000 (both cameras)" if index == 0 else "")
        ax.grid(axis="y", alpha=0.3)
    handles, names = fig.axes[0].get_legend_handles_labels()
    fig.legend([plt_patch(f"C{k}") for k in range(len(names))], names, loc="outside lower center",
               ncol=len(TRAINING) * len(METHODS) // 2, fontsize=8)
    fig.suptitle("Colour correction fitted on one set, scored on each (noise-free; hatched: in sample)", fontsize=10)
    save_png(fig, HERE / "calibration.png", dpi=110)
    print(f"wrote {HERE / 'calibration.csv'}, calibration.png and hue_sat_map_cv.csv")


if __name__ == "__main__":
    main()
