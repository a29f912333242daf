"""Study (c): optics from f/0.95 to f/64, a pinhole, 1:2 macro to "infinity", 4 to 600 mm.

Circle-of-confusion and diffraction regimes from :mod:`spectral_cam.optics`, checked by a
few tiny Mitsuba renders of a point source whose measured blur diameter is compared with
the thin-lens formula.

References
----------
.. [1] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10 (depth of field,
   circle of confusion); Goodman, J. W. (2005). Introduction to Fourier Optics, 3rd ed.,
   §6.3 (diffraction-limited MTF).
.. [2] docs/design.md, "Optics" (the thin lens, diffraction and the model decisions).
"""

from __future__ import annotations

import json
import math
import time
from functools import lru_cache
from pathlib import Path

import numpy as np

from ...viz import figure, save_png
from .settings import StressSettings
from .summary import summary_row

__all__ = ["F_NUMBERS", "FOCAL_LENGTHS_MM", "OPTICS_RENDERS", "chart_lens", "diffraction_limit_f_number",
           "bokeh_scene", "band_sum", "optics_study", "plot_optics"]

#: f-numbers of the optics charts (a pinhole is drawn as the zero-aperture limit).
F_NUMBERS = (0.95, 1.4, 2.0, 2.8, 4.0, 5.6, 8.0, 11.0, 16.0, 22.0, 32.0, 45.0, 64.0)
#: Focal lengths (mm) of the wide-to-long chart.
FOCAL_LENGTHS_MM = (4.0, 8.0, 14.0, 24.0, 50.0, 100.0, 200.0, 400.0, 600.0)
_CHART_FOCAL_MM, _CHART_FOCUS_M = 50.0, 2.0
#: Sensor of the analytic charts: 480 × 320 pixels of 6 µm.
_CHART_PITCH_UM, _CHART_WIDTH_PX, _CHART_HEIGHT_PX = 6.0, 480, 320
#: Focal length (mm) of the regime map: the default 8-mm lens, where all three regimes occur.
_REGIME_FOCAL_MM = 8.0
_GREEN_NM, _RED_NM = 550.0, 700.0


@lru_cache(maxsize=1)
def _chart_scene():
    from ...scene import scene_from_dict

    return scene_from_dict({"sensor": {"width_px": _CHART_WIDTH_PX, "height_px": _CHART_HEIGHT_PX,
                                       "pixel_pitch_um": _CHART_PITCH_UM}})


def chart_lens(focal_length_mm: float, f_number: float, focus_distance_m: float):
    """The thin lens of the analytic charts: ``lens.*`` keys of a scene with a 480 × 320
    sensor of 6-µm pixels, built by :meth:`spectral_cam.optics.ThinLens.from_config`.

    Parameters
    ----------
    focal_length_mm, f_number, focus_distance_m
        ``lens.focal_length_mm``, ``lens.f_number``, ``lens.focus_distance_m``.

    Returns
    -------
    ThinLens
    """
    from ...optics import ThinLens

    config = _chart_scene().replace(**{"lens.focal_length_mm": float(focal_length_mm),
                                       "lens.f_number": float(f_number),
                                       "lens.focus_distance_m": float(focus_distance_m)})
    return ThinLens.from_config(config.lens, config.sensor)


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

    from ...optics import MTF_TOLERANCE, diffraction_mtf

    tolerance = MTF_TOLERANCE if tolerance is None else tolerance
    nyquist = 0.5 / (pixel_pitch_um * 1e-6)
    return float(brentq(lambda n: 1.0 - diffraction_mtf(nyquist, wavelength_nm, n) - tolerance, 1e-3, 1e4))


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
    from ...scene import scene_from_dict

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


def band_sum(image) -> np.ndarray:
    """(H, W) float64 sum over the bands of a SpectralImage's radiance."""
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
    blur diameter measured from second moments (:func:`spectral_cam.metrics.blur.disc_diameter_from_moments`) against
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
    rows: list[dict] = []
    data = {"coc_vs_distance": _coc_vs_distance(),
            "regime_map": _regime_map(rows),
            "diffraction_cost": _diffraction_cost(rows),
            **_focus_and_field(rows)}
    renders, images = _rendered_blur(settings, rows)
    data["renders"] = renders
    return {"rows": rows, "data": data, "images": images}


