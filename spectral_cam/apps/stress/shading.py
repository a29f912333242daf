"""Study (i): lens and colour shading against the chief-ray angle, and where a flat-field table fails.

Noise-free RGGB flat fields (grey D65 reflector) behind thin lenses whose corner chief ray arrives at
5° … 35°, pixels accepting A_c(θ) = 2^(−(θ/θ½,c)²) with θ½ = 18°, 22°, 26° (R, G, B: red spreads
most into the neighbours): the corner's relative illumination per channel against cos⁴θ·A_c(θ), and
its tint R/G. A lens-shading table calibrated on one lens (corner 20°) corrects that lens to flat and
leaves the others shaded or over-corrected — why a zoom phone stores a table per focal length.

References
----------
.. [1] Catrysse & Wandell (2002), JOSA A 19(8) (pixel acceptance); Android camera2,
   STATISTICS_LENS_SHADING_CORRECTION_MAP.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .settings import StressSettings
from .summary import summary_row

__all__ = ["shading_study", "plot_shading", "STUDY_CORNER_DEG", "STUDY_HALVES_DEG"]

#: Corner chief-ray angles of the study's lenses (degrees), and the pixels' half-response angles (R, G, B).
STUDY_CORNER_DEG = (5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0)
STUDY_HALVES_DEG = (18.0, 22.0, 26.0)
CALIBRATED_DEG = 20.0
_SHAPE, _PITCH_UM = (64, 96), 6.0


def _flat(corner_deg: float):
    """A noise-free RGGB flat field behind the lens whose corner pixel centre sees ``corner_deg``."""
    import spectral_cam as sc
    from spectral_cam.radiance_targets import lambertian_radiance, uniform_image

    h, w = _SHAPE
    corner_m = math.hypot(w / 2 - 0.5, h / 2 - 0.5) * _PITCH_UM * 1e-6
    focal_mm = corner_m / math.tan(math.radians(corner_deg)) * 1e3
    scene = sc.scene_from_dict({
        "sensor": {"width_px": w, "height_px": h, "crop_margin_px": 0, "pixel_pitch_um": _PITCH_UM,
                   "angular_response_deg": list(STUDY_HALVES_DEG), "shot_noise": False, "read_noise_e": 0.0,
                   "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0, "bit_depth": 16},
        "lens": {"focal_length_mm": focal_mm, "focus_distance_m": 1e6}, "exposure": {"time_s": 0.004},
        "illuminant": {"spd": "D65"}})
    radiance = uniform_image(lambertian_radiance("D65", [0.5])[0], (h, w))
    return sc.expose(radiance, scene)


def _corner_ratios(raw) -> np.ndarray:
    """(3,) each channel's corner pixel over the same channel at the centre (RGGB sites)."""
    h, w = raw.mosaic.shape
    net = raw.mosaic.astype(float) - float(np.mean(raw.black_level))
    sites = ((0, 0), (0, 1), (1, 1))  # R, G, B of RGGB
    return np.array([net[r, c] / net[h // 2 + r, w // 2 + c] for r, c in sites])


def _non_flatness(raw, table) -> float:
    """max/min − 1 of each channel's corrected flat, the worst channel."""
    from ...cfa import channel_index
    from ...isp.normalise import normalise
    from ...isp.shading import correct_shading

    mosaic = correct_shading(normalise(raw.mosaic, black_level=raw.black_level, white_level=raw.white_level),
                             raw.cfa, table)
    index = channel_index(mosaic.shape, raw.cfa)
    return float(max(mosaic[index == c].max() / mosaic[index == c].min() - 1.0 for c in range(3)))


def shading_study(settings: StressSettings) -> dict:
    """Corner relative illumination and tint against the chief-ray angle; a fixed table's residual."""
    from ...isp.shading import calibrate_flat_field

    table = calibrate_flat_field(_flat(CALIBRATED_DEG))
    data = {"corner_deg": list(STUDY_CORNER_DEG), "halves_deg": list(STUDY_HALVES_DEG),
            "calibrated_deg": CALIBRATED_DEG, "measured": [], "analytic": [], "tint_rg": [], "residual_fixed": [],
            "residual_own": []}
    rows = []
    h, w = _SHAPE
    for corner in STUDY_CORNER_DEG:
        raw = _flat(corner)
        ratios = _corner_ratios(raw)
        # the analytic ratio of the two pixel centres (corner and centre sites) per channel
        v = math.hypot(w / 2 - 0.5, h / 2 - 0.5) / math.tan(math.radians(corner))  # image distance in pixels
        analytic = []
        for (r, c), half in zip(((0, 0), (0, 1), (1, 1)), STUDY_HALVES_DEG):
            t0 = math.atan(math.hypot(c + 0.5 - w / 2, r + 0.5 - h / 2) / v)
            t1 = math.atan(math.hypot(w // 2 + c + 0.5 - w / 2, h // 2 + r + 0.5 - h / 2) / v)
            analytic.append(math.cos(t0) ** 4 * 2 ** -(math.degrees(t0) / half) ** 2
                            / (math.cos(t1) ** 4 * 2 ** -(math.degrees(t1) / half) ** 2))
        data["measured"].append(ratios.tolist())
        data["analytic"].append(analytic)
        data["tint_rg"].append(float(ratios[0] / ratios[1]))
        data["residual_fixed"].append(_non_flatness(raw, table))
        data["residual_own"].append(_non_flatness(raw, calibrate_flat_field(raw)))
        rows.append(summary_row("shading", f"corner at {corner:g}°", "green corner / centre", ratios[1], "ratio",
                                f"cos⁴·A analytic {analytic[1]:.4f}"))
        rows.append(summary_row("shading", f"corner at {corner:g}°", "corner R/G (colour shading)",
                                ratios[0] / ratios[1], "ratio"))
        rows.append(summary_row("shading", f"corner at {corner:g}°",
                                f"non-flatness with the {CALIBRATED_DEG:g}° lens's table", data["residual_fixed"][-1],
                                "max/min − 1", f"own table: {data['residual_own'][-1]:.2e}"))
    return {"rows": rows, "data": data}


def plot_shading(result: dict, directory: Path) -> list[str]:
    """shading_corners.png: corner relative illumination per channel (measured, analytic) and tint;
    the residual of a table calibrated on another lens."""
    from ...viz import figure, save_png

    data = result["data"]
    angles = data["corner_deg"]
    fig = figure(11.0, 4.0)
    ax1, ax2 = fig.subplots(1, 2)
    for c, (name, colour) in enumerate(zip("RGB", ("tab:red", "tab:green", "tab:blue"))):
        ax1.plot(angles, [m[c] for m in data["measured"]], "o", color=colour, label=f"{name} measured")
        ax1.plot(angles, [a[c] for a in data["analytic"]], "-", color=colour, alpha=0.6,
                 label=f"{name}: cos⁴θ·2^-(θ/{data['halves_deg'][c]:g}°)²")
    ax1.plot(angles, data["tint_rg"], "k--", label="R/G at the corner")
    ax1.set_xlabel("corner chief-ray angle (°)")
    ax1.set_ylabel("corner / centre")
    ax1.set_title("Lens and colour shading")
    ax1.grid(alpha=0.3)
    ax1.legend(fontsize=7)
    ax2.semilogy(angles, np.maximum(data["residual_fixed"], 1e-5), "o-", label=f"table of the {data['calibrated_deg']:g}° lens")
    ax2.semilogy(angles, np.maximum(data["residual_own"], 1e-5), "s-", label="each lens's own table")
    ax2.axhline(0.01, color="grey", linestyle=":", label="1 %")
    ax2.set_xlabel("corner chief-ray angle (°)")
    ax2.set_ylabel("corrected flat: max/min − 1")
    ax2.set_title("Where a flat-field table fails")
    ax2.grid(alpha=0.3, which="both")
    ax2.legend(fontsize=7)
    save_png(fig, directory / "shading_corners.png", dpi=100)
    return ["shading_corners.png"]
