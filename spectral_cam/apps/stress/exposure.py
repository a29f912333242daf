"""Study (b): the sensor from 0.01 to 10⁵ electrons per pixel.

Synthetic flat fields through :func:`spectral_cam.sensor.expose`: the bias of the mean at
low counts (with and without read-noise dither of the ADC), clipping at saturation
(full-well and ADC limited), highlight handling without colour casts, and the SNR against
the EMVA 1288 model.

References
----------
.. [1] EMVA Standard 1288, Release 4.0 Linear (2021), §2–§6 (linear model, SNR, saturation).
.. [2] Widrow, B., & Kollár, I. (2008). Quantization Noise. Cambridge University Press,
   ch. 19 (dither: rounding is unbiased when the noise before the quantiser is ≳ 0.5 LSB).
.. [3] docs/design.md, "Sensor" (the noise chain and its EMVA order).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...radiance_targets import lambertian_radiance, narrow_band_flat, uniform_image
from ...viz import figure, save_png
from .settings import STUDY_CAMERA, StressSettings
from .summary import summary_row

__all__ = ["EXPOSURE_SENSORS", "mono_config", "neutral_chroma", "exposure_study", "plot_exposure"]

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


def mono_config(size_px: int, overrides: dict, iso: float, exposure_s: float):
    """A scene with a square monochrome sensor (``model = "ideal"``, ``cfa = "none"``, no
    vignetting) of ``size_px`` pixels, the sensor keys ``overrides`` and the exposure.

    Parameters
    ----------
    size_px
        Sensor side, pixels.
    overrides
        Further ``[sensor]`` keys (e.g. ``{"read_noise_e": 0.0}``).
    iso, exposure_s
        ``exposure.iso`` and ``exposure.time_s`` (s).

    Returns
    -------
    SceneConfig
    """
    from ...scene import scene_from_dict

    sensor = {"model": "ideal", "cfa": "none", "width_px": size_px, "height_px": size_px, "vignetting": False,
              **overrides}
    return scene_from_dict({"sensor": sensor, "exposure": {"time_s": exposure_s, "iso": iso}})


def neutral_chroma(linear_srgb_mean) -> float:
    """CIELAB chroma C*ab of a linear sRGB colour scaled to luminance Y = 1 (0 for any
    neutral; NaN for a colour without luminance).

    References
    ----------
    .. [1] CIE 15:2004 §8.2.1 (CIELAB; C*ab = √(a*² + b*²)).
    """
    import colour

    from ...metrics import linear_srgb_to_lab

    rgb = np.asarray(linear_srgb_mean, dtype=float)
    luminance = colour.RGB_to_XYZ(rgb, colour.models.RGB_COLOURSPACE_sRGB, apply_cctf_decoding=False)[1]
    if not luminance > 0:
        return float("nan")
    lab = linear_srgb_to_lab(rgb / luminance)
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
    low, high = settings.exposure_range_e
    levels = np.logspace(np.log10(low), np.log10(high), settings.exposure_levels)
    rows: list[dict] = []
    data: dict = {"levels_e": levels.tolist(), "sensors": {}, "highlights": {}}
    for s_index, (label, overrides, iso) in enumerate(EXPOSURE_SENSORS):
        entry = _flat_field_series(settings, s_index, label, overrides, iso, levels)
        data["sensors"][label] = entry
        rows += _flat_field_rows(label, entry, levels)
    for i_index, illuminant in enumerate(("A", "D65")):
        data["highlights"][illuminant], highlight_rows = _highlight_series(settings, i_index, illuminant)
        rows += highlight_rows
    return {"rows": rows, "data": data}


def _flat_field_series(settings: StressSettings, s_index: int, label: str, overrides: dict, iso: float,
                       levels: np.ndarray) -> dict:
    """One sensor's (an :data:`EXPOSURE_SENSORS` entry's) flat-field pairs at each level μ_e and
    its dark pair: the measured electrons (μ_y − μ_y.dark)/K with their standard errors, the SNR
    and its EMVA model, and the DN range (EMVA 1288 §6.1)."""
    from ... import sensor as S
    from ...metrics.emva1288 import pair_statistics, snr_model

    size = settings.flat_px
    config = mono_config(size, overrides, iso, _EXPOSURE_TIME_S)
    per_radiance = S.electrons_per_band_radiance(config, _NARROW_BAND_NM) * _EXPOSURE_TIME_S
    dark_frames = [S.expose(narrow_band_flat((size, size), 0.0, _NARROW_BAND_NM), config, frame_seed=settings.seed_for(2, s_index, k))
                   for k in (0, 1)]
    meta = dark_frames[0].meta
    gain, white, black = meta["K_dn_per_e"], dark_frames[0].white_level, dark_frames[0].black_level
    dark_mean, dark_var = (v["Y"] for v in pair_statistics(dark_frames[0].mosaic, dark_frames[1].mosaic))
    measured, standard_error, snr, snr_expected, max_dn, at_white, min_dn = [], [], [], [], [], [], []
    for l_index, level in enumerate(levels):
        image = narrow_band_flat((size, size), float(level / per_radiance), _NARROW_BAND_NM)
        a, b = (S.expose(image, config, frame_seed=settings.seed_for(3, s_index, l_index, k)) for k in (0, 1))
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
    return {
        "label": label, "iso": iso, "K_dn_per_e": gain, "saturation_e": meta["saturation_e"],
        "sigma_dark_e": meta["sigma_dark_e"], "white_level": white, "black_level": black,
        "measured_e": np.asarray(measured).tolist(), "standard_error_e": np.asarray(standard_error).tolist(),
        "snr": snr, "snr_model": snr_expected, "max_dn": max_dn, "min_dn": min_dn,
        "fraction_at_white": at_white,
    }


def _flat_field_rows(label: str, entry: dict, levels: np.ndarray) -> list[dict]:
    """Summary rows of one sensor's series: the bias at 0.01–1 e⁻ in standard errors, the mean and
    largest DN past saturation, the SNR against the EMVA model; adds ``bias_z`` and
    ``snr_ratio_max_deviation`` to ``entry``."""
    measured, standard_error = np.asarray(entry["measured_e"]), np.asarray(entry["standard_error_e"])
    saturation, white, max_dn, at_white = (entry[k] for k in ("saturation_e", "white_level", "max_dn",
                                                               "fraction_at_white"))
    rows = []
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
        rows.append(summary_row("exposure", label, "largest |bias| / standard error at 0.01-1 e-",
                                float(abs(z[worst])), "SE", note))
        one = int(np.argmin(np.abs(np.log(levels))))
        rows.append(summary_row("exposure", label, f"measured / expected at {levels[one]:.3g} e-",
                                float(measured[one] / levels[one]), "ratio",
                                f"standard error {standard_error[one] / levels[one]:.2g}"))
    over = levels >= 2 * saturation
    if over.any():
        clipped_e = measured[over]
        rows.append(summary_row("exposure", label, "mean past saturation / saturation capacity",
                                float(np.mean(clipped_e) / saturation), "ratio",
                                f"saturation {saturation:.5g} e-, white level {white} DN"))
        rows.append(summary_row("exposure", label, "largest DN past saturation - white level",
                                max(max_dn[i] for i in np.flatnonzero(over)) - white, "DN",
                                f"{100 * np.mean([at_white[i] for i in np.flatnonzero(over)]):.1f} % of pixels at white"))
    # below ~10 e- the measured SNR's own uncertainty (that of the mean) exceeds 3 %
    usable = (levels >= 10.0) & (levels <= 0.7 * saturation)
    if usable.any():
        ratio = np.asarray(entry["snr"])[usable] / np.asarray(entry["snr_model"])[usable]
        entry["snr_ratio_max_deviation"] = float(np.max(np.abs(ratio - 1)))
        rows.append(summary_row("exposure", label, "SNR / EMVA model, worst over 10 e- .. 70 % saturation",
                                float(ratio[np.argmax(np.abs(ratio - 1))]), "ratio"))
    return rows


#: The highlight methods compared on an over-exposed white (:mod:`spectral_cam.isp.highlights`).
_HIGHLIGHT_METHODS = ("none", "clip", "desaturate")


def _highlight_series(settings: StressSettings, i_index: int, illuminant: str) -> tuple[dict, list[dict]]:
    """A white reflector under ``illuminant`` exposed at ``highlight_factors`` × the time that
    saturates its brightest channel, developed with each highlight method: the CIELAB chroma,
    luminance and linear sRGB of its mean colour, and the largest cast at ≥ 1.25× as rows."""
    from ... import sensor as S
    from ...isp import ISPConfig, develop
    from ...scene import scene_from_dict

    factors = [float(f) for f in settings.highlight_factors]
    hl_size = max(24, settings.flat_px // 2)
    base = {"illuminant": {"spd": illuminant},
            "sensor": {"model": STUDY_CAMERA, "width_px": hl_size, "height_px": hl_size, "vignetting": False}}
    image = uniform_image(lambertian_radiance(illuminant, [0.9])[0], (hl_size, hl_size))
    probe = S.expose(image, scene_from_dict({**base, "exposure": {"time_s": "auto", "auto_fraction": 1.0, "metering": "etr"}}),
                     frame_seed=1)
    t_sat = probe.meta["exposure_s"]
    chroma = {m: [] for m in _HIGHLIGHT_METHODS}
    luminance = {m: [] for m in _HIGHLIGHT_METHODS}
    swatches = {m: [] for m in _HIGHLIGHT_METHODS}
    for f_index, factor in enumerate(factors):
        raw = S.expose(image, scene_from_dict({**base, "exposure": {"time_s": factor * t_sat}}),
                       frame_seed=settings.seed_for(4, i_index, f_index))
        for method in _HIGHLIGHT_METHODS:
            developed = develop(raw, ISPConfig(highlights=method, tone="linear"))
            mean = developed.linear[4:-4, 4:-4].reshape(-1, 3).astype(float).mean(axis=0)
            chroma[method].append(neutral_chroma(mean))
            luminance[method].append(float(mean @ np.array([0.2126, 0.7152, 0.0722])))
            swatches[method].append(mean.tolist())
    record = {"factors": factors, "chroma": chroma, "luminance": luminance,
              "mean_linear_srgb": swatches, "exposure_at_saturation_s": t_sat}
    clipped = [k for k, f in enumerate(factors) if f >= 1.25]
    rows = [summary_row("exposure", f"highlights '{method}', illuminant {illuminant}",
                        "largest colour cast (C*ab) at >= 1.25x saturation",
                        max(chroma[method][k] for k in clipped), "C*ab",
                        "CIELAB chroma of the mean white at Y = 1; < 1 is invisible")
            for method in _HIGHLIGHT_METHODS if clipped]
    return record, rows


def plot_exposure(result: dict, directory: Path) -> list[str]:
    """Figures of :func:`exposure_study`: bias and clipping, SNR against the EMVA model,
    highlight colour casts."""
    data = result["data"]
    levels = np.asarray(data["levels_e"])
    written = []
    fig = figure(12, 4.2)
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
    written.append(save_png(fig, Path(directory) / "exposure_bias_clipping.png").name)

    fig = figure(6.5, 4.4)
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
    written.append(save_png(fig, Path(directory) / "exposure_snr.png").name)

    highlights = data["highlights"]
    fig = figure(12, 4.4)
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
    # grey cell borders on a grey ground: a neutral (white) tile stays visible
    ax.set_facecolor("0.5")
    ax.pcolormesh(np.stack(tiles), edgecolors="0.35", linewidth=0.6)
    ax.invert_yaxis()
    ax.set_yticks(np.arange(len(tiles)) + 0.5, [f"{i} {m}" for i in highlights for m in methods], fontsize=7)
    factors = next(iter(highlights.values()))["factors"]
    ax.set_xticks(np.arange(len(factors)) + 0.5, [f"{f:g}" for f in factors], fontsize=7)
    ax.set_xlabel("exposure factor")
    ax.set_title("developed white (normalised)")
    written.append(save_png(fig, Path(directory) / "exposure_highlights.png").name)
    return written