def _coc_vs_distance() -> dict:
    """CoC diameter against object distance for each f-number of :data:`F_NUMBERS` (50 mm at
    2 m), with each one's Airy diameter."""
    distances = np.logspace(-1, 3, 240)
    curves = {}
    for n in F_NUMBERS:
        lens = chart_lens(_CHART_FOCAL_MM, n, _CHART_FOCUS_M)
        curves[f"{n:g}"] = {"coc_um": (lens.coc_diameter_m(distances) * 1e6).tolist(),
                            "airy_um": float(lens.airy_diameter_m(_GREEN_NM) * 1e6)}
    return {"focal_length_mm": _CHART_FOCAL_MM, "focus_m": _CHART_FOCUS_M,
            "distances_m": distances.tolist(), "curves": curves}


def _regime_map(rows: list) -> dict:
    """The dominant blur (pixel, defocus, diffraction) and the MTF at Nyquist over f-number
    and distance for the default 8-mm lens; its shares appended to ``rows``."""
    from ...optics import defocus_mtf, diffraction_mtf, pixel_mtf

    pitch = _CHART_PITCH_UM * 1e-6
    n_grid = np.logspace(np.log10(0.95), np.log10(64.0), 120)
    z_grid = np.logspace(-1, 3, 120)
    nyquist = 0.5 / pitch
    coc = np.empty((len(z_grid), len(n_grid)))
    airy = np.empty_like(coc)
    mtf = np.empty_like(coc)
    for j, n in enumerate(n_grid):
        lens = chart_lens(_REGIME_FOCAL_MM, n, _CHART_FOCUS_M)
        coc[:, j] = lens.coc_diameter_m(z_grid)
        airy[:, j] = lens.airy_diameter_m(_GREEN_NM)
        mtf[:, j] = (defocus_mtf(nyquist, coc[:, j]) * diffraction_mtf(nyquist, _GREEN_NM, lens.working_f_number)
                     * pixel_mtf(nyquist, pitch))
    # the blur that dominates: the pixel aperture, the CoC or the Airy disc (largest diameter)
    regime = np.argmax(np.stack([np.full_like(coc, pitch), coc, airy]), axis=0)  # 0 pixel, 1 defocus, 2 diffraction
    regime_map = {"focal_length_mm": _REGIME_FOCAL_MM, "focus_m": _CHART_FOCUS_M,
                  "f_numbers": n_grid.tolist(), "distances_m": z_grid.tolist(),
                  "regime": regime.tolist(), "mtf_at_nyquist": mtf.tolist(),
                  "labels": ["pixel", "defocus", "diffraction"]}
    for label, code in (("pixel", 0), ("defocus", 1), ("diffraction", 2)):
        rows.append(summary_row("optics", f"{_REGIME_FOCAL_MM:g} mm focused at {_CHART_FOCUS_M:g} m, f/0.95-f/64, 0.1-1000 m",
                                f"share of the (N, z) map where {label} dominates", float(np.mean(regime == code)), "fraction",
                                "largest of pixel pitch, CoC and Airy diameter (550 nm)"))
    return regime_map


