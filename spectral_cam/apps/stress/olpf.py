"""Study (g): false colour and sharpness against the optical low-pass filter's strength, per CFA and
demosaic.

A neutral zone plate (grey D65 reflector, local frequency 0 … 0.5 cycle per pixel) is exposed
noise-free through an RGGB, an X-Trans, a Quad Bayer and an RGBW sensor behind a four-spot filter of spot
separation d (0 = none … 1.5 pitch) and developed by each demosaic that takes the tile. Every colour in the result is false: the
false colour per frequency ring is the mean chroma (max − min channel) over the mean level; the
sharpness the filter costs is the zone plate's luminance modulation kept at 0.25 cycle per pixel,
against its analytic |sinc(f)|·|H_d(f)|² (pixel aperture, filter in x and y; the demosaic adds
its own loss). H_d is the filter as applied to pixels (:func:`spectral_cam.sensor.olpf.olpf_kernel_mtf`):
|cos(π f d)| at a whole-pitch d, and below it at a fractional one, whose displaced spot is shared by
area between two pixels.

References
----------
.. [1] Greivenkamp (1990), Appl. Opt. 29(5), 676–684 (the four-spot filter).
.. [2] Li, Gunturk & Zhang (2008), Proc. SPIE 6822 (false colour of demosaicing on zone plates).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .demosaic import DEMOSAIC_BORDER_PX, zone_plate
from .settings import StressSettings
from .summary import summary_row

__all__ = ["olpf_study", "plot_olpf", "STUDY_SEPARATIONS", "olpf_capture"]

#: Spot separations of the study, pixel pitches.
STUDY_SEPARATIONS = (0.0, 0.5, 0.75, 1.0, 1.25, 1.5)
#: The frequency whose kept modulation measures what the filter costs (cycles per pixel).
SHARPNESS_FREQUENCY = 0.25


def olpf_capture(pattern: np.ndarray, separation_px: float, cfa: str = "RGGB"):
    """A noise-free capture through ``cfa`` of a grey D65 reflector modulated by ``pattern`` (0 … 1)."""
    import spectral_cam as sc
    from spectral_cam.image import SpectralImage
    from spectral_cam.radiance_targets import lambertian_radiance, uniform_image

    h, w = pattern.shape
    grey = uniform_image(lambertian_radiance("D65", [0.5])[0], (h, w))
    data = grey.data * (0.05 + 0.9 * pattern[..., None]).astype(np.float32)
    scene = sc.scene_from_dict({
        "sensor": {"width_px": w, "height_px": h, "olpf": float(separation_px), "cfa": cfa, "shot_noise": False,
                   "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0,
                   "vignetting": False, "bit_depth": 14},
        "exposure": {"time_s": "auto"}, "illuminant": {"spd": "D65"}})
    return sc.expose(SpectralImage(data, grey.wavelengths_nm, grey.band_edges_nm), scene)


def olpf_study(settings: StressSettings, *, methods=None) -> dict:
    """False colour and kept modulation against spot separation, per demosaic (study (g)).

    Returns
    -------
    dict
        ``rows`` and ``data``: the separations, frequency-ring edges, and per method the false
        colour per ring and overall, and the modulation kept at :data:`SHARPNESS_FREQUENCY`;
        ``crops`` for the figure.
    """
    from ...isp import ISPConfig, develop
    from ...isp.demosaic import CFA_METHODS, bayer_methods

    cases = [("RGGB", m) for m in (bayer_methods() if methods is None else methods)]
    if methods is None:
        cases += [(cfa, m) for cfa, names in CFA_METHODS.items() for m in names if m != "colour_difference"
                  or cfa == "XTRANS"]
    plate, frequency = zone_plate(settings.zone_plate_px, max_frequency=0.5)
    edges = np.linspace(0.0, 0.5, settings.frequency_bins + 1)
    ring_of = np.digitize(frequency, edges) - 1
    b = DEMOSAIC_BORDER_PX
    inner = np.zeros(plate.shape, bool)
    inner[b:-b, b:-b] = True
    near = inner & (np.abs(frequency - SHARPNESS_FREQUENCY) < 0.02)
    data = {"separations_px": list(STUDY_SEPARATIONS), "frequency_edges": [float(e) for e in edges],
            "sharpness_frequency": SHARPNESS_FREQUENCY, "methods": {}}
    crops, rows = {}, []
    for cfa, method in cases:
        label = method if cfa == "RGGB" else f"{cfa} {method}"
        entry = {"cfa": cfa, "false_colour": [], "false_colour_per_ring": [], "modulation_kept": []}
        for separation in STUDY_SEPARATIONS:
            raw = olpf_capture(plate, separation, cfa)
            rgb = develop(raw, ISPConfig(demosaic=method, tone="linear", white_balance="as_shot")).linear
            rgb = np.asarray(rgb, dtype=float)
            level = rgb[inner].mean()
            chroma = (rgb.max(axis=-1) - rgb.min(axis=-1)) / level
            entry["false_colour"].append(float(chroma[inner].mean()))
            entry["false_colour_per_ring"].append(
                [float(chroma[inner & (ring_of == i)].mean()) if (inner & (ring_of == i)).any() else float("nan")
                 for i in range(len(edges) - 1)])
            luminance = rgb @ np.array([0.2126, 0.7152, 0.0722])
            # the filter moves the image d/2 right and down: the fit follows it
            entry["modulation_kept"].append(_modulation(luminance[near],
                                                        _plate_phase(plate.shape, shift_px=separation / 2)[near]))
            if label in ("bilinear", "menon2007", "XTRANS colour_difference", "QUAD_RGGB quad_remosaic",
                         "RGBW rgbw_fusion"):
                crops[(label, separation)] = rgb
        data["methods"][label] = entry
        rows += [summary_row("olpf", label, f"false colour, d = {d:g} pitch", fc, "of mean level")
                 for d, fc in zip(STUDY_SEPARATIONS, entry["false_colour"])]
        rows.append(summary_row("olpf", label, f"modulation kept at {SHARPNESS_FREQUENCY:g} cycle/px, d = 1",
                                entry["modulation_kept"][STUDY_SEPARATIONS.index(1.0)], "of the scene's",
                                f"analytic sinc·|H|² = {_analytic_kept(1.0):.3f}"))
    data["analytic_modulation_kept"] = [_analytic_kept(d) for d in STUDY_SEPARATIONS]
    return {"rows": rows, "data": data, "crops": crops}


def _plate_phase(shape, *, shift_px: float = 0.0) -> np.ndarray:
    """π·k·r² of :func:`zone_plate` (0.5 cycle/px at the middle of each edge), its centre moved
    ``shift_px`` right and down."""
    centre = shape[0] / 2.0
    y, x = np.mgrid[0:shape[0], 0:shape[1]].astype(np.float64) + 0.5 - centre - shift_px
    return np.pi * (0.5 / centre) * (x * x + y * y)


def _modulation(luminance: np.ndarray, phase: np.ndarray) -> float:
    """The zone plate's modulation kept in a ring, relative to the scene's: the least-squares fit
    L = a + b·cos φ + c·sin φ (the sine takes any phase a demosaic adds), then
    hypot(b, c)/a over the scene's 0.45/0.5."""
    design = np.stack([np.ones_like(phase), np.cos(phase), np.sin(phase)], axis=1)
    a, b, c = np.linalg.lstsq(design, luminance, rcond=None)[0]
    return float(np.hypot(b, c) / a / (0.45 / 0.5))


