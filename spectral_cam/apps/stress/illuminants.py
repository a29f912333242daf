"""Study (e): colour far from the D65 calibration.

A synthetic ColorChecker under illuminants far from the D65 calibration (tungsten A, FL11,
LED-B1, LED-RGB1 and a generated narrow-band RGB LED): ΔE2000 of the DNG matrix and of the
fitted matrix for the white-balance choices as_shot, grey_world and white_patch.

References
----------
.. [1] CIE 15:2004 and CIE 015:2018, Colorimetry (illuminants A, FL11; LED series);
   Sharma, G., Wu, W., & Dalal, E. N. (2005). The CIEDE2000 colour-difference formula.
   Color Res. Appl. 30(1), 21–30.
.. [2] docs/design.md, "Ground truth and metrics" (the one ground truth, the white patch).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from ...records import write_csv
from ...viz import figure, save_png
from .settings import STUDY_CAMERA, StressSettings
from .summary import summary_row

__all__ = ["STUDY_ILLUMINANTS", "NARROW_LED_PEAKS_NM", "NARROW_LED_FWHM_NM", "STUDY_WHITE_BALANCE",
           "STUDY_COLOUR_MATRICES", "PATCH_MARGIN", "write_narrow_band_led", "illuminant_study",
           "plot_illuminants"]

#: Illuminants of the illuminant study (besides the generated narrow-band LED).
STUDY_ILLUMINANTS = ("D65", "A", "FL11", "LED-B1", "LED-RGB1")
#: Peak wavelengths (nm) and FWHM (nm) of the generated narrow-band RGB LED.
NARROW_LED_PEAKS_NM = (450.0, 530.0, 630.0)
NARROW_LED_FWHM_NM = 15.0
#: Fraction of a patch's side left out on each side of its statistics (the middle half).
PATCH_MARGIN = 0.25
#: White-balance choices and colour-matrix sources of the illuminant study.
STUDY_WHITE_BALANCE = ("as_shot", "grey_world", "white_patch")
STUDY_COLOUR_MATRICES = ("dng_d65", "dng", "fitted")


def write_narrow_band_led(path: Path, *, peaks_nm=NARROW_LED_PEAKS_NM, fwhm_nm: float = NARROW_LED_FWHM_NM) -> Path:
    """Write a narrow-band RGB LED spectrum (Gaussian peaks of equal height) as a CSV
    ``wavelength_nm,value`` on 1-nm steps, 360–830 nm.

    Parameters
    ----------
    path
        Output CSV file.
    peaks_nm
        Peak wavelengths, nm.
    fwhm_nm
        Full width at half maximum of each peak, nm.

    Returns
    -------
    pathlib.Path

    References
    ----------
    .. [1] Schubert, E. F. (2006). Light-Emitting Diodes, 2nd ed., ch. 12 (LED emission
       spectra, ≈ Gaussian of 20–30 nm FWHM for direct-gap emitters).
    """
    wavelengths = np.arange(360.0, 831.0, 1.0)
    sigma = fwhm_nm / (2.0 * math.sqrt(2.0 * math.log(2.0)))
    values = sum(np.exp(-0.5 * ((wavelengths - peak) / sigma) ** 2) for peak in peaks_nm)
    rows = [{"wavelength_nm": f"{w:g}", "value": f"{v:.6g}"} for w, v in zip(wavelengths, values)]
    return write_csv(rows, path, ("wavelength_nm", "value"))


def illuminant_study(settings: StressSettings, *, directory: Path | None = None, illuminants=None) -> dict:
    """ΔE2000 of the colour pipeline under illuminants far from the D65 calibration (study (e)).

    A synthetic ColorChecker (:func:`spectral_cam.radiance_targets.synthetic_chart`: 6 × 4 patches of
    ``patch_px`` pixels of radiance ρ·E/π, no gaps) is exposed by the ``nikon_d850`` sensor
    (ISO 100, all noise terms on, white patch at 0.8 of saturation), developed with each
    white balance of :data:`STUDY_WHITE_BALANCE` and each colour matrix of
    :data:`STUDY_COLOUR_MATRICES` — ``"dng_d65"``: the D65-calibrated ColorMatrix1 alone
    (what LibRaw uses) with a Bradford adaptation from the white-balance neutral; ``"dng"``:
    ColorMatrix1 and ColorMatrix2 (Standard A) interpolated by the white's CCT;
    ``"fitted"``: the 3×3 matrix fitted under the scene illuminant — tone curve off, and compared per patch with the analytic
    ground truth (:func:`spectral_cam.colour_ground_truth.patch_linear_srgb`), exposure matched on
    the white patch.

    Parameters
    ----------
    settings
        ``patch_px`` and the seed.
    directory
        Where the generated narrow-band LED CSV is written (default: not used).
    illuminants
        Names or CSV paths; default :data:`STUDY_ILLUMINANTS` plus the generated LED.

    Returns
    -------
    dict
        ``rows`` and ``data``: per illuminant, matrix and white balance the ΔE2000 per patch,
        mean and max; the white-balance gains.

    References
    ----------
    .. [1] Sharma, Wu & Dalal (2005), Color Res. Appl. 30(1), 21–30 (CIEDE2000).
    .. [2] Buchsbaum (1980) (grey world); Land & McCann (1971) (white patch).
    .. [3] Adobe (2023), DNG Specification 1.7.1.0, ch. 6 (ColorMatrix, AsShotNeutral).
    """
    from ... import colour_ground_truth
    from ... import sensor as S
    from ...radiance_targets import reflectance_set, synthetic_chart
    from ...isp import ISPConfig, develop
    from ...metrics import delta_e2000, patch_means
    from ...scene import scene_from_dict

    names = list(STUDY_ILLUMINANTS) if illuminants is None else list(illuminants)
    labels = {name: name for name in names}
    if illuminants is None and directory is not None:
        led = write_narrow_band_led(Path(directory) / "narrowband_rgb_led.csv")
        names.append(str(led))
        labels[str(led)] = (f"RGB LED {'/'.join(f'{p:g}' for p in NARROW_LED_PEAKS_NM)} nm, "
                            f"{NARROW_LED_FWHM_NM:g} nm FWHM (CSV)")
    patch = settings.patch_px
    rows: list[dict] = []
    data: dict = {"illuminants": {}, "camera": STUDY_CAMERA}
    colorchecker = reflectance_set("colorchecker")
    for i_index, illuminant in enumerate(names):
        chart = synthetic_chart(colorchecker, illuminant, patch_px=patch, gap_px=0)
        height, width = chart.radiance.data.shape[:2]
        config = scene_from_dict({"illuminant": {"spd": illuminant},
                                  "sensor": {"model": STUDY_CAMERA, "width_px": width, "height_px": height,
                                             "vignetting": False},
                                  "exposure": {"time_s": "auto", "auto_fraction": 0.8, "metering": "etr"}})
        white = np.zeros((height, width), bool)
        white[chart.patches[chart.white_index].interior(PATCH_MARGIN)] = True
        raw = S.expose(chart.radiance, config, white_mask=white, frame_seed=settings.seed_for(10, i_index))
        reference = colour_ground_truth.patch_linear_srgb(illuminant, chart.sds[:chart.n_set])
        entry: dict = {"label": labels[illuminant], "results": {}}
        d65_only = dataclasses.replace(raw, color_matrix_2=None)
        for matrix in STUDY_COLOUR_MATRICES:
            source = d65_only if matrix == "dng_d65" else raw
            for balance in STUDY_WHITE_BALANCE:
                developed = develop(source, ISPConfig(white_balance=balance, colour_matrix=matrix.replace("_d65", ""),
                                                      tone="linear", highlights="none"))
                means = patch_means(developed.linear, chart.patches[:chart.n_set], margin=PATCH_MARGIN)
                delta = delta_e2000(means, reference, exposure_match_index=chart.white_index)
                entry["results"][f"{matrix}/{balance}"] = {
                    "delta_e": delta.tolist(), "mean": float(delta.mean()), "max": float(delta.max()),
                    "gains": developed.meta["white_balance_gains"]}
                rows.append(summary_row("illuminants", f"{labels[illuminant]}", f"mean ΔE2000, {matrix} matrix, {balance}",
                                        float(delta.mean()), "ΔE00", f"max {delta.max():.2f}"))
        data["illuminants"][labels[illuminant]] = entry
    return {"rows": rows, "data": data}


def plot_illuminants(result: dict, directory: Path) -> list[str]:
    """Figure of :func:`illuminant_study`: mean (bars) and max (ticks) ΔE2000 per illuminant,
    colour matrix and white balance."""
    data = result["data"]["illuminants"]
    labels = list(data)
    combos = list(next(iter(data.values()))["results"])
    fig = figure(max(9, 1.6 * len(labels) + 3), 4.6)
    ax = fig.subplots()
    width = 0.8 / len(combos)
    x = np.arange(len(labels))
    for k, combo in enumerate(combos):
        means = [data[label]["results"][combo]["mean"] for label in labels]
        maxima = [data[label]["results"][combo]["max"] for label in labels]
        bars = ax.bar(x + (k - (len(combos) - 1) / 2) * width, means, width, label=combo)
        ax.scatter(x + (k - (len(combos) - 1) / 2) * width, maxima, marker="_", s=60,
                   color=bars.patches[0].get_facecolor(), zorder=3)
    ax.set_xticks(x, [label if len(label) < 24 else label[:22] + "…" for label in labels], fontsize=8)
    ax.set_ylabel("ΔE2000 over the 24 patches (bar: mean, tick: max)")
    ax.axhline(2.0, color="k", lw=0.6, ls="--")
    ax.set_title(f"Colour error far from the D65 calibration ({result['data']['camera']}, tone curve off)", fontsize=10)
    ax.legend(fontsize=7, ncol=2)
    return [save_png(fig, Path(directory) / "illuminants_delta_e.png").name]