def _diffraction_cost(rows: list) -> dict:
    """MTF lost at Nyquist to diffraction against f-number (2 and 6 µm pixels, three
    wavelengths), and the f-numbers where the render starts applying the Airy PSF."""
    from ...optics import MTF_TOLERANCE, diffraction_mtf

    n_fine = np.logspace(np.log10(0.95), np.log10(64.0), 200)
    cost = {}
    for pitch_um in (6.0, 2.0):
        for wl in (450.0, _GREEN_NM, _RED_NM):
            cost[f"{pitch_um:g} um, {wl:g} nm"] = (1.0 - diffraction_mtf(0.5 / (pitch_um * 1e-6), wl, n_fine)).tolist()
    limits = {f"{p:g}": diffraction_limit_f_number(p, _RED_NM) for p in (6.0, 4.0, 2.0)}
    cost_record = {"f_numbers": n_fine.tolist(), "cost": cost, "tolerance": MTF_TOLERANCE,
                   "limit_f_number_700nm": limits}
    half = {f"{p:g}": diffraction_limit_f_number(p, _GREEN_NM, tolerance=0.5) for p in (6.0, 4.0, 2.0)}
    cost_record["half_mtf_f_number_550nm"] = half
    for p, n in limits.items():
        rows.append(summary_row("optics", f"{p}-um pixels", "f-number where diffraction costs 0.03 MTF at Nyquist (700 nm)",
                                n, "N_w", "above it the render applies the per-band Airy PSF (render.diffraction = auto)"))
        rows.append(summary_row("optics", f"{p}-um pixels", "f-number where diffraction halves the MTF at Nyquist (550 nm)",
                                half[p], "N_w", "diffraction-limited beyond"))
    return cost_record


def _focus_and_field(rows: list) -> dict:
    """The working f-number from 1:1 macro to 10⁶ m focus, the field of view from 4 to 600
    mm, and the CoC and Airy extremes (rows)."""
    pitch = _CHART_PITCH_UM * 1e-6
    data: dict = {}
    focus = {}
    for f_mm in (8.0, 50.0, 600.0):
        zf = np.logspace(np.log10(1.05 * f_mm * 1e-3), 6, 200)
        lenses = [chart_lens(f_mm, 2.8, z) for z in zf]
        focus[f"{f_mm:g}"] = {"focus_m": zf.tolist(),
                              "working_over_f_number": [lens.working_f_number / 2.8 for lens in lenses]}
    data["working_f_number"] = focus
    macro = chart_lens(50.0, 2.8, 0.1)  # z_f = 2f: 1:1
    rows.append(summary_row("optics", "50 mm at 1:1 (focus 0.1 m), f/2.8", "working f-number", macro.working_f_number,
                            "N_w", f"irradiance {(1 + 4 * 2.8 ** 2) / (1 + 4 * macro.working_f_number ** 2):.3f}× "
                                   "that at infinity focus"))
    fov = {}
    for width_mm in (_CHART_WIDTH_PX * _CHART_PITCH_UM * 1e-3, 36.0):
        fov[f"{width_mm:g}"] = [math.degrees(2 * math.atan(width_mm / (2 * f))) for f in FOCAL_LENGTHS_MM]
    data["fov"] = {"focal_lengths_mm": list(FOCAL_LENGTHS_MM), "fov_deg": fov}
    for f_mm in (FOCAL_LENGTHS_MM[0], FOCAL_LENGTHS_MM[-1]):
        rows.append(summary_row("optics", f"{f_mm:g} mm on a 36-mm-wide sensor", "horizontal field of view (infinity focus)",
                                math.degrees(2 * math.atan(36.0 / (2 * f_mm))), "deg"))
    for n in (0.95, 64.0):
        lens = chart_lens(_CHART_FOCAL_MM, n, _CHART_FOCUS_M)
        rows.append(summary_row("optics", f"50 mm f/{n:g} focused at 2 m", "CoC diameter of a point at infinity",
                                float(lens.coc_diameter_px(math.inf)), "px", f"{_CHART_PITCH_UM:g}-um pixels"))
        rows.append(summary_row("optics", f"50 mm f/{n:g} focused at 2 m", "Airy diameter 2.44·λ·N_w at 550 nm",
                                float(lens.airy_diameter_m(_GREEN_NM) / pitch), "px"))
    far = chart_lens(8.0, 1.4, 1e6)
    rows.append(summary_row("optics", "8 mm f/1.4 focused at 1e6 m", "CoC of a point at 1 m (limit A·f/z)",
                            float(far.coc_diameter_px(1.0)), "px",
                            f"A·f/z = {far.aperture_radius_m * 2 * far.focal_length_m / 1.0 / far.pixel_pitch_m:.4g} px"))
    return data


