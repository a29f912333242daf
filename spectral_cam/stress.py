"""``spectral-cam stress``: where each method of the chain stops being trustworthy.

Five studies, each a function that returns its numbers (``rows`` for the summary table,
``data`` for ``results.json``) and a plot function that draws them (matplotlib, Agg,
PNG); :func:`run` writes everything into one output folder, atomically:

(a) :func:`demosaic_study` — every registered demosaicing method on black-and-white
    checkerboards of square size 1, 2, 4, 8, … px (averaged over the four CFA phases) and on
    a zone plate: per-channel error maps, mean absolute error against square size and
    against spatial frequency, a false-colour measure, and the feature size at which each
    method becomes essentially lossless (:data:`LOSSLESS_TOLERANCE`).
(b) :func:`exposure_study` — synthetic flat fields from 0.01 to 10⁵ electrons per pixel
    through :func:`spectral_cam.sensor.expose`: the bias of the mean at low counts (with and
    without read-noise dither of the ADC), clipping at saturation (full-well and ADC
    limited), highlight handling without colour casts, and the SNR against the EMVA 1288
    model.
(c) :func:`optics_study` — f/0.95 to f/64 and a pinhole, focus from 1:2 macro to "infinity"
    (10⁶ m), wide to long focal lengths: circle-of-confusion and diffraction regimes from
    :mod:`spectral_cam.optics`, checked by a few tiny Mitsuba renders of a point source
    whose measured blur diameter is compared with the thin-lens formula.
(d) :func:`bokeh_study` — small bright out-of-focus sources converge slowly with
    camera-side path tracing (a pixel sees the source through a fraction p of the aperture;
    per-pixel noise ≈ √((1 − p)/(p·spp))). Charted against spp and time for the thin-lens
    path tracer, Mitsuba's light tracer (RGB/luminance films only) and the remedy
    implemented here, :func:`render_defocus_remedy`: render through a pinhole (every source
    in focus, fast to converge), then apply the thin-lens defocus as a per-depth uniform
    disc PSF of the circle-of-confusion diameter, layered back to front from a depth map
    (:func:`defocus_layers`). It works on the full spectral cube; the result is compared
    with a high-spp thin-lens reference.
(e) :func:`illuminant_study` — a synthetic ColorChecker (radiance ρ·E/π per patch block)
    under illuminants far from the D65 calibration (tungsten A, FL11, LED-B1, LED-RGB1 and a
    generated narrow-band RGB LED): ΔE2000 of the DNG matrix and of the fitted matrix for
    the white-balance choices as_shot, grey_world and white_patch.

References
----------
.. [1] Li, X., Gunturk, B., & Zhang, L. (2008). Image demosaicing: a systematic survey.
   Proc. SPIE 6822, 68221J (false colour and zipper artefacts; test patterns).
.. [2] EMVA Standard 1288, Release 4.0 Linear (2021), §2–§6 (linear model, SNR, saturation).
.. [3] Widrow, B., & Kollár, I. (2008). Quantization Noise. Cambridge University Press,
   ch. 19 (dither: rounding is unbiased when the noise before the quantiser is ≳ 0.5 LSB).
.. [4] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10 (depth of field,
   circle of confusion); Goodman, J. W. (2005). Introduction to Fourier Optics, 3rd ed.,
   §6.3 (diffraction-limited MTF).
.. [5] Potmesil, M., & Chakravarty, I. (1981). A lens and aperture camera model for
   synthetic image generation. Proc. SIGGRAPH '81, 297–305 (defocus as a post-process
   point-spread function on a depth map).
.. [6] Kraus, M., & Strengert, M. (2007). Depth-of-field rendering by pyramidal image
   processing. Computer Graphics Forum 26(3), 645–654 (depth layers composited back to
   front).
.. [7] Veach, E. (1997). Robust Monte Carlo Methods for Light Transport Simulation. PhD
   thesis, Stanford University, §10.2 (light tracing: paths started at the emitters).
.. [8] CIE 15:2004 and CIE 015:2018, Colorimetry (illuminants A, FL11; LED series);
   Sharma, G., Wu, W., & Dalal, E. N. (2005). The CIEDE2000 colour-difference formula.
   Color Res. Appl. 30(1), 21–30.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .errors import ConfigError
from .render.defocus import aperture_fraction, defocus_layers, disc_kernel, nearest_depth, render_layered

__all__ = [
    "StressSettings",
    "STUDIES",
    "LOSSLESS_TOLERANCE",
    "checkerboard",
    "zone_plate",
    "demosaic_errors",
    "demosaic_study",
    "electrons_per_band_radiance",
    "exposure_study",
    "diffraction_limit_f_number",
    "measured_blur_diameter_px",
    "optics_study",
    "bokeh_scene",
    "aperture_fraction",
    "disc_kernel",
    "defocus_layers",
    "nearest_depth",
    "render_layered",
    "bokeh_study",
    "write_narrow_band_led",
    "chart_radiance",
    "illuminant_study",
    "write_summary",
    "run_studies",
    "configure_parser",
    "run",
]

#: A demosaicing result counts as essentially lossless when its mean absolute error in
#: every channel and its false colour stay at or below this fraction of the white level.
LOSSLESS_TOLERANCE = 0.01
#: Pixels left out at each border of the demosaicing error statistics (the reach of the
#: methods' largest kernels; borders are handled by padding, which differs per method).
DEMOSAIC_BORDER_PX = 6
#: The demosaicing studies use this CFA (the methods are phase-equivariant; tests check it).
STUDY_CFA = "RGGB"
#: Colour sensor of the exposure and illuminant studies.
STUDY_CAMERA = "nikon_d850"
#: Illuminants of the illuminant study (besides the generated narrow-band LED).
STUDY_ILLUMINANTS = ("D65", "A", "FL11", "LED-B1", "LED-RGB1")
#: Peak wavelengths (nm) and FWHM (nm) of the generated narrow-band RGB LED.
NARROW_LED_PEAKS_NM = (450.0, 530.0, 630.0)
NARROW_LED_FWHM_NM = 15.0
#: ColorChecker index of the white patch (exposure reference).
WHITE_INDEX = 18


# ============================================================================= settings
@dataclass(frozen=True)
class StressSettings:
    """How large and how long each study is.

    Attributes
    ----------
    square_sizes_px
        Checkerboard square sizes, pixels.
    zone_plate_px
        Side of the square zone-plate image, pixels.
    frequency_bins
        Number of spatial-frequency rings of the zone-plate statistics (0 … 0.5 cycles/px).
    exposure_levels
        Number of signal levels, log-spaced over ``exposure_range_e``.
    exposure_range_e
        Smallest and largest mean photo-electrons per pixel.
    flat_px
        Side of the square flat-field frames, pixels.
    highlight_factors
        Exposures of the highlight study as multiples of the exposure that brings the
        brightest channel to saturation.
    optics_px
        Side of the optics study's renders, pixels.
    optics_spp
        Samples per pixel of the optics renders.
    bokeh_px
        Side of the bokeh renders, pixels.
    bokeh_thin_spp, bokeh_tracer_spp, bokeh_remedy_spp
        Samples per pixel of the thin-lens path tracer, the light tracer and the remedy's
        pinhole render.
    bokeh_reference_spp
        Samples per pixel of each of the two independent halves of the thin-lens reference.
    patch_px
        Side of a ColorChecker patch in the illuminant study, pixels.
    seed
        Seed of every render and frame (each gets its own derived seed).
    """

    square_sizes_px: tuple[int, ...] = (1, 2, 4, 8, 16, 32, 64)
    zone_plate_px: int = 256
    frequency_bins: int = 40
    exposure_levels: int = 25
    exposure_range_e: tuple[float, float] = (0.01, 1e5)
    flat_px: int = 128
    highlight_factors: tuple[float, ...] = (0.25, 0.5, 0.8, 1.0, 1.25, 1.5, 2.0, 4.0, 8.0, 16.0, 64.0)
    optics_px: int = 40
    optics_spp: int = 1024
    bokeh_px: int = 40
    bokeh_thin_spp: tuple[int, ...] = (16, 64, 256, 1024, 4096, 16384)
    bokeh_tracer_spp: tuple[int, ...] = (4, 16, 64, 256, 1024, 4096)
    bokeh_remedy_spp: tuple[int, ...] = (4, 16, 64, 256, 1024)
    bokeh_reference_spp: int = 65536
    patch_px: int = 20
    seed: int = 7

    @classmethod
    def full(cls) -> "StressSettings":
        """The full run (a few minutes on 2 cores)."""
        return cls()

    @classmethod
    def quick(cls) -> "StressSettings":
        """``--quick``: the same studies on fewer levels, samples and pixels (about a minute)."""
        return cls(square_sizes_px=(1, 2, 4, 8, 16, 32), zone_plate_px=192, frequency_bins=32,
                   exposure_levels=15, flat_px=96,
                   highlight_factors=(0.5, 0.8, 1.0, 1.5, 2.0, 4.0, 16.0, 64.0),
                   optics_px=40, optics_spp=256,
                   bokeh_thin_spp=(16, 64, 256, 1024, 4096), bokeh_tracer_spp=(4, 16, 64, 256, 1024),
                   bokeh_remedy_spp=(4, 16, 64, 256), bokeh_reference_spp=8192, patch_px=16)

    def replace(self, **changes) -> "StressSettings":
        """A copy with some fields changed (e.g. tiny settings for tests)."""
        return dataclasses.replace(self, **changes)


def _row(study: str, case: str, metric: str, value, unit: str, note: str = "") -> dict:
    return {"study": study, "case": case, "metric": metric,
            "value": None if value is None else float(value), "unit": unit, "note": note}


def _seed(settings: StressSettings, *keys: int) -> int:
    """A reproducible 31-bit seed for one render or frame of a study."""
    return int(np.random.SeedSequence([settings.seed, *keys]).generate_state(1)[0] >> 1)


def _figure(width_in: float, height_in: float):
    from matplotlib.figure import Figure

    return Figure(figsize=(width_in, height_in), dpi=100, layout="constrained")


def _save(fig, directory: Path, name: str, *, dpi: int = 100, palette: bool = False) -> str:
    """Write a figure as PNG (atomically); ``palette`` stores it with 256 adaptive colours
    (noise-like image panels then take a third of the space)."""
    from .io import atomic_path

    path = Path(directory) / name
    with atomic_path(path) as tmp:
        if palette:
            from matplotlib.backends.backend_agg import FigureCanvasAgg
            from PIL import Image

            canvas = FigureCanvasAgg(fig)
            fig.set_dpi(dpi)
            canvas.draw()
            rgb = np.asarray(canvas.buffer_rgba())[..., :3]
            Image.fromarray(rgb).quantize(256, method=Image.Quantize.MEDIANCUT).save(tmp, format="png", optimize=True)
        else:
            fig.savefig(tmp, format="png", dpi=dpi)
    return name


# ============================================================================= (a) demosaic
def checkerboard(square_px: int, shape: tuple[int, int], *, offset: tuple[int, int] = (0, 0)) -> np.ndarray:
    """A black-and-white checkerboard, point sampled on the pixel grid.

    Parameters
    ----------
    square_px
        Side of one square, pixels (≥ 1).
    shape
        (height, width) of the image, pixels.
    offset
        (row, column) shift of the pattern, pixels (to move it against the CFA phase).

    Returns
    -------
    numpy.ndarray
        (H, W) float32, 1 on white squares and 0 on black ones (the top-left square is
        white without offset).

    References
    ----------
    .. [1] Li, Gunturk & Zhang (2008), Proc. SPIE 6822 (synthetic demosaicing targets).
    """
    if not (isinstance(square_px, (int, np.integer)) and square_px >= 1):
        raise ConfigError(f"checkerboard square size {square_px!r} must be a whole number of pixels >= 1")
    rows = (np.arange(shape[0]) + offset[0]) // square_px
    cols = (np.arange(shape[1]) + offset[1]) // square_px
    return ((rows[:, None] + cols[None, :]) % 2 == 0).astype(np.float32)


def zone_plate(size_px: int, *, max_frequency: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """A circular zone plate ``½ + ½·cos(π·k·r²)`` whose local frequency ``k·r`` (cycles/px)
    rises linearly from 0 at the centre to ``max_frequency`` at the middle of each edge.

    Parameters
    ----------
    size_px
        Side of the square image, pixels.
    max_frequency
        Local frequency at radius ``size_px / 2``, cycles per pixel (0.5 = Nyquist).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        (H, W) float32 image in [0, 1] and (H, W) local frequency, cycles/px.

    References
    ----------
    .. [1] Li, Gunturk & Zhang (2008), Proc. SPIE 6822; the zone plate's instantaneous
       frequency d(k·r²/2)/dr = k·r.
    """
    centre = size_px / 2.0
    y, x = np.mgrid[0:size_px, 0:size_px].astype(np.float64) + 0.5 - centre
    radius = np.hypot(x, y)
    k = max_frequency / centre
    image = 0.5 + 0.5 * np.cos(np.pi * k * radius ** 2)
    return image.astype(np.float32), k * radius


def demosaic_errors(truth: np.ndarray, *, method: str, cfa: str = STUDY_CFA,
                    border_px: int = DEMOSAIC_BORDER_PX) -> dict:
    """Demosaic the CFA samples of an achromatic image and measure the error.

    Parameters
    ----------
    truth
        (H, W) linear grey image (R = G = B), 1 = white level.
    method
        A name of :data:`spectral_cam.isp.demosaic.DEMOSAIC`.
    cfa
        Bayer tile.
    border_px
        Pixels left out at each border of the statistics.

    Returns
    -------
    dict
        ``error``: (H, W, 3) signed error (output − truth); ``mae``: (3,) mean absolute
        error per channel over the interior; ``mae_all``: their mean; ``false_colour``:
        mean of max(R, G, B) − min(R, G, B) over the interior (0 for a neutral output);
        ``output``: (H, W, 3) demosaiced image.

    References
    ----------
    .. [1] Li, Gunturk & Zhang (2008), Proc. SPIE 6822 (false colour of achromatic detail).
    """
    from .isp.demosaic import demosaic

    truth = np.asarray(truth, dtype=np.float32)
    # an achromatic scene white-balanced to gains 1 gives every CFA site the grey value
    output = demosaic(truth, cfa, method=method)
    error = output - truth[..., None]
    inner = (slice(border_px, -border_px or None), slice(border_px, -border_px or None))
    mae = np.abs(error[inner]).reshape(-1, 3).mean(axis=0)
    inside = output[inner]
    false_colour = float(np.mean(inside.max(axis=-1) - inside.min(axis=-1)))
    return {"error": error, "mae": mae, "mae_all": float(mae.mean()), "false_colour": false_colour,
            "output": output}


def _lossless_from(sizes, mae_per_channel, false_colour, tolerance) -> float | None:
    """Smallest size from which on (towards larger sizes) every channel and the false
    colour stay within the tolerance; None if never."""
    ok = [bool(np.all(np.asarray(m) <= tolerance) and f <= tolerance)
          for m, f in zip(mae_per_channel, false_colour)]
    best = None
    for size, good in zip(reversed(list(sizes)), reversed(ok)):
        if not good:
            break
        best = size
    return best


def demosaic_study(settings: StressSettings, *, methods=None) -> dict:
    """Demosaicing on checkerboards and a zone plate (study (a)).

    Each checkerboard is measured at the four shifts (0|1, 0|1) against the CFA and the
    errors averaged; images are ``max(64, 4·square)`` pixels wide so every size shows at
    least four squares.

    Parameters
    ----------
    settings
        Square sizes, zone-plate size and frequency rings.
    methods
        Demosaicing method names; default every method of the registry.

    Returns
    -------
    dict
        ``rows`` (summary) and ``data``: per method the mean absolute error per channel and
        false colour per square size, the zone-plate error per frequency ring, the lossless
        square size (px) and the lossless zone-plate frequency (cycles/px) with its
        half-period feature size (px); ``maps`` (arrays for the figures, not serialised).

    References
    ----------
    .. [1] Li, Gunturk & Zhang (2008), Proc. SPIE 6822.
    .. [2] Malvar, He & Cutler (2004); Menon, Andriani & Calvagno (2007) (the methods).
    """
    from .isp.demosaic import DEMOSAIC

    methods = list(DEMOSAIC) if methods is None else list(methods)
    sizes = [int(s) for s in settings.square_sizes_px]
    phases = [(0, 0), (0, 1), (1, 0), (1, 1)]
    data: dict = {"square_sizes_px": sizes, "tolerance": LOSSLESS_TOLERANCE, "methods": {}}
    maps: dict = {"checker": {}, "zone": {}}
    rows = []
    plate, frequency = zone_plate(settings.zone_plate_px)
    edges = np.linspace(0.0, 0.5, settings.frequency_bins + 1)
    inner = np.zeros(plate.shape, bool)
    b = DEMOSAIC_BORDER_PX
    inner[b:-b, b:-b] = True
    ring_of = np.digitize(frequency, edges) - 1
    for method in methods:
        mae, fc = [], []
        for size in sizes:
            side = max(64, 4 * size)
            results = [demosaic_errors(checkerboard(size, (side, side), offset=p), method=method)
                       for p in phases]
            mae.append(np.mean([r["mae"] for r in results], axis=0))
            fc.append(float(np.mean([r["false_colour"] for r in results])))
            maps["checker"][(method, size)] = results[0]
        zone = demosaic_errors(plate, method=method)
        maps["zone"][method] = zone
        abs_err = np.abs(zone["error"]).mean(axis=-1)
        chroma = zone["output"].max(axis=-1) - zone["output"].min(axis=-1)
        ring_mae, ring_fc = [], []
        for i in range(len(edges) - 1):
            sel = inner & (ring_of == i)
            ring_mae.append(float(abs_err[sel].mean()) if sel.any() else float("nan"))
            ring_fc.append(float(chroma[sel].mean()) if sel.any() else float("nan"))
        limit = 0.0
        for upper, e, f in zip(edges[1:], ring_mae, ring_fc):
            if not (e <= LOSSLESS_TOLERANCE and f <= LOSSLESS_TOLERANCE):
                break
            limit = float(upper)
        lossless = _lossless_from(sizes, mae, fc, LOSSLESS_TOLERANCE)
        data["methods"][method] = {
            "checker_mae_per_channel": [list(map(float, m)) for m in mae],
            "checker_mae": [float(np.mean(m)) for m in mae],
            "checker_false_colour": fc,
            "lossless_square_px": lossless,
            "zone_frequency_edges": [float(e) for e in edges],
            "zone_mae": ring_mae,
            "zone_false_colour": ring_fc,
            "zone_lossless_frequency": limit,
            "zone_lossless_feature_px": (0.5 / limit) if limit > 0 else None,
        }
        first = sizes.index(1) if 1 in sizes else 0
        rows += [
            _row("demosaic", method, f"mean abs error, {sizes[first]}-px checkerboard",
                 float(np.mean(mae[first])), "of white"),
            _row("demosaic", method, f"false colour, {sizes[first]}-px checkerboard", fc[first], "of white"),
            _row("demosaic", method, "lossless square size", lossless, "px",
                 "" if lossless is not None else f"error > {LOSSLESS_TOLERANCE:g} up to {sizes[-1]} px"),
            _row("demosaic", method, "lossless zone-plate half period", data["methods"][method]["zone_lossless_feature_px"],
                 "px", f"frequency <= {limit:.4g} cycles/px"),
        ]
        if 8 in sizes:
            rows.append(_row("demosaic", method, "mean abs error, 8-px checkerboard",
                             float(np.mean(mae[sizes.index(8)])), "of white"))
    return {"rows": rows, "data": data, "maps": maps}


def plot_demosaic(result: dict, directory: Path) -> list[str]:
    """Figures of :func:`demosaic_study`: checkerboard outputs, per-channel error maps
    (checkerboards and zone plate) and the error-versus-size/frequency charts."""
    data, maps = result["data"], result["maps"]
    methods = list(data["methods"])
    sizes = [s for s in data["square_sizes_px"] if s <= 8] or data["square_sizes_px"][:4]
    crop = 32
    written = []

    fig = _figure(1.6 * len(sizes) + 0.8, 1.5 * len(methods) + 0.6)
    axes = fig.subplots(len(methods), len(sizes), squeeze=False)
    for i, method in enumerate(methods):
        for j, size in enumerate(sizes):
            out = maps["checker"][(method, size)]["output"]
            ax = axes[i, j]
            ax.imshow(np.clip(out[:crop, :crop], 0, 1) ** (1 / 2.2), interpolation="nearest")
            ax.set_xticks([]), ax.set_yticks([])
            if i == 0:
                ax.set_title(f"{size}-px squares", fontsize=9)
            if j == 0:
                ax.set_ylabel(method, fontsize=9)
    fig.suptitle("Demosaiced black-and-white checkerboards (RGGB; colour = false colour)", fontsize=10)
    written.append(_save(fig, directory, "demosaic_checkerboards.png"))

    fig = _figure(0.95 * 3 * len(sizes) + 1.2, 1.1 * len(methods) + 0.8)
    axes = fig.subplots(len(methods), 3 * len(sizes), squeeze=False)
    image = None
    for i, method in enumerate(methods):
        for j, size in enumerate(sizes):
            err = maps["checker"][(method, size)]["error"][:crop, :crop]
            for c, name in enumerate("RGB"):
                ax = axes[i, 3 * j + c]
                image = ax.imshow(err[..., c], cmap="RdBu_r", vmin=-1, vmax=1, interpolation="nearest")
                ax.set_xticks([]), ax.set_yticks([])
                if i == 0:
                    ax.set_title(f"{size} px {name}", fontsize=7)
            if j == 0:
                axes[i, 0].set_ylabel(method, fontsize=8)
    fig.colorbar(image, ax=axes, shrink=0.6, label="signed error (of white)")
    fig.suptitle("Per-channel demosaicing error on checkerboards (output − truth)", fontsize=10)
    written.append(_save(fig, directory, "demosaic_error_maps.png", palette=True))

    # about one screen pixel per image pixel: a resampled zone plate would show its own moiré
    panel_in = maps["zone"][methods[0]]["output"].shape[0] / 2 / 100 + 0.15
    fig = _figure(panel_in * 4 + 1.0, panel_in * len(methods) + 0.7)
    axes = fig.subplots(len(methods), 4, squeeze=False)
    for i, method in enumerate(methods):
        zone = maps["zone"][method]
        half = zone["output"].shape[0] // 2  # one quadrant: centre (0 cycles/px) to the edges (0.5)
        axes[i, 0].imshow(np.clip(zone["output"][half:, half:], 0, 1), interpolation="nearest")
        for c, name in enumerate("RGB"):
            image = axes[i, c + 1].imshow(zone["error"][half:, half:, c], cmap="RdBu_r", vmin=-0.5, vmax=0.5,
                                          interpolation="nearest")
            if i == 0:
                axes[i, c + 1].set_title(f"error {name}", fontsize=9)
        axes[i, 0].set_ylabel(method, fontsize=9)
        if i == 0:
            axes[i, 0].set_title("output", fontsize=9)
        for ax in axes[i]:
            ax.set_xticks([]), ax.set_yticks([])
    fig.colorbar(image, ax=axes, shrink=0.6, label="signed error (of white)")
    fig.suptitle("Zone plate: demosaiced output and per-channel error", fontsize=10)
    written.append(_save(fig, directory, "demosaic_zone_plate.png", palette=True))

    fig = _figure(13, 3.8)
    ax1, ax2, ax3 = fig.subplots(1, 3)
    all_sizes = data["square_sizes_px"]
    for method in methods:
        entry = data["methods"][method]
        ax1.plot(all_sizes, np.maximum(entry["checker_mae"], 1e-5), "o-", label=method)
        ax2.plot(all_sizes, np.maximum(entry["checker_false_colour"], 1e-5), "o-", label=method)
        centres = 0.5 * (np.asarray(entry["zone_frequency_edges"][:-1]) + np.asarray(entry["zone_frequency_edges"][1:]))
        ax3.plot(centres, entry["zone_mae"], "-", label=method)
    for ax in (ax1, ax2):
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.axhline(LOSSLESS_TOLERANCE, color="k", ls="--", lw=0.8)
        ax.set_xlabel("checkerboard square size (px)")
    ax1.set_ylabel("mean |error| (of white), 4 CFA phases")
    ax1.set_title("Error vs feature size")
    ax2.set_ylabel("mean max(RGB) − min(RGB)")
    ax2.set_title("False colour vs feature size")
    ax3.set_yscale("log")
    ax3.axhline(LOSSLESS_TOLERANCE, color="k", ls="--", lw=0.8, label=f"lossless ({LOSSLESS_TOLERANCE:g})")
    ax3.set_xlabel("zone-plate local frequency (cycles/px)")
    ax3.set_ylabel("mean |error| in ring")
    ax3.set_title("Zone plate: error vs frequency")
    ax3.legend(fontsize=8)
    ax1.legend(fontsize=8)
    written.append(_save(fig, directory, "demosaic_error_vs_size.png"))
    return written


# ============================================================================= (b) exposure
#: Sensor variants of the low-count / clipping series (monochrome, flat QE), as
#: ``(label, sensor overrides, ISO)``: the default chain, the same chain without read
#: noise or other dither before the ADC, and ISO 800 (ADC-limited saturation).
EXPOSURE_SENSORS = (
    ("ISO 100, read noise 2.5 e-", {}, 100.0),
    ("ISO 100, no read noise (no ADC dither)",
     {"read_noise_e": 0.0, "dsnu_e": 0.0, "dark_current_e_per_s": 0.0, "prnu": 0.0}, 100.0),
    ("ISO 800, read noise 2.5 e-", {}, 800.0),
)
_EXPOSURE_TIME_S = 0.01
_NARROW_BAND_NM = 550.0


def _bands():
    from . import spectra
    from .scene import SPECTRAL_BANDS_DEFAULT

    return spectra.parse_bands(SPECTRAL_BANDS_DEFAULT)


def _spectral_image(data: np.ndarray, bands=None):
    from .image import SpectralImage

    bands = _bands() if bands is None else bands
    return SpectralImage(np.ascontiguousarray(data, dtype=np.float32), np.asarray(bands.centres_nm, float),
                         np.asarray(bands.edges_nm, float))


def _mono_config(size_px: int, overrides: dict, iso: float, exposure_s: float):
    from .scene import scene_from_dict

    sensor = {"model": "ideal", "cfa": "none", "width_px": size_px, "height_px": size_px, "vignetting": False,
              **overrides}
    return scene_from_dict({"sensor": sensor, "exposure": {"time_s": exposure_s, "iso": iso}})


def electrons_per_band_radiance(config, wavelength_nm: float) -> float:
    """Photo-electrons per second of one pixel per unit band radiance (W·m⁻²·sr⁻¹) in the
    band centred on ``wavelength_nm``, on axis, for a monochrome (``cfa = "none"``) sensor.

    ``π·T/(1 + 4·N_w²)·A_pix·λ/(h·c)·η`` (EMVA 1288 §2.1; the camera equation of
    :func:`spectral_cam.sensor.band_weights`).

    Parameters
    ----------
    config
        Scene with a monochrome sensor.
    wavelength_nm
        A band centre of the 400:700:10 grid, nm.

    Returns
    -------
    float
        e⁻·s⁻¹ per W·m⁻²·sr⁻¹.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1 eqs. (1)–(2).
    """
    from . import sensor as S
    from .optics import ThinLens

    bands = _bands()
    wl = np.asarray(bands.centres_nm, float)
    qe = S.quantum_efficiency(config.sensor.model, wl, peak_qe=config.sensor.peak_qe, monochrome=True)
    lens = ThinLens.from_config(config.lens, config.sensor)
    weights = S.band_weights(wl, qe, working_f_number=lens.working_f_number,
                             pixel_area_m2=(config.sensor.pixel_pitch_um * 1e-6) ** 2)
    return float(weights[int(np.argmin(np.abs(wl - wavelength_nm))), 0])


def _narrow_band_flat(size_px: int, band_radiance: float):
    bands = _bands()
    spectrum = np.zeros(len(bands), np.float32)
    spectrum[int(np.argmin(np.abs(np.asarray(bands.centres_nm) - _NARROW_BAND_NM)))] = band_radiance
    return _spectral_image(np.broadcast_to(spectrum, (size_px, size_px, len(bands))).copy(), bands)


def _reflector_radiance(illuminant: str, reflectance: float, size_px: int, *, lux: float = 1000.0):
    """A Lambertian reflector of flat reflectance under an illuminant: L = ρ·E/π per band."""
    from . import spectra

    bands = _bands()
    wl, irradiance = spectra.absolute_irradiance(illuminant, lux)
    radiance = spectra.band_integrals(reflectance * irradiance / np.pi, wl, bands).astype(np.float32)
    return _spectral_image(np.broadcast_to(radiance, (size_px, size_px, len(bands))).copy(), bands)


def _neutral_chroma(linear_srgb_mean) -> float:
    """CIELAB chroma C*ab of a colour scaled to luminance Y = 1 (0 for any neutral)."""
    import colour

    rgb = np.asarray(linear_srgb_mean, dtype=float)
    space = colour.models.RGB_COLOURSPACE_sRGB
    xyz = colour.RGB_to_XYZ(rgb, space, apply_cctf_decoding=False)
    if not xyz[1] > 0:
        return float("nan")
    lab = colour.XYZ_to_Lab(xyz / xyz[1], space.whitepoint)
    return float(np.hypot(lab[1], lab[2]))


def exposure_study(settings: StressSettings) -> dict:
    """Flat fields from ``exposure_range_e`` electrons per pixel through the sensor (study (b)).

    For each sensor of :data:`EXPOSURE_SENSORS` and each level μ_e (log-spaced): a pair of
    narrow-band (550 nm) flat fields and a dark pair at t = 10 ms. The mean signal
    (μ_y − μ_y.dark)/K is compared with μ_e (bias, in units of its standard error), the
    pair's temporal variance gives the SNR, compared with the EMVA 1288 model
    :func:`spectral_cam.metrics.emva1288.snr_model`; past saturation the frames show how
    the chain clips (full well at ISO 100, the ADC at ISO 800). Then a white reflector
    under illuminants A and D65, exposed from ``highlight_factors`` × the exposure that
    saturates the brightest channel, is developed with each highlight method and the colour
    cast measured as the CIELAB chroma of its mean colour at Y = 1.

    Parameters
    ----------
    settings
        Levels, range and frame size.

    Returns
    -------
    dict
        ``rows`` and ``data`` (per sensor: expected and measured electrons, standard
        errors, SNR and model SNR; saturation checks; highlight chroma per method and
        factor).

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.3–2.4 (noise model, SNR), §6.1 (mean and temporal
       variance from a pair of frames).
    .. [2] Widrow & Kollár (2008), Quantization Noise, ch. 19 (dither).
    .. [3] Coffin, D. dcraw.c, highlight modes (clip, blend).
    """
    from . import sensor as S
    from .isp import ISPConfig, develop
    from .metrics.emva1288 import pair_statistics, snr_model

    low, high = settings.exposure_range_e
    levels = np.logspace(np.log10(low), np.log10(high), settings.exposure_levels)
    size = settings.flat_px
    rows: list[dict] = []
    data: dict = {"levels_e": levels.tolist(), "sensors": {}, "highlights": {}}
    for s_index, (label, overrides, iso) in enumerate(EXPOSURE_SENSORS):
        config = _mono_config(size, overrides, iso, _EXPOSURE_TIME_S)
        per_radiance = electrons_per_band_radiance(config, _NARROW_BAND_NM) * _EXPOSURE_TIME_S
        dark_frames = [S.expose(_narrow_band_flat(size, 0.0), config, frame_seed=_seed(settings, 2, s_index, k))
                       for k in (0, 1)]
        meta = dark_frames[0].meta
        gain, white, black = meta["K_dn_per_e"], dark_frames[0].white_level, dark_frames[0].black_level
        dark_mean, dark_var = (v["Y"] for v in pair_statistics(dark_frames[0].mosaic, dark_frames[1].mosaic))
        measured, standard_error, snr, snr_expected, max_dn, at_white, min_dn = [], [], [], [], [], [], []
        for l_index, level in enumerate(levels):
            image = _narrow_band_flat(size, float(level / per_radiance))
            a, b = (S.expose(image, config, frame_seed=_seed(settings, 3, s_index, l_index, k)) for k in (0, 1))
            means, variances = pair_statistics(a.mosaic, b.mosaic)
            signal_dn = means["Y"] - dark_mean
            measured.append(signal_dn / gain)
            standard_error.append(math.sqrt((variances["Y"] + dark_var) / (2 * a.mosaic.size)) / gain)
            snr.append(signal_dn / math.sqrt(variances["Y"]) if variances["Y"] > 0 else float("inf"))
            snr_expected.append(float(snr_model(level / config.sensor.peak_qe, quantum_efficiency=config.sensor.peak_qe,
                                                sigma_d_e=meta["sigma_dark_e"], gain=gain)))
            both = np.concatenate([a.mosaic.ravel(), b.mosaic.ravel()])
            max_dn.append(int(both.max()))
            min_dn.append(int(both.min()))
            at_white.append(float(np.mean(both == white)))
        measured = np.asarray(measured)
        standard_error = np.asarray(standard_error)
        saturation = meta["saturation_e"]
        entry = {
            "label": label, "iso": iso, "K_dn_per_e": gain, "saturation_e": saturation,
            "sigma_dark_e": meta["sigma_dark_e"], "white_level": white, "black_level": black,
            "measured_e": measured.tolist(), "standard_error_e": standard_error.tolist(),
            "snr": snr, "snr_model": snr_expected, "max_dn": max_dn, "min_dn": min_dn,
            "fraction_at_white": at_white,
        }
        data["sensors"][label] = entry
        low_counts = levels <= 1.0 + 1e-9
        bias = measured - levels
        # a frame without any temporal noise has a standard error of 0: its bias is exact
        z = np.divide(bias, standard_error, out=np.where(bias == 0, 0.0, np.inf), where=standard_error > 0)
        entry["bias_z"] = z.tolist()
        if low_counts.any():
            worst = int(np.flatnonzero(low_counts)[np.argmax(np.abs(z[low_counts]))])
            note = f"at {levels[worst]:.3g} e-: measured {measured[worst]:.4g} ± {standard_error[worst]:.2g} e-"
            if standard_error[worst] == 0:
                note += " (no noise reaches the ADC: every pixel reads the same DN)"
            rows.append(_row("exposure", label, "largest |bias| / standard error at 0.01-1 e-",
                             float(abs(z[worst])), "SE", note))
            one = int(np.argmin(np.abs(np.log(levels))))
            rows.append(_row("exposure", label, f"measured / expected at {levels[one]:.3g} e-",
                             float(measured[one] / levels[one]), "ratio",
                             f"standard error {standard_error[one] / levels[one]:.2g}"))
        over = levels >= 2 * saturation
        if over.any():
            clipped_e = measured[over]
            rows.append(_row("exposure", label, "mean past saturation / saturation capacity",
                             float(np.mean(clipped_e) / saturation), "ratio",
                             f"saturation {saturation:.5g} e-, white level {white} DN"))
            rows.append(_row("exposure", label, "largest DN past saturation - white level",
                             max(max_dn[i] for i in np.flatnonzero(over)) - white, "DN",
                             f"{100 * np.mean([at_white[i] for i in np.flatnonzero(over)]):.1f} % of pixels at white"))
        # below ~10 e- the measured SNR's own uncertainty (that of the mean) exceeds 3 %
        usable = (levels >= 10.0) & (levels <= 0.7 * saturation)
        if usable.any():
            ratio = np.asarray(snr)[usable] / np.asarray(snr_expected)[usable]
            entry["snr_ratio_max_deviation"] = float(np.max(np.abs(ratio - 1)))
            rows.append(_row("exposure", label, "SNR / EMVA model, worst over 10 e- .. 70 % saturation",
                             float(ratio[np.argmax(np.abs(ratio - 1))]), "ratio"))

    methods = ("none", "clip", "desaturate")
    factors = [float(f) for f in settings.highlight_factors]
    hl_size = max(24, size // 2)
    for i_index, illuminant in enumerate(("A", "D65")):
        from .scene import scene_from_dict

        base = {"illuminant": {"spd": illuminant},
                "sensor": {"model": STUDY_CAMERA, "width_px": hl_size, "height_px": hl_size, "vignetting": False}}
        image = _reflector_radiance(illuminant, 0.9, hl_size)
        probe = S.expose(image, scene_from_dict({**base, "exposure": {"time_s": "auto", "auto_fraction": 1.0}}),
                         frame_seed=1)
        t_sat = probe.meta["exposure_s"]
        chroma = {m: [] for m in methods}
        luminance = {m: [] for m in methods}
        swatches = {m: [] for m in methods}
        for f_index, factor in enumerate(factors):
            raw = S.expose(image, scene_from_dict({**base, "exposure": {"time_s": factor * t_sat}}),
                           frame_seed=_seed(settings, 4, i_index, f_index))
            for method in methods:
                developed = develop(raw, ISPConfig(highlights=method, tone="linear"))
                mean = developed.linear[4:-4, 4:-4].reshape(-1, 3).astype(float).mean(axis=0)
                chroma[method].append(_neutral_chroma(mean))
                luminance[method].append(float(mean @ np.array([0.2126, 0.7152, 0.0722])))
                swatches[method].append(mean.tolist())
        data["highlights"][illuminant] = {"factors": factors, "chroma": chroma, "luminance": luminance,
                                          "mean_linear_srgb": swatches, "exposure_at_saturation_s": t_sat}
        clipped = [k for k, f in enumerate(factors) if f >= 1.25]
        for method in methods:
            if clipped:
                rows.append(_row("exposure", f"highlights '{method}', illuminant {illuminant}",
                                 "largest colour cast (C*ab) at >= 1.25x saturation",
                                 max(chroma[method][k] for k in clipped), "C*ab",
                                 "CIELAB chroma of the mean white at Y = 1; < 1 is invisible"))
    return {"rows": rows, "data": data}


def plot_exposure(result: dict, directory: Path) -> list[str]:
    """Figures of :func:`exposure_study`: bias and clipping, SNR against the EMVA model,
    highlight colour casts."""
    data = result["data"]
    levels = np.asarray(data["levels_e"])
    written = []
    fig = _figure(12, 4.2)
    ax1, ax2 = fig.subplots(1, 2)
    for label, entry in data["sensors"].items():
        measured = np.asarray(entry["measured_e"])
        se = np.asarray(entry["standard_error_e"])
        line, = ax1.plot(levels, measured / levels, "o-", ms=3, label=label)
        ax1.fill_between(levels, (measured - 2 * se) / levels, (measured + 2 * se) / levels,
                         color=line.get_color(), alpha=0.15)
        ax2.plot(levels, np.maximum(measured, 1e-3), "o-", ms=3, color=line.get_color(), label=label)
        ax2.axhline(entry["saturation_e"], color=line.get_color(), ls=":", lw=0.8)
    ax1.set_xscale("log")
    ax1.set_ylim(-0.5, 2.0)
    ax1.axhline(1.0, color="k", lw=0.8)
    ax1.set_xlabel("expected photo-electrons per pixel")
    ax1.set_ylabel("measured / expected (band: ±2 standard errors)")
    ax1.set_title("Bias of the mean (dark-subtracted)")
    ax1.legend(fontsize=8)
    ax2.plot(levels, levels, "k--", lw=0.8, label="expected")
    ax2.set_xscale("log"), ax2.set_yscale("log")
    ax2.set_xlabel("expected photo-electrons per pixel")
    ax2.set_ylabel("measured electrons (dotted: saturation capacity)")
    ax2.set_title("Linearity and clipping")
    ax2.legend(fontsize=8)
    written.append(_save(fig, directory, "exposure_bias_clipping.png"))

    fig = _figure(6.5, 4.4)
    ax = fig.subplots()
    label, entry = next(iter(data["sensors"].items()))
    ax.loglog(levels, np.maximum(entry["snr"], 1e-4), "o", ms=4, label=f"measured ({label})")
    ax.loglog(levels, entry["snr_model"], "-", label="EMVA 1288 model")
    ax.loglog(levels, np.sqrt(levels), ":", color="gray", label="shot-noise limit √μe")
    ax.axvline(entry["saturation_e"], color="k", ls="--", lw=0.8, label="saturation capacity")
    ax.set_xlabel("mean photo-electrons per pixel μe")
    ax.set_ylabel("SNR (temporal, from a frame pair)")
    ax.set_ylim(1e-3, None)
    ax.legend(fontsize=8)
    ax.set_title("SNR against the EMVA 1288 model")
    written.append(_save(fig, directory, "exposure_snr.png"))

    highlights = data["highlights"]
    fig = _figure(12, 4.4)
    axes = fig.subplots(1, len(highlights) + 1, width_ratios=[3] * len(highlights) + [2])
    for ax, (illuminant, entry) in zip(axes, highlights.items()):
        for method, values in entry["chroma"].items():
            ax.semilogx(entry["factors"], values, "o-", ms=4, label=f"highlights = {method}")
        ax.axvline(1.0, color="k", ls="--", lw=0.8)
        ax.set_xlabel("exposure / exposure saturating the brightest channel")
        ax.set_ylabel("colour cast C*ab of the developed white")
        ax.set_title(f"White reflector under {illuminant}")
        ax.legend(fontsize=8)
    ax = axes[-1]
    methods = list(next(iter(highlights.values()))["mean_linear_srgb"])
    tiles = []
    for illuminant, entry in highlights.items():
        for method in methods:
            rgb = np.asarray(entry["mean_linear_srgb"][method], float)
            rgb = rgb / np.maximum(rgb.max(axis=1, keepdims=True), 1e-9)
            tiles.append(np.clip(rgb, 0, 1) ** (1 / 2.2))
    ax.imshow(np.stack(tiles), aspect="auto", interpolation="nearest")
    ax.set_yticks(range(len(tiles)), [f"{i} {m}" for i in highlights for m in methods], fontsize=7)
    factors = next(iter(highlights.values()))["factors"]
    ax.set_xticks(range(len(factors)), [f"{f:g}" for f in factors], fontsize=7)
    ax.set_xlabel("exposure factor")
    ax.set_title("developed white (normalised)")
    written.append(_save(fig, directory, "exposure_highlights.png"))
    return written


# ============================================================================= (c) optics
#: f-numbers of the optics charts (a pinhole is drawn as the zero-aperture limit).
F_NUMBERS = (0.95, 1.4, 2.0, 2.8, 4.0, 5.6, 8.0, 11.0, 16.0, 22.0, 32.0, 45.0, 64.0)
#: Focal lengths (mm) of the wide-to-long chart.
FOCAL_LENGTHS_MM = (4.0, 8.0, 14.0, 24.0, 50.0, 100.0, 200.0, 400.0, 600.0)
_CHART_FOCAL_MM, _CHART_FOCUS_M, _CHART_PITCH_UM, _CHART_WIDTH_PX = 50.0, 2.0, 6.0, 480
#: Focal length (mm) of the regime map: the default 8-mm lens, where all three regimes occur.
_REGIME_FOCAL_MM = 8.0
_GREEN_NM, _RED_NM = 550.0, 700.0


def _lens(focal_length_mm: float, f_number: float, focus_distance_m: float, *, pitch_um: float = _CHART_PITCH_UM,
          width_px: int = _CHART_WIDTH_PX, height_px: int = 320):
    from .optics import ThinLens

    return ThinLens(focal_length_m=focal_length_mm * 1e-3, f_number=f_number, focus_distance_m=focus_distance_m,
                    sensor_width_m=width_px * pitch_um * 1e-6, sensor_height_m=height_px * pitch_um * 1e-6,
                    width_px=width_px, height_px=height_px)


def diffraction_limit_f_number(pixel_pitch_um: float, wavelength_nm: float, *, tolerance: float | None = None) -> float:
    """The f-number (at unit magnification factor, N_w = N) above which diffraction costs more
    than ``tolerance`` of MTF at the sensor's Nyquist frequency 1/(2p).

    Solves ``1 − MTF_diff(1/(2p); λ, N) = tolerance`` (Goodman §6.3.2) by bracketing.

    Parameters
    ----------
    pixel_pitch_um
        Pixel pitch p, µm.
    wavelength_nm
        Wavelength λ, nm.
    tolerance
        MTF loss; default :data:`spectral_cam.optics.MTF_TOLERANCE` (the render's model
        decision).

    Returns
    -------
    float
        N (dimensionless).

    References
    ----------
    .. [1] Goodman, J. W. (2005). Introduction to Fourier Optics, 3rd ed., §6.3.2.
    """
    from scipy.optimize import brentq

    from .optics import MTF_TOLERANCE, diffraction_mtf

    tolerance = MTF_TOLERANCE if tolerance is None else tolerance
    nyquist = 0.5 / (pixel_pitch_um * 1e-6)
    return float(brentq(lambda n: 1.0 - diffraction_mtf(nyquist, wavelength_nm, n) - tolerance, 1e-3, 1e4))


def _second_moment(image: np.ndarray) -> float:
    """Radial second moment ⟨r²⟩ (px²) of a non-negative image about its centroid."""
    image = np.asarray(image, dtype=np.float64)
    total = image.sum()
    if not total > 0:
        return float("nan")
    y, x = np.mgrid[0:image.shape[0], 0:image.shape[1]].astype(np.float64)
    cy, cx = (image * y).sum() / total, (image * x).sum() / total
    return float((image * ((y - cy) ** 2 + (x - cx) ** 2)).sum() / total)


def measured_blur_diameter_px(defocused: np.ndarray, sharp: np.ndarray) -> float:
    """Diameter (px) of a uniform disc PSF from the growth of the second moment.

    Second moments add under convolution, and a uniform disc of diameter c has ⟨r²⟩ = c²/8,
    so ``c = √(8·(⟨r²⟩_defocused − ⟨r²⟩_sharp))`` whatever the source's own size and the
    pixel aperture.

    Parameters
    ----------
    defocused, sharp
        (H, W) images (e.g. band sums) of the same source through the thin lens and through
        a pinhole of the same geometry.

    Returns
    -------
    float
        Blur diameter, pixels (0 when the difference is not positive).

    References
    ----------
    .. [1] Bracewell, R. N. (2000). The Fourier Transform and Its Applications, 3rd ed.,
       ch. 8 (second moments add under convolution).
    """
    difference = _second_moment(defocused) - _second_moment(sharp)
    return float(math.sqrt(8.0 * difference)) if difference > 0 else 0.0


def bokeh_scene(*, width_px: int = 40, pixel_pitch_um: float = 6.0, focal_length_mm: float = 8.0,
                f_number: float = 1.4, focus_distance_m: float = 0.3, source_depth_m: float = 3.0,
                source_radius_m: float = 0.0012, model: str = "thin", spp: int = 64, seed: int = 0,
                diffraction: str = "off"):
    """A square view of one small emitting disc on the optical axis (preset ``point_sources``).

    Parameters
    ----------
    width_px
        Sensor side, pixels.
    pixel_pitch_um
        Pixel pitch, µm.
    focal_length_mm, f_number, focus_distance_m
        The thin lens (mm, dimensionless, m).
    source_depth_m, source_radius_m
        Depth (m) and radius (m) of the emitting disc (radiance of a white diffuser under
        1000 lx of D65).
    model
        ``"thin"`` or ``"pinhole"``.
    spp, seed
        Samples per pixel and render seed.
    diffraction
        ``render.diffraction``: ``"off"`` (default: pure geometric optics), ``"on"`` or
        ``"auto"``.

    Returns
    -------
    SceneConfig
    """
    from .scene import scene_from_dict

    return scene_from_dict({
        "scene": {"preset": "point_sources", "depths_m": [float(source_depth_m)],
                  "source_radius_m": float(source_radius_m)},
        "lens": {"focal_length_mm": float(focal_length_mm), "f_number": float(f_number),
                 "focus_distance_m": float(focus_distance_m), "model": model},
        "sensor": {"width_px": int(width_px), "height_px": int(width_px), "pixel_pitch_um": float(pixel_pitch_um)},
        "render": {"spp": int(spp), "seed": int(seed), "diffraction": diffraction},
    })


#: The optics study's renders: (label, thin-lens settings of :func:`bokeh_scene`).
OPTICS_RENDERS = (
    ("f/0.95", dict(f_number=0.95, focus_distance_m=0.5, source_depth_m=2.0, source_radius_m=0.003)),
    ("f/2.8", dict(f_number=2.8, focus_distance_m=0.5, source_depth_m=2.0, source_radius_m=0.003)),
    ("f/8", dict(f_number=8.0, focus_distance_m=0.5, source_depth_m=2.0, source_radius_m=0.003)),
    ("f/64 + diffraction", dict(f_number=64.0, focus_distance_m=0.5, source_depth_m=2.0, source_radius_m=0.003,
                                diffraction="on")),
    ("focus 24 mm (1:2), f/8", dict(f_number=8.0, focus_distance_m=0.024, source_depth_m=0.03,
                                    source_radius_m=2e-5)),
    ("focus 1e6 m ('infinity'), f/1.4", dict(f_number=1.4, focus_distance_m=1e6, source_depth_m=1.0,
                                             source_radius_m=0.0015)),
)


def _band_sum(image) -> np.ndarray:
    return np.asarray(image.data, dtype=np.float64).sum(axis=-1)


def optics_study(settings: StressSettings) -> dict:
    """Circle-of-confusion and diffraction regimes, analytic and rendered (study (c)).

    Analytic (:mod:`spectral_cam.optics`): the CoC diameter against object distance for
    f/0.95 … f/64 (f = 50 mm focused at 2 m) with the Airy diameters 2.44·λ·N_w; the map of
    the dominant blur (defocus, diffraction or the pixel; a pinhole is the A → 0 limit,
    CoC = 0) over f-number and distance for the default 8-mm lens; MTF
    lost at Nyquist to diffraction against f-number (the f-number at which the render starts
    applying the Airy PSF); the working f-number N·(1 + m) from 1:1 macro to 10⁶ m focus;
    the field of view from 4 to 600 mm. Rendered: one small source through a thin lens and
    through a pinhole of the same geometry for each case of :data:`OPTICS_RENDERS`; the
    blur diameter measured from second moments (:func:`measured_blur_diameter_px`) against
    the thin-lens formula.

    Parameters
    ----------
    settings
        ``optics_px`` and ``optics_spp`` of the renders.

    Returns
    -------
    dict
        ``rows``, ``data`` and ``images`` (band-sum renders for the figure).

    References
    ----------
    .. [1] Ray (2002), Applied Photographic Optics, ch. 10 (CoC, hyperfocal distance).
    .. [2] Hecht (2017), Optics, §10.2.5 (Airy disc 2.44·λ·N).
    .. [3] Goodman (2005), Introduction to Fourier Optics, §6.3.2 (diffraction MTF).
    """
    from .optics import MTF_TOLERANCE, ThinLens, defocus_mtf, diffraction_mtf, pixel_mtf
    from .render import render

    rows: list[dict] = []
    data: dict = {}
    pitch = _CHART_PITCH_UM * 1e-6
    distances = np.logspace(-1, 3, 240)
    curves = {}
    for n in F_NUMBERS:
        lens = _lens(_CHART_FOCAL_MM, n, _CHART_FOCUS_M)
        curves[f"{n:g}"] = {"coc_um": (lens.coc_diameter_m(distances) * 1e6).tolist(),
                            "airy_um": float(lens.airy_diameter_m(_GREEN_NM) * 1e6)}
    data["coc_vs_distance"] = {"focal_length_mm": _CHART_FOCAL_MM, "focus_m": _CHART_FOCUS_M,
                               "distances_m": distances.tolist(), "curves": curves}

    n_grid = np.logspace(np.log10(0.95), np.log10(64.0), 120)
    z_grid = np.logspace(-1, 3, 120)
    nyquist = 0.5 / pitch
    coc = np.empty((len(z_grid), len(n_grid)))
    airy = np.empty_like(coc)
    mtf = np.empty_like(coc)
    for j, n in enumerate(n_grid):
        lens = _lens(_REGIME_FOCAL_MM, n, _CHART_FOCUS_M)
        coc[:, j] = lens.coc_diameter_m(z_grid)
        airy[:, j] = lens.airy_diameter_m(_GREEN_NM)
        mtf[:, j] = (defocus_mtf(nyquist, coc[:, j]) * diffraction_mtf(nyquist, _GREEN_NM, lens.working_f_number)
                     * pixel_mtf(nyquist, pitch))
    # the blur that dominates: the pixel aperture, the CoC or the Airy disc (largest diameter)
    regime = np.argmax(np.stack([np.full_like(coc, pitch), coc, airy]), axis=0)  # 0 pixel, 1 defocus, 2 diffraction
    data["regime_map"] = {"focal_length_mm": _REGIME_FOCAL_MM, "focus_m": _CHART_FOCUS_M,
                          "f_numbers": n_grid.tolist(), "distances_m": z_grid.tolist(),
                          "regime": regime.tolist(), "mtf_at_nyquist": mtf.tolist(),
                          "labels": ["pixel", "defocus", "diffraction"]}
    for label, code in (("pixel", 0), ("defocus", 1), ("diffraction", 2)):
        rows.append(_row("optics", f"{_REGIME_FOCAL_MM:g} mm focused at {_CHART_FOCUS_M:g} m, f/0.95-f/64, 0.1-1000 m",
                         f"share of the (N, z) map where {label} dominates", float(np.mean(regime == code)), "fraction",
                         "largest of pixel pitch, CoC and Airy diameter (550 nm)"))

    n_fine = np.logspace(np.log10(0.95), np.log10(64.0), 200)
    cost = {}
    for pitch_um in (6.0, 2.0):
        for wl in (450.0, _GREEN_NM, _RED_NM):
            cost[f"{pitch_um:g} um, {wl:g} nm"] = (1.0 - diffraction_mtf(0.5 / (pitch_um * 1e-6), wl, n_fine)).tolist()
    limits = {f"{p:g}": diffraction_limit_f_number(p, _RED_NM) for p in (6.0, 4.0, 2.0)}
    data["diffraction_cost"] = {"f_numbers": n_fine.tolist(), "cost": cost, "tolerance": MTF_TOLERANCE,
                                "limit_f_number_700nm": limits}
    half = {f"{p:g}": diffraction_limit_f_number(p, _GREEN_NM, tolerance=0.5) for p in (6.0, 4.0, 2.0)}
    data["diffraction_cost"]["half_mtf_f_number_550nm"] = half
    for p, n in limits.items():
        rows.append(_row("optics", f"{p}-um pixels", "f-number where diffraction costs 0.03 MTF at Nyquist (700 nm)",
                         n, "N_w", "above it the render applies the per-band Airy PSF (render.diffraction = auto)"))
        rows.append(_row("optics", f"{p}-um pixels", "f-number where diffraction halves the MTF at Nyquist (550 nm)",
                         half[p], "N_w", "diffraction-limited beyond"))

    focus = {}
    for f_mm in (8.0, 50.0, 600.0):
        zf = np.logspace(np.log10(1.05 * f_mm * 1e-3), 6, 200)
        lenses = [_lens(f_mm, 2.8, z) for z in zf]
        focus[f"{f_mm:g}"] = {"focus_m": zf.tolist(),
                              "working_over_f_number": [lens.working_f_number / 2.8 for lens in lenses]}
    data["working_f_number"] = focus
    macro = _lens(50.0, 2.8, 0.1)  # z_f = 2f: 1:1
    rows.append(_row("optics", "50 mm at 1:1 (focus 0.1 m), f/2.8", "working f-number", macro.working_f_number,
                     "N_w", f"irradiance {(1 + 4 * 2.8 ** 2) / (1 + 4 * macro.working_f_number ** 2):.3f}× "
                            "that at infinity focus"))
    fov = {}
    for width_mm in (_CHART_WIDTH_PX * _CHART_PITCH_UM * 1e-3, 36.0):
        fov[f"{width_mm:g}"] = [math.degrees(2 * math.atan(width_mm / (2 * f))) for f in FOCAL_LENGTHS_MM]
    data["fov"] = {"focal_lengths_mm": list(FOCAL_LENGTHS_MM), "fov_deg": fov}
    for f_mm in (FOCAL_LENGTHS_MM[0], FOCAL_LENGTHS_MM[-1]):
        rows.append(_row("optics", f"{f_mm:g} mm on a 36-mm-wide sensor", "horizontal field of view (infinity focus)",
                         math.degrees(2 * math.atan(36.0 / (2 * f_mm))), "deg"))
    for n in (0.95, 64.0):
        lens = _lens(_CHART_FOCAL_MM, n, _CHART_FOCUS_M)
        rows.append(_row("optics", f"50 mm f/{n:g} focused at 2 m", "CoC diameter of a point at infinity",
                         float(lens.coc_diameter_px(math.inf)), "px", f"{_CHART_PITCH_UM:g}-um pixels"))
        rows.append(_row("optics", f"50 mm f/{n:g} focused at 2 m", "Airy diameter 2.44·λ·N_w at 550 nm",
                         float(lens.airy_diameter_m(_GREEN_NM) / pitch), "px"))
    far = _lens(8.0, 1.4, 1e6)
    rows.append(_row("optics", "8 mm f/1.4 focused at 1e6 m", "CoC of a point at 1 m (limit A·f/z)",
                     float(far.coc_diameter_px(1.0)), "px",
                     f"A·f/z = {far.aperture_radius_m * 2 * far.focal_length_m / 1.0 / far.pixel_pitch_m:.4g} px"))

    # ------------------------------------------------------------------ renders
    size, spp = settings.optics_px, settings.optics_spp
    images: dict[str, np.ndarray] = {}
    cache: dict = {}
    renders = []

    def band_sum_of(config):
        key = json.dumps(config.to_dict(), sort_keys=True)
        if key not in cache:
            started = time.perf_counter()
            cache[key] = (_band_sum(render(config, with_depth=False)), time.perf_counter() - started)
        return cache[key]

    for index, (label, kwargs) in enumerate(OPTICS_RENDERS):
        kwargs = dict(kwargs)
        diffraction = kwargs.pop("diffraction", "off")
        seed = _seed(settings, 5, index)
        thin_cfg = bokeh_scene(width_px=size, model="thin", spp=spp, seed=seed, diffraction=diffraction, **kwargs)
        pin_cfg = bokeh_scene(width_px=size, model="pinhole", spp=spp, seed=seed + 1, diffraction=diffraction, **kwargs)
        thin, thin_s = band_sum_of(thin_cfg)
        pin, _ = band_sum_of(pin_cfg)
        lens = ThinLens.from_config(thin_cfg.lens, thin_cfg.sensor)
        predicted = float(lens.coc_diameter_px(kwargs["source_depth_m"]))
        measured = measured_blur_diameter_px(thin, pin)
        entry = {"label": label, "predicted_coc_px": predicted, "measured_coc_px": measured,
                 "airy_diameter_px": float(lens.airy_diameter_m(_GREEN_NM) / lens.pixel_pitch_m),
                 "working_f_number": lens.working_f_number, "render_s": thin_s}
        if diffraction == "on":
            sharp_cfg = bokeh_scene(width_px=size, model="pinhole", spp=spp, seed=seed + 1, diffraction="off", **kwargs)
            sharp, _ = band_sum_of(sharp_cfg)
            entry["peak_ratio_diffraction"] = float(pin.max() / sharp.max())
            images["pinhole (no diffraction)"] = sharp
            rows.append(_row("optics", f"render: {label}", "peak intensity with / without diffraction (pinhole)",
                             entry["peak_ratio_diffraction"], "ratio",
                             f"Airy diameter {entry['airy_diameter_px']:.3g} px, source image "
                             f"{2 * kwargs['source_radius_m'] * lens.image_distance_m / kwargs['source_depth_m'] / lens.pixel_pitch_m:.3g} px"))
        images[label] = thin
        renders.append(entry)
        # second moments of pixel-sampled images carry a sampling error of about
        # ±0.15 px² (Sheppard), i.e. ±0.6/c px on the diameter c
        uncertainty = 0.6 / max(predicted, 0.5)
        entry["measurement_uncertainty_px"] = uncertainty
        rows.append(_row("optics", f"render: {label}", "measured / predicted CoC diameter",
                         measured / predicted if predicted > 1.0 else None, "ratio",
                         f"predicted {predicted:.3g} px, measured {measured:.3g} ± {uncertainty:.2g} px"
                         + ("" if predicted > 1.0 else " (below 1 px: in focus)")))
    data["renders"] = renders
    return {"rows": rows, "data": data, "images": images}


def plot_optics(result: dict, directory: Path) -> list[str]:
    """Figures of :func:`optics_study`: CoC and diffraction regimes, MTF and focus extremes,
    and the renders."""
    from matplotlib.colors import ListedColormap

    data = result["data"]
    written = []
    fig = _figure(13, 4.6)
    ax1, ax2 = fig.subplots(1, 2)
    coc = data["coc_vs_distance"]
    distances = np.asarray(coc["distances_m"])
    for name, curve in coc["curves"].items():
        if name not in ("0.95", "2.8", "8", "22", "64"):
            continue
        line, = ax1.loglog(distances, np.maximum(curve["coc_um"], 1e-3), label=f"f/{name} CoC")
        ax1.axhline(curve["airy_um"], color=line.get_color(), ls="--", lw=0.9)
    ax1.axhline(_CHART_PITCH_UM, color="k", lw=1.2, label=f"pixel pitch {_CHART_PITCH_UM:g} µm")
    ax1.axvline(coc["focus_m"], color="gray", ls=":")
    ax1.set_ylim(0.1, 1e4)
    ax1.set_xlabel("object distance (m)")
    ax1.set_ylabel("blur diameter on the sensor (µm)")
    ax1.set_title(f"{coc['focal_length_mm']:g} mm focused at {coc['focus_m']:g} m: CoC (solid) vs Airy 2.44λN_w (dashed)",
                  fontsize=9)
    ax1.legend(fontsize=8)
    regime = data["regime_map"]
    n_grid, z_grid = np.asarray(regime["f_numbers"]), np.asarray(regime["distances_m"])
    cmap = ListedColormap(["#d9d9d9", "#9ecae1", "#fdae6b"])
    ax2.pcolormesh(n_grid, z_grid, np.asarray(regime["regime"]), cmap=cmap, vmin=-0.5, vmax=2.5, shading="auto")
    contours = ax2.contour(n_grid, z_grid, np.asarray(regime["mtf_at_nyquist"]), levels=[0.2, 0.4], colors="k",
                           linewidths=0.7)
    ax2.clabel(contours, fontsize=7, fmt="MTF %.1f")
    ax2.set_xscale("log"), ax2.set_yscale("log")
    ax2.set_xlabel("f-number")
    ax2.set_ylabel("object distance (m)")
    ax2.set_title(f"{regime['focal_length_mm']:g} mm focused at {regime['focus_m']:g} m, {_CHART_PITCH_UM:g}-µm pixels: "
                  "dominant blur\ngrey pixel, blue defocus (CoC), orange diffraction; contours: total MTF at Nyquist",
                  fontsize=9)
    written.append(_save(fig, directory, "optics_regimes.png"))

    fig = _figure(14, 4.2)
    ax1, ax2, ax3 = fig.subplots(1, 3)
    cost = data["diffraction_cost"]
    for name, values in cost["cost"].items():
        ax1.semilogx(cost["f_numbers"], values, label=name)
    ax1.axhline(cost["tolerance"], color="k", ls="--", lw=0.8, label="model decision threshold 0.03")
    ax1.set_xlabel("working f-number")
    ax1.set_ylabel("MTF lost to diffraction at Nyquist")
    ax1.set_title("Diffraction regime vs pixel pitch and wavelength", fontsize=9)
    ax1.legend(fontsize=7)
    for name, entry in data["working_f_number"].items():
        ax2.semilogx(entry["focus_m"], entry["working_over_f_number"], label=f"f = {name} mm")
    ax2.set_xlabel("focus distance (m); 10⁶ m ≈ infinity")
    ax2.set_ylabel("N_w / N = 1 + m")
    ax2.set_yscale("log")
    ax2.set_title("Focus near the lens: working f-number", fontsize=9)
    ax2.legend(fontsize=8)
    fov = data["fov"]
    for width, values in fov["fov_deg"].items():
        ax3.loglog(fov["focal_lengths_mm"], values, "o-", label=f"sensor width {width} mm")
    ax3.set_xlabel("focal length (mm)")
    ax3.set_ylabel("horizontal field of view (deg)")
    ax3.set_title("Wide to long focal lengths", fontsize=9)
    ax3.legend(fontsize=8)
    written.append(_save(fig, directory, "optics_mtf_focus.png"))

    images = result.get("images") or {}
    if images:
        renders = {r["label"]: r for r in data["renders"]}
        fig = _figure(2.2 * len(images), 2.6)
        axes = fig.subplots(1, len(images), squeeze=False)[0]
        for ax, (label, image) in zip(axes, images.items()):
            ax.imshow(image / max(image.max(), 1e-30), cmap="magma", interpolation="nearest")
            ax.set_xticks([]), ax.set_yticks([])
            entry = renders.get(label)
            text = label if entry is None else (f"{label}\nCoC {entry['predicted_coc_px']:.2f} px pred.,"
                                                f"\n{entry['measured_coc_px']:.2f} px measured")
            ax.set_title(text, fontsize=7)
        fig.suptitle("Tiny renders of one small source: thin lens (pinhole twins subtracted for the measurement)",
                     fontsize=9)
        written.append(_save(fig, directory, "optics_renders.png"))
    return written


# ============================================================================= (d) bokeh
def _light_tracer(config, *, spp: int, seed: int) -> tuple[np.ndarray, float]:
    """Luminance image (arbitrary units) of Mitsuba's particle tracer through the thin lens
    (``ptracer`` accepts RGB/luminance films only, not ``specfilm``) and its render time (s)."""
    import mitsuba as mi

    from .optics import ThinLens
    from .presets import build_objects
    from .render import choose_variant

    mi.set_variant(choose_variant(config.render.variant))
    lens = ThinLens.from_config(config.lens, config.sensor)
    width, height = config.sensor.width_px, config.sensor.height_px
    camera = {
        "type": "thinlens", "fov": lens.fov_x_deg, "fov_axis": "x",
        "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 0], target=[0, 0, 1], up=[0, 1, 0]),
        "aperture_radius": lens.aperture_radius_m, "focus_distance": lens.focus_distance_m,
        "near_clip": min(1e-3, lens.focus_distance_m / 10),
        "sampler": {"type": "independent", "sample_count": spp},
        "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
                 "pixel_format": "luminance", "component_format": "float32"},
    }
    scene = {"type": "scene", "integrator": {"type": "ptracer", "max_depth": config.render.max_depth},
             "sensor": camera, **build_objects(config, lens, mi)}
    loaded = mi.load_dict(scene)
    started = time.perf_counter()
    image = np.asarray(mi.render(loaded, seed=seed, spp=spp), dtype=np.float64).reshape(height, width, -1)[..., 0]
    return image, time.perf_counter() - started


#: The bokeh study's scene (keywords of :func:`bokeh_scene`): a 2.4-mm source at 3 m seen by
#: an 8-mm f/1.4 lens focused at 0.3 m; its 1.1-px image blurs into a 23.5-px disc, so a
#: pixel inside the disc sees the source through p = 0.22 % of the aperture.
#: Independent remedy renders per spp (its error is a random level error: averaged in quadrature).
BOKEH_REMEDY_REPEATS = 3
BOKEH_CASE = dict(pixel_pitch_um=6.0, focal_length_mm=8.0, f_number=1.4, focus_distance_m=0.3,
                  source_depth_m=3.0, source_radius_m=0.0012)


def _disc_mask(size: int, diameter_px: float, *, inset_px: float = 1.5) -> np.ndarray:
    y, x = np.mgrid[0:size, 0:size] + 0.5 - size / 2.0
    return np.hypot(x, y) < 0.5 * diameter_px - inset_px


def _relative_error(image: np.ndarray, reference: np.ndarray, mask: np.ndarray, reference_var: float) -> tuple[float, float]:
    """(raw, reference-noise-corrected) RMS error inside the mask relative to the reference mean."""
    mean = float(reference[mask].mean())
    mse = float(np.mean((image[mask] - reference[mask]) ** 2))
    return math.sqrt(mse) / mean, math.sqrt(max(mse - reference_var, 0.0)) / mean


def bokeh_study(settings: StressSettings) -> dict:
    """Monte-Carlo noise of a small bright source far out of focus, and the remedy (study (d)).

    The scene is :data:`BOKEH_CASE`. Measured inside the blur disc (its interior, 1.5 px in
    from the CoC edge) on the band sum of the spectral radiance: the per-pixel relative
    noise of the thin-lens path tracer and of the light tracer against spp and render time,
    and the per-pixel RMS error of :func:`render_defocus_remedy` against a thin-lens
    reference of 2 × ``bokeh_reference_spp`` samples per pixel (the reference's own noise,
    measured from its two independent halves, is subtracted in quadrature). Times exclude
    Mitsuba's first JIT compilation (a warm-up render of each kind runs first).

    Parameters
    ----------
    settings
        Image size, the spp series and the reference spp.

    Returns
    -------
    dict
        ``rows``, ``data`` (series with spp, seconds, noise, errors; aperture fraction p;
        CoC; reference noise; equal-time comparisons; the remedy's spectral error) and
        ``images`` for the figure.

    References
    ----------
    .. [1] Veach (1997), PhD thesis, §10.2 (light tracing).
    .. [2] Potmesil & Chakravarty (1981); Kraus & Strengert (2007) (the remedy).
    """
    from .optics import ThinLens
    from .render import render

    size = settings.bokeh_px
    case = dict(BOKEH_CASE, width_px=size)
    base = bokeh_scene(model="thin", spp=1, **case)
    lens = ThinLens.from_config(base.lens, base.sensor)
    coc = float(lens.coc_diameter_px(case["source_depth_m"]))
    p = aperture_fraction(base)
    disc = _disc_mask(size, coc)
    if disc.sum() < 20:
        raise ConfigError(f"bokeh_px = {size} leaves too few pixels inside the {coc:.3g}-px blur disc")

    def thin(spp, seed):
        started = time.perf_counter()
        image = render(bokeh_scene(model="thin", spp=spp, seed=seed, **case), with_depth=False)
        return image, time.perf_counter() - started

    # warm-up: Mitsuba compiles its kernels on first use; not part of any method's time
    thin(settings.bokeh_thin_spp[0], 1)
    render_layered(bokeh_scene(model="pinhole", spp=settings.bokeh_remedy_spp[0], seed=2, **case))
    _light_tracer(base, spp=settings.bokeh_tracer_spp[0], seed=3)

    reference_a, _ = thin(settings.bokeh_reference_spp, _seed(settings, 6, 1))
    reference_b, _ = thin(settings.bokeh_reference_spp, _seed(settings, 6, 2))
    ref_a, ref_b = _band_sum(reference_a), _band_sum(reference_b)
    reference = 0.5 * (ref_a + ref_b)
    reference_var = float(np.mean((0.5 * (ref_a - ref_b))[disc] ** 2))
    ref_mean = float(reference[disc].mean())
    spectrum_a, spectrum_b = reference_a.data[disc].mean(axis=0), reference_b.data[disc].mean(axis=0)
    ref_spectrum = 0.5 * (spectrum_a + spectrum_b)
    # relative variance of the reference's per-band disc means, from its two halves
    ref_band_var = float(np.mean((0.5 * (spectrum_a - spectrum_b) / ref_spectrum) ** 2))
    data: dict = {
        "coc_px": coc, "aperture_fraction": p, "disc_pixels": int(disc.sum()),
        "reference_spp": 2 * settings.bokeh_reference_spp,
        "reference_noise": math.sqrt(reference_var) / ref_mean,
        "reference_level_noise": math.sqrt(reference_var / disc.sum()) / ref_mean,
        "reference_band_noise": math.sqrt(ref_band_var),
        # the corrected per-pixel error is known to about ±(var_ref·√(2/N))^½
        "error_floor": math.sqrt(reference_var * math.sqrt(2.0 / disc.sum())) / ref_mean,
        "predicted_noise_coefficient": math.sqrt((1.0 - p) / p),
        "thin": {"spp": [], "seconds": [], "noise": [], "error": [], "error_corrected": []},
        "tracer": {"spp": [], "seconds": [], "noise": []},
        "remedy": {"spp": [], "seconds": [], "error": [], "error_corrected": [], "level_error": [],
                   "spectral_error": [], "repeats": BOKEH_REMEDY_REPEATS},
        "wavelengths_nm": [float(w) for w in reference_a.wavelengths_nm],
        "reference_spectrum": ref_spectrum.tolist(),
    }
    images = {"reference": reference}
    for index, spp in enumerate(settings.bokeh_thin_spp):
        image, seconds = thin(spp, _seed(settings, 7, index))
        total = _band_sum(image)
        raw, corrected = _relative_error(total, reference, disc, reference_var)
        entry = data["thin"]
        entry["spp"].append(spp), entry["seconds"].append(seconds)
        entry["noise"].append(float(total[disc].std() / total[disc].mean()))
        entry["error"].append(raw), entry["error_corrected"].append(corrected)
        images[f"thin lens, {spp} spp"] = total
    for index, spp in enumerate(settings.bokeh_tracer_spp):
        image, seconds = _light_tracer(base, spp=spp, seed=_seed(settings, 8, index))
        entry = data["tracer"]
        entry["spp"].append(spp), entry["seconds"].append(seconds)
        entry["noise"].append(float(image[disc].std() / image[disc].mean()))
        images[f"light tracer (luminance), {spp} spp"] = image
    remedy_spectrum = None
    for index, spp in enumerate(settings.bokeh_remedy_spp):
        seconds, squared, levels, spectral = [], [], [], []
        for repeat in range(BOKEH_REMEDY_REPEATS):
            started = time.perf_counter()
            remedy = render_layered(bokeh_scene(model="pinhole", spp=spp,
                                                       seed=_seed(settings, 9, index, repeat), **case))
            seconds.append(time.perf_counter() - started)
            total = _band_sum(remedy)
            squared.append(float(np.mean((total[disc] - reference[disc]) ** 2)))
            levels.append(float(total[disc].mean() / ref_mean - 1.0))
            spectrum = remedy.data[disc].mean(axis=0)
            spectral.append(float(np.mean((spectrum / ref_spectrum - 1.0) ** 2)))
        mse = float(np.mean(squared))
        entry = data["remedy"]
        entry["spp"].append(spp), entry["seconds"].append(float(np.mean(seconds)))
        entry["error"].append(math.sqrt(mse) / ref_mean)
        entry["error_corrected"].append(math.sqrt(max(mse - reference_var, 0.0)) / ref_mean)
        entry["level_error"].append(float(np.sqrt(np.mean(np.square(levels)))))
        entry["spectral_error"].append(math.sqrt(max(float(np.mean(spectral)) - ref_band_var, 0.0)))
        images[f"remedy, {spp} spp"] = total
        remedy_spectrum = spectrum
    data["remedy_spectrum"] = None if remedy_spectrum is None else remedy_spectrum.tolist()

    # thin-lens noise follows b/√spp and a/√t: fit the constants through the measurements
    thin_data = data["thin"]
    spp_arr, sec_arr = np.asarray(thin_data["spp"], float), np.asarray(thin_data["seconds"], float)
    noise_arr = np.asarray(thin_data["noise"])
    b = float(np.exp(np.mean(np.log(noise_arr * np.sqrt(spp_arr)))))
    a = float(np.exp(np.mean(np.log(np.asarray(thin_data["error_corrected"]).clip(1e-9) * np.sqrt(sec_arr)))))
    seconds_per_spp = float(np.exp(np.mean(np.log(sec_arr / spp_arr))))
    spp_one_percent = (b / 0.01) ** 2
    data.update({"thin_noise_coefficient": b, "thin_error_time_coefficient": a,
                 "thin_spp_for_1_percent": spp_one_percent,
                 "thin_seconds_for_1_percent": spp_one_percent * seconds_per_spp})
    equal_time = [a / math.sqrt(t) for t in data["remedy"]["seconds"]]
    data["remedy"]["thin_error_at_equal_time"] = equal_time

    rows = [
        _row("bokeh", "scene", "blur-disc (CoC) diameter", coc, "px",
             f"source image {2 * case['source_radius_m'] * lens.image_distance_m / case['source_depth_m'] / lens.pixel_pitch_m:.2g} px"),
        _row("bokeh", "scene", "aperture fraction p seeing the source", p, "fraction",
             f"predicted thin-lens noise √((1-p)/p)/√spp = {math.sqrt((1 - p) / p):.3g}/√spp"),
        _row("bokeh", "thin-lens reference", "per-pixel noise of the reference", data["reference_noise"], "relative",
             f"{data['reference_spp']} spp; subtracted in quadrature from the errors below"),
    ]
    for spp, noise, seconds in zip(thin_data["spp"], thin_data["noise"], thin_data["seconds"]):
        rows.append(_row("bokeh", f"thin-lens path tracer, {spp} spp", "per-pixel noise inside the blur disc",
                         noise, "relative", f"{seconds:.2f} s"))
    rows.append(_row("bokeh", "thin-lens path tracer", "spp for 1 % per-pixel noise (fit b/√spp)",
                     spp_one_percent, "spp", f"≈ {data['thin_seconds_for_1_percent']:.3g} s at this size"))
    for spp, noise, seconds in zip(data["tracer"]["spp"], data["tracer"]["noise"], data["tracer"]["seconds"]):
        rows.append(_row("bokeh", f"light tracer (luminance film only), {spp} spp",
                         "per-pixel noise inside the blur disc", noise, "relative", f"{seconds:.2f} s"))
    remedy = data["remedy"]
    for spp, err, level, spec, seconds, eq in zip(remedy["spp"], remedy["error_corrected"], remedy["level_error"],
                                                  remedy["spectral_error"], remedy["seconds"], equal_time):
        rows.append(_row("bokeh", f"remedy (pinhole {spp} spp + depth layers)",
                         "per-pixel RMS error vs converged thin lens", err, "relative",
                         f"{seconds:.2f} s (thin lens at equal time: {eq:.3g}); disc level error {level:.3g}; "
                         f"per-band error {spec:.3g}; estimation floor ±{data['error_floor']:.2g}"))
    return {"rows": rows, "data": data, "images": images}


def plot_bokeh(result: dict, directory: Path) -> list[str]:
    """Figures of :func:`bokeh_study`: noise against spp and time; images, profiles, spectra."""
    data, images = result["data"], result["images"]
    written = []
    fig = _figure(12, 4.4)
    ax1, ax2 = fig.subplots(1, 2)
    thin, tracer, remedy = data["thin"], data["tracer"], data["remedy"]
    spp = np.asarray(thin["spp"], float)
    grid = np.logspace(0, np.log10(max(spp.max(), 1e6)), 50)
    ax1.loglog(spp, thin["noise"], "o-", label="thin-lens path tracer (spectral)")
    ax1.loglog(grid, data["predicted_noise_coefficient"] / np.sqrt(grid), ":", color="gray",
               label=f"√((1−p)/(p·spp)), p = {data['aperture_fraction']:.2g}")
    ax1.loglog(tracer["spp"], tracer["noise"], "s-", label="light tracer (luminance film only)")
    ax1.loglog(remedy["spp"], np.maximum(remedy["error_corrected"], 1e-4), "^-",
               label="remedy: pinhole + depth layers (spectral),\nerror vs converged thin lens")
    ax1.axhline(data["error_floor"], color="tab:green", lw=0.6, ls=":", label="floor of that error estimate")
    ax1.axhline(data["reference_noise"], color="k", lw=0.6, ls="--", label="reference's own noise")
    ax1.set_xlabel("samples per pixel")
    ax1.set_ylabel("per-pixel relative error inside the blur disc")
    ax1.set_title(f"Bokeh of a 1-px source, CoC {data['coc_px']:.1f} px")
    ax1.legend(fontsize=7)
    ax2.loglog(thin["seconds"], thin["noise"], "o-", label="thin-lens path tracer")
    ax2.loglog(tracer["seconds"], tracer["noise"], "s-", label="light tracer (not spectral)")
    ax2.loglog(remedy["seconds"], np.maximum(remedy["error_corrected"], 1e-4), "^-", label="remedy")
    ax2.set_xlabel("render time (s), 2 cores, after JIT warm-up")
    ax2.set_ylabel("per-pixel relative error inside the blur disc")
    ax2.set_title("Error against time")
    ax2.legend(fontsize=8)
    written.append(_save(fig, directory, "bokeh_convergence.png"))

    picks = [name for name in images if name != "reference"]
    chosen = ([n for n in picks if n.startswith("thin")][1:2] + [n for n in picks if n.startswith("thin")][-1:]
              + [n for n in picks if n.startswith("light")][-1:] + [n for n in picks if n.startswith("remedy")][-2:-1]
              + ["reference"])
    fig = _figure(2.5 * len(chosen) + 3.5, 3.2)
    axes = fig.subplots(1, len(chosen) + 1, width_ratios=[1] * len(chosen) + [1.6])
    reference = images["reference"]
    size = reference.shape[0]
    scale = float(reference[_disc_mask(size, data["coc_px"])].mean())
    y, x = np.mgrid[0:size, 0:size] + 0.5 - size / 2.0
    ring = np.floor(np.hypot(x, y)).astype(int)
    counts = np.bincount(ring.ravel())
    for ax, name in zip(axes, chosen):
        image = images[name]
        image_scale = scale if not name.startswith("light") else float(image[_disc_mask(size, data["coc_px"])].mean())
        ax.imshow(image / max(image_scale, 1e-30), cmap="magma", vmin=0, vmax=2.0, interpolation="nearest")
        ax.set_xticks([]), ax.set_yticks([])
        ax.set_title(name, fontsize=7)
        if not name.startswith("light"):
            profile = np.bincount(ring.ravel(), image.ravel()) / np.maximum(counts, 1)
            axes[-1].plot(profile / max(scale, 1e-30), label=name)
    axes[-1].set_xlabel("radius (px)")
    axes[-1].set_ylabel("ring mean / reference disc mean")
    axes[-1].set_title("radial profiles", fontsize=8)
    axes[-1].legend(fontsize=6)
    written.append(_save(fig, directory, "bokeh_images.png"))

    if data.get("remedy_spectrum") is not None:
        fig = _figure(6, 3.6)
        ax = fig.subplots()
        ax.plot(data["wavelengths_nm"], data["reference_spectrum"], "k-", label="thin-lens reference")
        ax.plot(data["wavelengths_nm"], data["remedy_spectrum"], "o", ms=3,
                label=f"remedy, {data['remedy']['spp'][-1]} spp")
        ax.set_xlabel("band centre (nm)")
        ax.set_ylabel("mean band radiance in the disc (W·m⁻²·sr⁻¹)")
        ax.set_title("The remedy keeps the spectrum", fontsize=9)
        ax.legend(fontsize=8)
        written.append(_save(fig, directory, "bokeh_spectrum.png"))
    return written


# ============================================================================= (e) illuminants
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
    from .io import atomic_path

    wavelengths = np.arange(360.0, 831.0, 1.0)
    sigma = fwhm_nm / (2.0 * math.sqrt(2.0 * math.log(2.0)))
    values = sum(np.exp(-0.5 * ((wavelengths - peak) / sigma) ** 2) for peak in peaks_nm)
    path = Path(path)
    with atomic_path(path) as tmp:
        with open(tmp, "w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(["wavelength_nm", "value"])
            writer.writerows((f"{w:g}", f"{v:.6g}") for w, v in zip(wavelengths, values))
    return path


def chart_radiance(illuminant: str, *, patch_px: int, lux: float = 1000.0):
    """A synthetic ColorChecker: 6 × 4 blocks of ``patch_px`` pixels, each the radiance
    ρ(λ)·E(λ)/π of a BabelColor patch under the illuminant (band integrals, 400:700:10).

    Parameters
    ----------
    illuminant
        Illuminant name or CSV path (:func:`spectral_cam.spectra.illuminant`).
    patch_px
        Side of a patch, pixels.
    lux
        Illuminance on the chart, lx.

    Returns
    -------
    (SpectralImage, list of (slice, slice))
        The chart and the interior (middle half) of every patch in chart order.

    References
    ----------
    .. [1] McCamy, Marcus & Davidson (1976) (the chart); Pascale (2006), BabelColor
       averages; Lambert's law L = ρ·E/π.
    """
    from . import spectra

    bands = _bands()
    wl, irradiance = spectra.absolute_irradiance(illuminant, lux)
    reflectances = np.stack([spectra.sample(sd, wl) for sd in spectra.colorchecker_reflectances().values()])
    radiance = spectra.band_integrals(reflectances * irradiance / np.pi, wl, bands).astype(np.float32)
    data = np.zeros((4 * patch_px, 6 * patch_px, len(bands)), np.float32)
    interiors = []
    margin = patch_px // 4
    for index in range(24):
        row, col = divmod(index, 6)
        data[row * patch_px:(row + 1) * patch_px, col * patch_px:(col + 1) * patch_px] = radiance[index]
        interiors.append((slice(row * patch_px + margin, (row + 1) * patch_px - margin),
                          slice(col * patch_px + margin, (col + 1) * patch_px - margin)))
    return _spectral_image(data, bands), interiors


#: White-balance choices and colour-matrix sources of the illuminant study.
STUDY_WHITE_BALANCE = ("as_shot", "grey_world", "white_patch")
STUDY_COLOUR_MATRICES = ("dng_d65", "dng", "fitted")


def illuminant_study(settings: StressSettings, *, directory: Path | None = None, illuminants=None) -> dict:
    """ΔE2000 of the colour pipeline under illuminants far from the D65 calibration (study (e)).

    The synthetic chart (:func:`chart_radiance`) is exposed by the ``nikon_d850`` sensor
    (ISO 100, all noise terms on, white patch at 0.8 of saturation), developed with each
    white balance of :data:`STUDY_WHITE_BALANCE` and each colour matrix of
    :data:`STUDY_COLOUR_MATRICES` — ``"dng_d65"``: the D65-calibrated ColorMatrix1 alone
    (what LibRaw uses) with a Bradford adaptation from the white-balance neutral; ``"dng"``:
    ColorMatrix1 and ColorMatrix2 (Standard A) interpolated by the white's CCT;
    ``"fitted"``: the 3×3 matrix fitted under the scene illuminant — tone curve off, and compared per patch with the analytic
    ground truth (:func:`spectral_cam.colorimetry.patch_linear_srgb`), exposure matched on
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
    from . import colorimetry
    from . import sensor as S
    from .isp import ISPConfig, develop
    from .metrics import delta_e2000
    from .scene import scene_from_dict

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
    for i_index, illuminant in enumerate(names):
        image, interiors = chart_radiance(illuminant, patch_px=patch)
        config = scene_from_dict({"illuminant": {"spd": illuminant},
                                  "sensor": {"model": STUDY_CAMERA, "width_px": 6 * patch, "height_px": 4 * patch,
                                             "vignetting": False},
                                  "exposure": {"time_s": "auto", "auto_fraction": 0.8}})
        white = np.zeros((4 * patch, 6 * patch), bool)
        white[interiors[WHITE_INDEX]] = True
        raw = S.expose(image, config, white_mask=white, frame_seed=_seed(settings, 10, i_index))
        reference = colorimetry.patch_linear_srgb(illuminant)
        entry: dict = {"label": labels[illuminant], "results": {}}
        d65_only = dataclasses.replace(raw, color_matrix_2=None)
        for matrix in STUDY_COLOUR_MATRICES:
            source = d65_only if matrix == "dng_d65" else raw
            for balance in STUDY_WHITE_BALANCE:
                developed = develop(source, ISPConfig(white_balance=balance, colour_matrix=matrix.replace("_d65", ""),
                                                      tone="linear", highlights="none"))
                means = np.array([developed.linear[s].reshape(-1, 3).astype(float).mean(axis=0) for s in interiors])
                delta = delta_e2000(means, reference, exposure_match_index=WHITE_INDEX)
                entry["results"][f"{matrix}/{balance}"] = {
                    "delta_e": delta.tolist(), "mean": float(delta.mean()), "max": float(delta.max()),
                    "gains": developed.meta["white_balance_gains"]}
                rows.append(_row("illuminants", f"{labels[illuminant]}", f"mean ΔE2000, {matrix} matrix, {balance}",
                                 float(delta.mean()), "ΔE00", f"max {delta.max():.2f}"))
        data["illuminants"][labels[illuminant]] = entry
    return {"rows": rows, "data": data}


def plot_illuminants(result: dict, directory: Path) -> list[str]:
    """Figure of :func:`illuminant_study`: mean (bars) and max (ticks) ΔE2000 per illuminant,
    colour matrix and white balance."""
    data = result["data"]["illuminants"]
    labels = list(data)
    combos = list(next(iter(data.values()))["results"])
    fig = _figure(max(9, 1.6 * len(labels) + 3), 4.6)
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
    return [_save(fig, directory, "illuminants_delta_e.png")]


# ============================================================================= summary + CLI
#: The studies in run order: name → (study function, plot function, one-line description).
STUDIES: dict[str, tuple[Callable, Callable, str]] = {
    "demosaic": (demosaic_study, plot_demosaic, "demosaicing on checkerboards and a zone plate"),
    "exposure": (exposure_study, plot_exposure, "0.01 to 1e5 electrons: bias, clipping, highlights, SNR"),
    "optics": (optics_study, plot_optics, "f/0.95 to f/64, pinhole, near/infinity focus, 4 to 600 mm"),
    "bokeh": (bokeh_study, plot_bokeh, "out-of-focus point sources: Monte-Carlo noise and the remedy"),
    "illuminants": (illuminant_study, plot_illuminants, "ΔE2000 under A, FL11 and LEDs vs white balance"),
}
SUMMARY_FIELDS = ("study", "case", "metric", "value", "unit", "note")


def _format_value(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    magnitude = abs(value)
    return f"{value:.4g}" if magnitude == 0 or 1e-3 <= magnitude < 1e5 else f"{value:.3e}"


def write_summary(rows: list[dict], directory: Path) -> list[str]:
    """Write the summary table as ``summary.csv`` and ``summary.png``.

    Parameters
    ----------
    rows
        Dicts with the keys of :data:`SUMMARY_FIELDS` (``value`` a float or None).
    directory
        Output folder.

    Returns
    -------
    list of str
        The file names written.
    """
    from .io import atomic_path

    directory = Path(directory)
    with atomic_path(directory / "summary.csv") as tmp:
        with open(tmp, "w", newline="", encoding="utf-8") as handle:
            writer = csv.DictWriter(handle, fieldnames=SUMMARY_FIELDS)
            writer.writeheader()
            for row in rows:
                writer.writerow({**row, "value": _format_value(row["value"])})
    cells = [[row["study"], row["case"][:44], row["metric"][:58], _format_value(row["value"]), row["unit"],
              row["note"][:70]] for row in rows]
    fig = _figure(17, 0.6 + 0.19 * (len(cells) + 1))
    ax = fig.subplots()
    ax.axis("off")
    table = ax.table(cellText=cells or [[""] * 6], colLabels=list(SUMMARY_FIELDS), loc="upper left",
                     cellLoc="left", colLoc="left", colWidths=[0.06, 0.2, 0.27, 0.07, 0.05, 0.35])
    table.auto_set_font_size(False)
    table.set_fontsize(7)
    table.scale(1.0, 1.0)
    for (r, _), cell in table.get_celld().items():
        cell.set_height(1.0 / (len(cells) + 1))
        if r == 0:
            cell.set_text_props(weight="bold")
    return ["summary.csv", _save(fig, directory, "summary.png", dpi=80, palette=True)]


def _json_ready(value):
    if isinstance(value, dict):
        return {str(k): _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return _json_ready(value.tolist())
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else str(float(value))
    if isinstance(value, np.integer):
        return int(value)
    return value


def run_studies(directory: Path, settings: StressSettings, *, only=None, log=None) -> dict:
    """Run the chosen studies, write their figures, the summary and ``results.json`` into
    ``directory`` (which must exist).

    Parameters
    ----------
    directory
        Output folder.
    settings
        Study sizes (:meth:`StressSettings.quick` or :meth:`StressSettings.full`).
    only
        Study names (keys of :data:`STUDIES`); default all.
    log
        Called with one progress line per study.

    Returns
    -------
    dict
        The content of ``results.json``: settings, per-study data, rows, files and timings.
    """
    directory = Path(directory)
    names = list(STUDIES) if not only else [name for name in STUDIES if name in set(only)]
    rows: list[dict] = []
    results: dict = {"settings": dataclasses.asdict(settings), "studies": {}, "timings_s": {}, "files": []}
    for name in names:
        study, plot, _ = STUDIES[name]
        started = time.perf_counter()
        result = study(settings, directory=directory) if name == "illuminants" else study(settings)
        files = plot(result, directory)
        seconds = time.perf_counter() - started
        rows += result["rows"]
        results["studies"][name] = {"data": result["data"], "rows": result["rows"]}
        results["timings_s"][name] = seconds
        results["files"] += files
        if log is not None:
            log(f"{name}: {seconds:.1f} s, {len(files)} charts")
    results["files"] += write_summary(rows, directory)
    from .job import package_versions

    results["versions"] = package_versions()
    from .io import atomic_path

    with atomic_path(directory / "results.json") as tmp:
        tmp.write_text(json.dumps(_json_ready(results), indent=1, ensure_ascii=False), encoding="utf-8")
    results["files"].append("results.json")
    return results


def configure_parser(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``spectral-cam stress``."""
    parser.add_argument("-o", "--output", required=True,
                        help="output folder for the charts (PNG), summary.csv/png and results.json "
                             "(must not exist unless --force)")
    parser.add_argument("--quick", action="store_true",
                        help="fewer levels, samples and pixels: about a minute instead of a few")
    parser.add_argument("--only", action="append", choices=list(STUDIES), metavar="STUDY",
                        help=f"run only this study (repeatable): {', '.join(STUDIES)}")
    parser.add_argument("--force", action="store_true", help="replace an existing output folder")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """``spectral-cam stress``: run the studies into a staged folder renamed onto
    ``args.output`` when complete (an interrupted run leaves no partial result)."""
    from .io import staged_directory

    settings = StressSettings.quick() if args.quick else StressSettings.full()
    started = time.perf_counter()

    def log(line: str) -> None:
        if not args.quiet:
            print(f"stress: {line}", file=sys.stderr, flush=True)

    try:
        with staged_directory(args.output, force=args.force) as stage:
            results = run_studies(stage, settings, only=args.only, log=log)
    except OSError as exc:  # an output path that cannot be a folder (a file's child, no permission, ...)
        raise ConfigError(f"cannot write the stress results to {str(args.output)!r}: "
                          f"{exc.strerror or exc} ({exc.filename or args.output})") from None
    log(f"wrote {args.output}/ ({len(results['files'])} files) in {time.perf_counter() - started:.0f} s")
    return 0
