"""What a camera's colour calibration scores in and out of sample, and what a DNG reader gets:
docs/validate/calibration.csv, calibration.png and the README / docs/design.md blocks between
``<!-- calibration:begin -->`` and ``<!-- calibration:end -->`` (the README's "Validating colour pipelines").

Two kinds of correction (white-balanced camera RGB → XYZ D65), each fitted on one training set (the
ColorChecker's 24 patches, or the 190 rawtoaces training reflectances) and scored noise-free on every set:

- fitted under the scene's own light (the ISP's ``fitted`` / ``root_polynomial``, which read them from the
  RAW's meta): a white-preserving 3 × 3 (``linear``), a degree-2 root-polynomial, and a camera profile — the
  3 × 3 as a DNG forward matrix followed by a hue/sat map — fitted under that light (``scene_profile``);
- what a DNG reader gets from our DNG's tags (issue 39 #21b): the colour matrices of D65 and Standard A
  blended by the white's CCT (``dng_matrix``, ``isp.colour_matrix = "dng"``), the camera profile of D65
  and A blended the same way (``dng_profile``, what our DNGs carried before and what a reader of DNG
  1.5 or older, RawTherapee's .dcp included, still gets), and the same plus the DNG 1.6 third
  calibration fitted under the scene's light when it is off the D65–A locus (``dng_profile_triple``:
  CalibrationIlluminant3 = 255 with IlluminantData3, ColorMatrix3, ForwardMatrix3,
  ProfileHueSatMapData3, weighted as the DNG SDK weighs three calibrations; our develop and DNG 1.6
  readers).

Scored with CIEDE2000 against each reflectance's CIE 1931 XYZ under the illuminant, Bradford-adapted to
D65. The camera responses, the XYZ and the ΔE are colour-science's own (``sd_to_XYZ``,
``chromatic_adaptation``, ``delta_E``), independent of the fits.

The hue/sat map's smoothness is chosen by 5-fold cross-validation on the rawtoaces training set
alone (both cameras, D65 and A): hue_sat_map_cv.csv.

    .venv/bin/python docs/make_calibration_figure.py
"""

from __future__ import annotations

import csv
from pathlib import Path

import colour
import numpy as np

from spectral_cam.isp.colour_correction import dng_camera_to_xyz_d65, dng_profile_camera_to_xyz_d65
from spectral_cam.raw import Calibration, RawImage
from spectral_cam.reflectance_sets import reflectance_set
from spectral_cam.sensor.colour_calibration import (
    camera_to_xyz_d65,
    fit_hue_sat_map,
    forward_matrix_d50,
    xyz_to_camera_matrix,
)
from spectral_cam.sensor.dng_colour import on_d65_a_locus
from spectral_cam.spectra import camera_sensitivities
from spectral_cam.viz import figure, save_png

ROOT = Path(__file__).resolve().parent.parent
HERE = ROOT / "docs" / "validate"
CAMERAS = ("nikon_d850", "sony_ilce_7m3")
#: D65 and A (the DNG's own calibrations), D50 (a daylight between them), and three lights off the D65–A
#: locus: cool-white and triband fluorescents and a phosphor LED.
ILLUMINANTS = ("D65", "A", "D50", "FL2", "FL11", "LED-B3")
TRAINING = ("colorchecker", "rawtoaces")
SCORED = ("colorchecker", "cie2017", "rawtoaces")
#: Corrections fitted under the scene's own light.
FITTED = ("linear", "root_polynomial", "scene_profile")
#: What a DNG reader gets from the DNG's tags.
READER = ("dng_matrix", "dng_profile", "dng_profile_triple")
METHODS = FITTED + READER
BEGIN, END = "<!-- calibration:begin -->", "<!-- calibration:end -->"
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


def _profile(camera, light: str, training, smoothness=None) -> dict:
    """A camera profile fitted under ``light`` on ``training``: ColorMatrix, ForwardMatrix, hue/sat map."""
    forward = forward_matrix_d50(camera, light, reflectances=training)
    kwargs = {} if smoothness is None else {"smoothness": smoothness}
    return {"color_matrix": xyz_to_camera_matrix(camera, light, reflectances=training), "forward_matrix": forward,
            "hue_sat_map": fit_hue_sat_map(camera, light, forward_matrix=forward, reflectances=training, **kwargs)}


def _profile_raw(profiles: list[dict], third: dict | None = None, light: str = "") -> RawImage:
    """A RawImage carrying one calibration, or D65 then A (and a third under ``light``), as read from a DNG."""
    tags = {f"{key}{suffix}": value for suffix, profile in zip(("", "_2"), profiles) for key, value in profile.items()}
    if third is not None:
        white = colour.sd_to_XYZ(colour.sd_ones(SHAPE), illuminant=_illuminant(light))
        tags["calibration_3"] = Calibration(light, tuple(colour.XYZ_to_xy(white)), **third)
    return RawImage(np.zeros((2, 2), np.uint16), "RGGB", 0.0, 4095, **tags)