def _analytic_kept(separation_px: float) -> float:
    """|sinc(f)|·|H_d(f)| of the pixel aperture and the filter as applied at :data:`SHARPNESS_FREQUENCY`,
    for a radial pattern seen along x and y alike (the filter acts on both axes; a ring's mean of both).
    H_d is |cos(π f d)| for a whole-pitch d (the four-spot filter exactly) and the area-shared kernel's
    transfer for a fractional one (:func:`~spectral_cam.sensor.olpf.olpf_kernel_mtf`)."""
    from ...sensor.olpf import olpf_kernel_mtf

    f = SHARPNESS_FREQUENCY
    angles = np.linspace(0, np.pi / 2, 91)
    fx, fy = f * np.cos(angles), f * np.sin(angles)
    return float(np.mean(np.abs(np.sinc(fx) * np.sinc(fy)) * olpf_kernel_mtf(fx, separation_px)
                         * olpf_kernel_mtf(fy, separation_px)))


def plot_olpf(result: dict, directory: Path) -> list[str]:
    """olpf_false_colour.png (false colour vs separation per demosaic, and per frequency ring) and
    olpf_zone_plates.png (the developed zone plates without and with a 1-pitch filter)."""
    from ...viz import figure, save_png

    data = result["data"]
    separations = data["separations_px"]
    fig = figure(12.0, 4.0)
    ax1, ax2, ax3 = fig.subplots(1, 3)
    # eleven methods outrun matplotlib's ten colours: Bayer methods solid with circles, the larger
    # tiles dashed with their own markers, so no two curves look alike
    markers = iter("osD^v<>ph*X")
    for name, entry in data["methods"].items():
        style = {"marker": next(markers), "linestyle": "-" if " " not in name else "--", "label": name}
        ax1.plot(separations, entry["false_colour"], **style)
        ax3.plot(separations, entry["modulation_kept"], **style)
    ax3.plot(separations, data["analytic_modulation_kept"], "k:", linewidth=2,
             label="pixel × filter as applied (analytic)")
    centres = 0.5 * (np.array(data["frequency_edges"][:-1]) + np.array(data["frequency_edges"][1:]))
    first = next(iter(data["methods"].values()))
    for d, ring in zip(separations, first["false_colour_per_ring"]):
        ax2.plot(centres, ring, label=f"d = {d:g}")
    ax1.set_xlabel("spot separation d (pixel pitches)")
    ax1.set_ylabel("false colour (mean chroma / level)")
    ax1.set_title("False colour on a neutral zone plate")
    ax2.set_xlabel("local frequency (cycles/px)")
    ax2.set_title(f"per frequency ({next(iter(data['methods']))}, RGGB)")
    ax2.axvline(0.25, color="grey", linestyle=":")
    ax3.set_xlabel("spot separation d (pixel pitches)")
    ax3.set_ylabel(f"modulation kept at {data['sharpness_frequency']:g} cycle/px")
    ax3.set_title("What the filter costs")
    for ax in (ax1, ax2, ax3):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    save_png(fig, directory / "olpf_false_colour.png", dpi=100)

    crops = result.get("crops", {})
    chosen = [key for key in crops if key[1] in (0.0, 1.0)]
    columns = 4
    fig = figure(3.2 * columns, 3.4 * -(-len(chosen) // columns))
    for index, key in enumerate(chosen):
        ax = fig.add_subplot(-(-len(chosen) // columns), columns, index + 1)
        rgb = crops[key]
        ax.imshow(np.clip(rgb / np.percentile(rgb, 99), 0, 1) ** (1 / 2.2), interpolation="nearest")
        ax.set_title(f"{key[0]}, d = {key[1]:g}", fontsize=9)
        ax.axis("off")
    save_png(fig, directory / "olpf_zone_plates.png", dpi=100)
    return ["olpf_false_colour.png", "olpf_zone_plates.png"]
