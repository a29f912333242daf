"""Study (d): bokeh of small bright out-of-focus sources, and the depth-layered remedy.

Small bright out-of-focus sources converge slowly with camera-side path tracing (a pixel
sees the source through a fraction p of the aperture; per-pixel noise ≈ √((1 − p)/(p·spp))).
Charted against spp and time for the thin-lens path tracer, Mitsuba's light tracer
(RGB/luminance films only) and the depth-layered lens model
(:func:`spectral_cam.render.render_layered`, ``lens.model = "layered"``): render through a
pinhole (every source in focus, fast to converge), then apply the thin-lens defocus as a
per-depth uniform disc PSF of the circle-of-confusion diameter, layered back to front from
a depth map. It works on the full spectral cube; the result is compared with a high-spp
thin-lens reference.

References
----------
.. [1] Potmesil, M., & Chakravarty, I. (1981). A lens and aperture camera model for
   synthetic image generation. Proc. SIGGRAPH '81, 297–305 (defocus as a post-process
   point-spread function on a depth map).
.. [2] Kraus, M., & Strengert, M. (2007). Depth-of-field rendering by pyramidal image
   processing. Computer Graphics Forum 26(3), 645–654 (depth layers composited back to
   front).
.. [3] Veach, E. (1997). Robust Monte Carlo Methods for Light Transport Simulation. PhD
   thesis, Stanford University, §10.2 (light tracing: paths started at the emitters).
.. [4] docs/design.md, "Rendering" and "Model decisions" (the layered lens model).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...render.layered import aperture_fraction, render_layered
from ...render.trace import light_trace
from ...viz import figure, save_png
from .optics import band_sum, bokeh_scene
from .settings import StressSettings
from .summary import summary_row

__all__ = ["BOKEH_CASE", "BOKEH_REMEDY_REPEATS", "disc_mask", "bokeh_study", "plot_bokeh"]

#: The bokeh study's scene (keywords of :func:`~spectral_cam.apps.stress.optics.bokeh_scene`):
#: a 2.4-mm source at 3 m seen by an 8-mm f/1.4 lens focused at 0.3 m; its 1.1-px image
#: blurs into a 23.5-px disc, so a pixel inside the disc sees the source through p = 0.22 %
#: of the aperture.
BOKEH_CASE = dict(pixel_pitch_um=6.0, focal_length_mm=8.0, f_number=1.4, focus_distance_m=0.3,
                  source_depth_m=3.0, source_radius_m=0.0012)
#: What the charts and summary call the remedy: the scene key a reader sets to get it.
LAYERED_LABEL = 'lens.model = "layered"'
#: Independent remedy renders per spp (its error is a random level error: averaged in quadrature).
BOKEH_REMEDY_REPEATS = 3


def disc_mask(size: int, diameter_px: float, *, inset_px: float = 1.5) -> np.ndarray:
    """(size, size) bool mask of the pixels whose centres lie more than ``inset_px`` inside
    a disc of ``diameter_px`` centred on the image (the blur disc's interior)."""
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
    and the per-pixel RMS error of the depth-layered lens model
    (:func:`spectral_cam.render.render_layered`, ``lens.model = "layered"``) against a thin-lens
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
    from ...optics import ThinLens

    size = settings.bokeh_px
    case = dict(BOKEH_CASE, width_px=size)
    base = bokeh_scene(model="thin", spp=1, **case)
    lens = ThinLens.from_config(base.lens, base.sensor)
    coc = float(lens.coc_diameter_px(case["source_depth_m"]))
    p = aperture_fraction(base)
    disc = disc_mask(size, coc)
    if disc.sum() < 20:
        raise ConfigError(f"bokeh_px = {size} leaves too few pixels inside the {coc:.3g}-px blur disc")

    # warm-up: Mitsuba compiles its kernels on first use; not part of any method's time
    _thin_render(case, settings.bokeh_thin_spp[0], 1)
    render_layered(bokeh_scene(model="pinhole", spp=settings.bokeh_remedy_spp[0], seed=2, **case))
    light_trace(base, spp=settings.bokeh_tracer_spp[0], seed=3)

    reference = _BokehReference(settings, case, disc)
    data: dict = {"coc_px": coc, "aperture_fraction": p, "disc_pixels": int(disc.sum()), **reference.record,
                  "predicted_noise_coefficient": math.sqrt((1.0 - p) / p)}
    images = {"reference": reference.image}
    data["thin"] = _thin_series(settings, case, reference, disc, images)
    data["tracer"] = _tracer_series(settings, base, disc, images)
    data["remedy"], data["remedy_spectrum"] = _remedy_series(settings, case, reference, disc, images)
    data.update(_noise_fits(data))
    rows = _bokeh_rows(data, case, lens)
    return {"rows": rows, "data": data, "images": images}


def _thin_render(case: dict, spp: int, seed: int):
    """The thin-lens path-traced image of the case and its render time (s)."""
    from ...render import render

    started = time.perf_counter()
    image = render(bokeh_scene(model="thin", spp=spp, seed=seed, **case), with_depth=False)
    return image, time.perf_counter() - started


class _BokehReference:
    """The converged thin lens: two independent renders of ``bokeh_reference_spp``, their
    mean, and their own noise (from the halves' difference) to subtract in quadrature."""

    def __init__(self, settings: StressSettings, case: dict, disc: np.ndarray):
        image_a, _ = _thin_render(case, settings.bokeh_reference_spp, settings.seed_for(6, 1))
        image_b, _ = _thin_render(case, settings.bokeh_reference_spp, settings.seed_for(6, 2))
        sum_a, sum_b = band_sum(image_a), band_sum(image_b)
        self.image = 0.5 * (sum_a + sum_b)
        self.variance = float(np.mean((0.5 * (sum_a - sum_b))[disc] ** 2))
        self.mean = float(self.image[disc].mean())
        spectrum_a, spectrum_b = image_a.data[disc].mean(axis=0), image_b.data[disc].mean(axis=0)
        self.spectrum = 0.5 * (spectrum_a + spectrum_b)
        # relative variance of the reference's per-band disc means, from its two halves
        self.band_variance = float(np.mean((0.5 * (spectrum_a - spectrum_b) / self.spectrum) ** 2))
        self.record = {
            "reference_spp": 2 * settings.bokeh_reference_spp,
            "reference_noise": math.sqrt(self.variance) / self.mean,
            "reference_level_noise": math.sqrt(self.variance / disc.sum()) / self.mean,
            "reference_band_noise": math.sqrt(self.band_variance),
            # the corrected per-pixel error is known to about ±(var_ref·√(2/N))^½
            "error_floor": math.sqrt(self.variance * math.sqrt(2.0 / disc.sum())) / self.mean,
            "wavelengths_nm": [float(w) for w in image_a.wavelengths_nm],
            "reference_spectrum": self.spectrum.tolist(),
        }


def _thin_series(settings: StressSettings, case: dict, reference: _BokehReference, disc, images: dict) -> dict:
    """Thin-lens path tracing at each spp of the series: noise and error inside the disc."""
    entry = {"spp": [], "seconds": [], "noise": [], "error": [], "error_corrected": []}
    for index, spp in enumerate(settings.bokeh_thin_spp):
        image, seconds = _thin_render(case, spp, settings.seed_for(7, index))
        total = band_sum(image)
        raw, corrected = _relative_error(total, reference.image, disc, reference.variance)
        entry["spp"].append(spp), entry["seconds"].append(seconds)
        entry["noise"].append(float(total[disc].std() / total[disc].mean()))
        entry["error"].append(raw), entry["error_corrected"].append(corrected)
        images[f"thin lens, {spp} spp"] = total
    return entry


def _tracer_series(settings: StressSettings, base, disc, images: dict) -> dict:
    """The light tracer (luminance film) at each spp of its series: noise inside the disc."""
    entry = {"spp": [], "seconds": [], "noise": []}
    for index, spp in enumerate(settings.bokeh_tracer_spp):
        image, seconds = light_trace(base, spp=spp, seed=settings.seed_for(8, index))
        entry["spp"].append(spp), entry["seconds"].append(seconds)
        entry["noise"].append(float(image[disc].std() / image[disc].mean()))
        images[f"light tracer (luminance), {spp} spp"] = image
    return entry


def _remedy_series(settings: StressSettings, case: dict, reference: _BokehReference, disc,
                   images: dict) -> tuple[dict, list | None]:
    """The layered model at each spp, :data:`BOKEH_REMEDY_REPEATS` seeds each: per-pixel,
    disc-level and per-band error against the reference; and its last disc spectrum."""
    entry = {"spp": [], "seconds": [], "error": [], "error_corrected": [], "level_error": [],
             "spectral_error": [], "repeats": BOKEH_REMEDY_REPEATS}
    spectrum = None
    for index, spp in enumerate(settings.bokeh_remedy_spp):
        seconds, squared, levels, spectral = [], [], [], []
        for repeat in range(BOKEH_REMEDY_REPEATS):
            started = time.perf_counter()
            remedy = render_layered(bokeh_scene(model="pinhole", spp=spp,
                                                seed=settings.seed_for(9, index, repeat), **case))
            seconds.append(time.perf_counter() - started)
            total = band_sum(remedy)
            squared.append(float(np.mean((total[disc] - reference.image[disc]) ** 2)))
            levels.append(float(total[disc].mean() / reference.mean - 1.0))
            spectrum = remedy.data[disc].mean(axis=0)
            spectral.append(float(np.mean((spectrum / reference.spectrum - 1.0) ** 2)))
        mse = float(np.mean(squared))
        entry["spp"].append(spp), entry["seconds"].append(float(np.mean(seconds)))
        entry["error"].append(math.sqrt(mse) / reference.mean)
        entry["error_corrected"].append(math.sqrt(max(mse - reference.variance, 0.0)) / reference.mean)
        entry["level_error"].append(float(np.sqrt(np.mean(np.square(levels)))))
        entry["spectral_error"].append(math.sqrt(max(float(np.mean(spectral)) - reference.band_variance, 0.0)))
        images[f"layered, {spp} spp"] = total
    return entry, None if spectrum is None else spectrum.tolist()


def _noise_fits(data: dict) -> dict:
    """Thin-lens noise follows b/√spp and its error a/√t: the constants fitted through the
    measurements, the spp and time for 1 % noise, the thin lens's error at the remedy's times."""
    thin = data["thin"]
    spp, seconds = np.asarray(thin["spp"], float), np.asarray(thin["seconds"], float)
    b = float(np.exp(np.mean(np.log(np.asarray(thin["noise"]) * np.sqrt(spp)))))
    a = float(np.exp(np.mean(np.log(np.asarray(thin["error_corrected"]).clip(1e-9) * np.sqrt(seconds)))))
    seconds_per_spp = float(np.exp(np.mean(np.log(seconds / spp))))
    spp_one_percent = (b / 0.01) ** 2
    data["remedy"]["thin_error_at_equal_time"] = [a / math.sqrt(t) for t in data["remedy"]["seconds"]]
    return {"thin_noise_coefficient": b, "thin_error_time_coefficient": a, "thin_spp_for_1_percent": spp_one_percent,
            "thin_seconds_for_1_percent": spp_one_percent * seconds_per_spp}


def _bokeh_rows(data: dict, case: dict, lens) -> list[dict]:
    """The study's summary rows."""
    coc, p = data["coc_px"], data["aperture_fraction"]
    rows = [
        summary_row("bokeh", "scene", "blur-disc (CoC) diameter", coc, "px",
                    f"source image {2 * case['source_radius_m'] * lens.image_distance_m / case['source_depth_m'] / lens.pixel_pitch_m:.2g} px"),
        summary_row("bokeh", "scene", "aperture fraction p seeing the source", p, "fraction",
                    f"predicted thin-lens noise √((1-p)/p)/√spp = {math.sqrt((1 - p) / p):.3g}/√spp"),
        summary_row("bokeh", "thin-lens reference", "per-pixel noise of the reference", data["reference_noise"], "relative",
                    f"{data['reference_spp']} spp; subtracted in quadrature from the errors below"),
    ]
    thin = data["thin"]
    for spp, noise, seconds in zip(thin["spp"], thin["noise"], thin["seconds"]):
        rows.append(summary_row("bokeh", f"thin-lens path tracer, {spp} spp", "per-pixel noise inside the blur disc",
                                noise, "relative", f"{seconds:.2f} s"))
    rows.append(summary_row("bokeh", "thin-lens path tracer", "spp for 1 % per-pixel noise (fit b/√spp)",
                            data["thin_spp_for_1_percent"], "spp",
                            f"≈ {data['thin_seconds_for_1_percent']:.3g} s at this size"))
    for spp, noise, seconds in zip(data["tracer"]["spp"], data["tracer"]["noise"], data["tracer"]["seconds"]):
        rows.append(summary_row("bokeh", f"light tracer (luminance film only), {spp} spp",
                                "per-pixel noise inside the blur disc", noise, "relative", f"{seconds:.2f} s"))
    remedy = data["remedy"]
    for spp, err, level, spec, seconds, eq in zip(remedy["spp"], remedy["error_corrected"], remedy["level_error"],
                                                  remedy["spectral_error"], remedy["seconds"],
                                                  remedy["thin_error_at_equal_time"]):
        rows.append(summary_row("bokeh", f"lens.model = layered (pinhole {spp} spp + depth layers)",
                                "per-pixel RMS error vs converged thin lens", err, "relative",
                                f"{seconds:.2f} s (thin lens at equal time: {eq:.3g}); disc level error {level:.3g}; "
                                f"per-band error {spec:.3g}; estimation floor ±{data['error_floor']:.2g}"))
    return rows


def plot_bokeh(result: dict, directory: Path) -> list[str]:
    """Figures of :func:`bokeh_study`: noise against spp and time; images, profiles, spectra."""
    data, images = result["data"], result["images"]
    written = []
    fig = figure(12, 4.4)
    ax1, ax2 = fig.subplots(1, 2)
    thin, tracer, remedy = data["thin"], data["tracer"], data["remedy"]
    spp = np.asarray(thin["spp"], float)
    grid = np.logspace(0, np.log10(max(spp.max(), 1e6)), 50)
    ax1.loglog(spp, thin["noise"], "o-", label="thin-lens path tracer (spectral)")
    ax1.loglog(grid, data["predicted_noise_coefficient"] / np.sqrt(grid), ":", color="gray",
               label=f"√((1−p)/(p·spp)), p = {data['aperture_fraction']:.2g}")
    ax1.loglog(tracer["spp"], tracer["noise"], "s-", label="light tracer (luminance film only)")
    # an error the reference's noise hides is drawn at the estimate's floor, hollow, not as a plunge to 0
    layered = np.maximum(remedy["error_corrected"], data["error_floor"])
    hidden = np.asarray(remedy["error_corrected"]) <= data["error_floor"]
    ax1.loglog(remedy["spp"], layered, "^-", color="tab:green",
               label=f"{LAYERED_LABEL}: pinhole + depth layers\n(spectral), error vs converged thin lens")
    if hidden.any():
        ax1.loglog(np.asarray(remedy["spp"])[hidden], layered[hidden], "^", color="tab:green", mfc="white",
                   label="hollow: at or below that floor")
    ax1.axhline(data["error_floor"], color="tab:green", lw=0.6, ls=":", label="floor of that error estimate")
    ax1.axhline(data["reference_noise"], color="k", lw=0.6, ls="--", label="reference's own noise")
    ax1.set_xlabel("samples per pixel")
    ax1.set_ylabel("per-pixel relative error inside the blur disc")
    ax1.set_title(f"Bokeh of a 1-px source, CoC {data['coc_px']:.1f} px")
    ax1.legend(fontsize=7)
    ax2.loglog(thin["seconds"], thin["noise"], "o-", label="thin-lens path tracer")
    ax2.loglog(tracer["seconds"], tracer["noise"], "s-", label="light tracer (not spectral)")
    ax2.loglog(remedy["seconds"], layered, "^-", color="tab:green", label=LAYERED_LABEL)
    if hidden.any():
        ax2.loglog(np.asarray(remedy["seconds"])[hidden], layered[hidden], "^", color="tab:green", mfc="white",
                   label="hollow: at or below the error floor")
    ax2.set_xlabel("render time (s), 2 cores, after JIT warm-up")
    ax2.set_ylabel("per-pixel relative error inside the blur disc")
    ax2.set_title("Error against time")
    ax2.legend(fontsize=8)
    written.append(save_png(fig, Path(directory) / "bokeh_convergence.png").name)

    picks = [name for name in images if name != "reference"]
    chosen = ([n for n in picks if n.startswith("thin")][1:2] + [n for n in picks if n.startswith("thin")][-1:]
              + [n for n in picks if n.startswith("light")][-1:] + [n for n in picks if n.startswith("layered")][-2:-1]
              + ["reference"])
    fig = figure(2.5 * len(chosen) + 3.5, 3.2)
    axes = fig.subplots(1, len(chosen) + 1, width_ratios=[1] * len(chosen) + [1.6])
    reference = images["reference"]
    size = reference.shape[0]
    scale = float(reference[disc_mask(size, data["coc_px"])].mean())
    y, x = np.mgrid[0:size, 0:size] + 0.5 - size / 2.0
    ring = np.floor(np.hypot(x, y)).astype(int)
    counts = np.bincount(ring.ravel())
    for ax, name in zip(axes, chosen):
        image = images[name]
        image_scale = scale if not name.startswith("light") else float(image[disc_mask(size, data["coc_px"])].mean())
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
    written.append(save_png(fig, Path(directory) / "bokeh_images.png").name)

    if data.get("remedy_spectrum") is not None:
        fig = figure(6, 3.6)
        ax = fig.subplots()
        ax.plot(data["wavelengths_nm"], data["reference_spectrum"], "k-", label="thin-lens reference")
        ax.plot(data["wavelengths_nm"], data["remedy_spectrum"], "o", ms=3,
                label=f"{LAYERED_LABEL}, {data['remedy']['spp'][-1]} spp")
        ax.set_xlabel("band centre (nm)")
        ax.set_ylabel("mean band radiance in the disc (W·m⁻²·sr⁻¹)")
        ax.set_title('The layered lens model (lens.model = "layered") keeps the spectrum', fontsize=9)
        ax.legend(fontsize=8)
        written.append(save_png(fig, Path(directory) / "bokeh_spectrum.png").name)
    return written