def _correction(camera, light: str, method: str, training, smoothness=None, profiles=None):
    """White-balanced camera RGB (N, 3) → XYZ D65 by ``method``, fitted on ``training``; the ``neutral``
    (the camera's white under the light, max 1) is what a DNG's AsShotNeutral would hold."""
    if method in ("linear", "root_polynomial"):
        fitted = camera_to_xyz_d65(camera, light, method=method, reflectances=training)
        return (lambda rgb, neutral: rgb @ np.asarray(fitted).T) if method == "linear" else \
            (lambda rgb, neutral: fitted(rgb))
    profiles = profiles if profiles is not None else {}

    def fitted_under(name):
        if name not in profiles:
            profiles[name] = _profile(camera, name, training, smoothness)
        return profiles[name]

    if method == "scene_profile":
        raw = _profile_raw([fitted_under(light)])
    elif method == "dng_matrix":
        pair = [fitted_under("D65"), fitted_under("A")]
        return lambda rgb, neutral: rgb @ dng_camera_to_xyz_d65(pair[0]["color_matrix"], neutral,
                                                                color_matrix_2=pair[1]["color_matrix"]).T
    else:
        third = fitted_under(light) if method == "dng_profile_triple" and not on_d65_a_locus(light) else None
        raw = _profile_raw([fitted_under("D65"), fitted_under("A")], third, light)

    def apply(rgb, neutral):
        transform = dng_profile_camera_to_xyz_d65(raw, neutral)
        return rgb @ transform.T if isinstance(transform, np.ndarray) else transform(rgb)

    return apply


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
                    xyz = _correction(camera, name, "scene_profile", fit_on, value)(rgb[held], np.ones(3))
                    errors[value].extend(colour.delta_E(colour.XYZ_to_Lab(xyz, d65_xy), truth[held]))
    return [{"smoothness": value, "delta_e_mean": float(np.mean(errors[value]))} for value in SMOOTHNESS]


def _neutral(camera, illuminant) -> np.ndarray:
    """The camera's response to the light's white, max 1: a DNG's AsShotNeutral."""
    curves = camera_sensitivities(camera).to_colour().copy().align(SHAPE, extrapolator_kwargs={"method": "Constant",
                                                                                                "left": 0, "right": 0})
    white = illuminant.values @ curves.values
    return white / white.max()


def _scores(sets) -> list[dict]:
    d65_xy = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    rows = []
    for camera in CAMERAS:
        for name in ILLUMINANTS:
            illuminant, neutral = _illuminant(name), _neutral(camera, _illuminant(name))
            for training in TRAINING:
                profiles: dict = {}
                for method in METHODS:
                    correction = _correction(camera, name, method, sets[training], profiles=profiles)
                    for scored in SCORED:
                        xyz = correction(_camera_rgb(camera, illuminant, sets[scored]), neutral)
                        delta = colour.delta_E(colour.XYZ_to_Lab(xyz, d65_xy), _truth_lab(illuminant, sets[scored]),
                                               method="CIE 2000")
                        rows.append({"camera": camera, "illuminant": name, "training": training, "method": method,
                                     "path": "DNG reader" if method in READER else "fitted under the scene light",
                                     "scored": scored, "sample": "in" if scored == training else "out",
                                     "delta_e_mean": float(delta.mean()), "delta_e_p95": float(np.percentile(delta, 95)),
                                     "delta_e_max": float(delta.max())})
    return rows


def pooled(rows: list[dict], *, method: str, scored: str, illuminants=ILLUMINANTS, training: str = "rawtoaces"
           ) -> float:
    """Mean of the per-camera, per-light mean ΔE2000 (both cameras) of ``method`` fitted on ``training``."""
    return float(np.mean([float(r["delta_e_mean"]) for r in rows if r["method"] == method and r["scored"] == scored
                          and r["training"] == training and r["illuminant"] in illuminants]))