def _rendered_blur(settings: StressSettings, rows: list) -> tuple[list, dict]:
    """One small source through a thin lens and a pinhole of the same geometry per case of
    :data:`OPTICS_RENDERS`: the blur diameter measured from second moments against the
    thin-lens CoC (and the peak with and without diffraction)."""
    from ...metrics.blur import disc_diameter_from_moments
    from ...optics import ThinLens
    from ...render import render

    size, spp = settings.optics_px, settings.optics_spp
    images: dict[str, np.ndarray] = {}
    cache: dict = {}
    renders = []

    def band_sum_of(config):
        key = json.dumps(config.to_dict(), sort_keys=True)
        if key not in cache:
            started = time.perf_counter()
            cache[key] = (band_sum(render(config, with_depth=False)), time.perf_counter() - started)
        return cache[key]

    for index, (label, kwargs) in enumerate(OPTICS_RENDERS):
        kwargs = dict(kwargs)
        diffraction = kwargs.pop("diffraction", "off")
        seed = settings.seed_for(5, index)
        thin_cfg = bokeh_scene(width_px=size, model="thin", spp=spp, seed=seed, diffraction=diffraction, **kwargs)
        pin_cfg = bokeh_scene(width_px=size, model="pinhole", spp=spp, seed=seed + 1, diffraction=diffraction, **kwargs)
        thin, thin_s = band_sum_of(thin_cfg)
        pin, _ = band_sum_of(pin_cfg)
        lens = ThinLens.from_config(thin_cfg.lens, thin_cfg.sensor)
        predicted = float(lens.coc_diameter_px(kwargs["source_depth_m"]))
        measured = disc_diameter_from_moments(thin, pin)
        entry = {"label": label, "predicted_coc_px": predicted, "measured_coc_px": measured,
                 "airy_diameter_px": float(lens.airy_diameter_m(_GREEN_NM) / lens.pixel_pitch_m),
                 "working_f_number": lens.working_f_number, "render_s": thin_s}
        if diffraction == "on":
            sharp_cfg = bokeh_scene(width_px=size, model="pinhole", spp=spp, seed=seed + 1, diffraction="off", **kwargs)
            sharp, _ = band_sum_of(sharp_cfg)
            entry["peak_ratio_diffraction"] = float(pin.max() / sharp.max())
            images["pinhole (no diffraction)"] = sharp
            rows.append(summary_row("optics", f"render: {label}", "peak intensity with / without diffraction (pinhole)",
                                    entry["peak_ratio_diffraction"], "ratio",
                                    f"Airy diameter {entry['airy_diameter_px']:.3g} px, source image "
                                    f"{2 * kwargs['source_radius_m'] * lens.image_distance_m / kwargs['source_depth_m'] / lens.pixel_pitch_m:.3g} px"))
        images[label] = thin
        renders.append(entry)
        # second moments of pixel-sampled images carry a sampling error of about
        # ±0.15 px² (Sheppard), i.e. ±0.6/c px on the diameter c
        uncertainty = 0.6 / max(predicted, 0.5)
        entry["measurement_uncertainty_px"] = uncertainty
        rows.append(summary_row("optics", f"render: {label}", "measured / predicted CoC diameter",
                                measured / predicted if predicted > 1.0 else None, "ratio",
                                f"predicted {predicted:.3g} px, measured {measured:.3g} ± {uncertainty:.2g} px"
                                + ("" if predicted > 1.0 else " (below 1 px: in focus)")))
    return renders, images


def plot_optics(result: dict, directory: Path) -> list[str]:
    """Figures of :func:`optics_study`: CoC and diffraction regimes, MTF and focus extremes,
    and the renders."""
    from matplotlib.colors import ListedColormap

    data = result["data"]
    written = []
    fig = figure(13, 4.6)
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
    written.append(save_png(fig, Path(directory) / "optics_regimes.png").name)

    fig = figure(14, 4.2)
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
    written.append(save_png(fig, Path(directory) / "optics_mtf_focus.png").name)

    images = result.get("images") or {}
    if images:
        renders = {r["label"]: r for r in data["renders"]}
        fig = figure(2.2 * len(images), 2.6)
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
        written.append(save_png(fig, Path(directory) / "optics_renders.png").name)
    return written