def block(rows: list[dict]) -> str:
    """The README / design.md block: out-of-sample mean ΔE2000 (fitted on rawtoaces, both cameras) of each
    path, per light and pooled, read from calibration.csv."""
    off = tuple(name for name in ILLUMINANTS if not on_d65_a_locus(name))
    lines = [BEGIN, "Out of sample (fitted on the rawtoaces training set; mean ΔE2000 of both cameras; "
             "`python docs/make_calibration_figure.py` writes [calibration.csv](docs/validate/calibration.csv) "
             "and this block). CIE 2017 / ColorChecker:", "",
             "| path | " + " | ".join(ILLUMINANTS) + f" | pooled | off the D65–A locus ({', '.join(off)}) |",
             "|---|" + "---|" * (len(ILLUMINANTS) + 2)]
    labels = {"linear": "3 × 3 fitted under the scene light (`fitted`)",
              "scene_profile": "camera profile fitted under the scene light",
              "dng_matrix": "DNG ColorMatrix, D65/A by CCT (`dng`)",
              "dng_profile": "DNG profile, D65/A by CCT (DNG ≤ 1.5 readers)",
              "dng_profile_triple": "DNG profile + third calibration (`dng_profile`; DNG 1.6 readers)"}
    for method, label in labels.items():
        cells = [f"{pooled(rows, method=method, scored='cie2017', illuminants=(name,)):.2f} / "
                 f"{pooled(rows, method=method, scored='colorchecker', illuminants=(name,)):.2f}" for name in ILLUMINANTS]
        for group in (ILLUMINANTS, off):
            cells.append(f"{pooled(rows, method=method, scored='cie2017', illuminants=group):.2f} / "
                         f"{pooled(rows, method=method, scored='colorchecker', illuminants=group):.2f}")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines += ["", "In and out of sample (all lights pooled; in sample: fitted and scored on the ColorChecker):", "",
              "| fitted under the scene light | on ColorChecker → ColorChecker | on rawtoaces → ColorChecker "
              "| on ColorChecker → CIE 2017 | on rawtoaces → CIE 2017 |", "|---|---|---|---|---|"]
    for method in FITTED:
        cells = [f"{pooled(rows, method=method, scored=scored, training=training):.2f}"
                 for scored in ("colorchecker", "cie2017") for training in ("colorchecker", "rawtoaces")]
        lines.append(f"| {labels.get(method, method.replace('_', '-'))} | " + " | ".join(cells) + " |")
    return "\n".join(lines + [END])


def _rewrite_block(path: Path, text: str) -> None:
    current = path.read_text(encoding="utf-8")
    start, end = current.index(BEGIN), current.index(END) + len(END)
    path.write_text(current[:start] + text + current[end:], encoding="utf-8")


def read_rows(path: Path = HERE / "calibration.csv") -> list[dict]:
    with open(path, newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def main() -> None:
    sets = {name: [sd.to_colour() if hasattr(sd, "to_colour") else sd for sd in reflectance_set(name).sds]
            for name in set(TRAINING) | set(SCORED)}
    rows = _scores(sets)
    HERE.mkdir(parents=True, exist_ok=True)
    with open(HERE / "calibration.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows({k: (f"{v:.4f}" if isinstance(v, float) else v) for k, v in row.items()} for row in rows)
    rows = read_rows()
    for document in (ROOT / "README.md", ROOT / "docs" / "design.md"):
        _rewrite_block(document, block(rows))

    cv = _cross_validation(sets["rawtoaces"])
    with open(HERE / "hue_sat_map_cv.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(cv[0]))
        writer.writeheader()
        writer.writerows({k: f"{v:.4f}" if k == "delta_e_mean" else f"{v:g}" for k, v in row.items()} for row in cv)

    _figure(rows)
    print(f"wrote {HERE / 'calibration.csv'}, calibration.png, hue_sat_map_cv.csv and the README/design.md blocks")


def _figure(rows: list[dict]) -> None:
    """Top: corrections fitted under the scene light, on each training set (hatched: in sample). Bottom:
    what a DNG reader gets (fitted on rawtoaces), against the profile fitted under the scene light."""
    fig = figure(15.0, 8.4)
    panels = ((FITTED, TRAINING), (("scene_profile",) + READER, ("rawtoaces",)))
    for row_index, (methods, trainings) in enumerate(panels):
        for index, scored in enumerate(SCORED):
            ax = fig.add_subplot(2, len(SCORED), row_index * len(SCORED) + index + 1)
            pairs = [(t, m) for t in trainings for m in methods]
            width = 0.8 / len(pairs)
            for k, (training, method) in enumerate(pairs):
                means = [pooled(rows, method=method, scored=scored, illuminants=(name,), training=training)
                         for name in ILLUMINANTS]
                colour_index = METHODS.index(method) + (len(METHODS) if training == "colorchecker" else 0)
                ax.bar(np.arange(len(ILLUMINANTS)) + (k - (len(pairs) - 1) / 2) * width, means, width,
                       label=f"fitted on {training}, {method.replace('_', ' ')}",
                       hatch="//" if training == scored else None, color=f"C{colour_index % 10}")
            ax.set_xticks(np.arange(len(ILLUMINANTS)), ILLUMINANTS)
            ax.set_title(f"scored on {scored}" + (" — DNG reader paths" if row_index else ""), fontsize=9)
            ax.set_ylabel("mean ΔE2000 (both cameras)" if index == 0 else "")
            ax.grid(axis="y", alpha=0.3)
            if index == len(SCORED) - 1:
                handles, names = ax.get_legend_handles_labels()
                ax.legend([plt_patch(h.patches[0].get_facecolor()) for h in handles], names, fontsize=6.5,
                          loc="upper right")
    fig.suptitle("Colour correction fitted on one set, scored on each (noise-free; hatched: in sample); bottom: "
                 "what a DNG reader gets from our DNG's tags", fontsize=10)
    save_png(fig, HERE / "calibration.png", dpi=110)


if __name__ == "__main__":
    main()
