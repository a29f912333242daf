"""How long a frame is exposed and what it collects: the metered time (a camera's meter, ISO 12232
mid grey; or expose to the right), the exposure index the rendering must honour, and the noise-free
electrons of a frame.

References
----------
.. [1] ISO 12232:2019, Photography — Digital still cameras — Determination of exposure
   index (saturation-based exposure).
.. [2] EMVA 1288 Release 4.0, §2.1 (μ_e = η·μ_p).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SensorError
from .noise import saturation_electrons, system_gain
from .radiometry import electron_rates, max_channel_rates, signal_model

if TYPE_CHECKING:  # pragma: no cover
    from ..image import SpectralImage
    from ..scene import SceneConfig

#: Row step of the pixel sample the 99th-percentile auto exposure looks at when a frame
#: has more than :data:`_AUTO_FULL_BELOW` pixels (whole rows: contiguous in memory).
_AUTO_STEP = 8


_AUTO_FULL_BELOW = 1 << 21


def auto_exposure_time(reference_rates: np.ndarray, *, saturation_e: float, fraction: float,
                       dark_current_e_per_s: float = 0.0, percentile: float | None = 99.0
                       ) -> tuple[float, float]:
    """Exposure time that puts the brightest relevant region at a fraction of saturation.

    The reference rate r is the mean of ``reference_rates`` (the white patch's pixels)
    when ``percentile`` is None, else their ``percentile``-th percentile. Then
    ``t = fraction·saturation_e / (r + I_d)``.

    Parameters
    ----------
    reference_rates : numpy.ndarray
        Max-channel photo-electron rates (e⁻/s) of the reference pixels
        (:func:`max_channel_rates`).
    saturation_e : float
        Electrons at saturation.
    fraction : float
        Target fraction of saturation, in (0, 1].
    dark_current_e_per_s : float
        Dark current I_d (e⁻/s), which fills the well too.
    percentile : float or None
        Percentile of the rates to use; None for their mean.

    Returns
    -------
    (float, float)
        Exposure time (s) and the reference rate r (e⁻/s).

    Raises
    ------
    SensorError
        If the reference region receives no light.

    References
    ----------
    .. [1] ISO 12232:2019, Photography — Digital still cameras — Determination of exposure
       index (saturation-based exposure).
    """
    rates = np.asarray(reference_rates, dtype=np.float64).ravel()
    if rates.size == 0:
        raise SensorError("auto exposure needs at least one reference pixel")
    reference = float(rates.mean() if percentile is None else np.percentile(rates, percentile))
    if not reference > 0:
        raise SensorError("exposure.time_s = 'auto' found no light in the reference region; "
                          "give exposure.time_s in seconds")
    return fraction * saturation_e / (reference + dark_current_e_per_s), reference


def _on_capture(mask: np.ndarray, radiance) -> np.ndarray:
    """A mask given for the frame, placed in an image that also holds a crop margin."""
    window = getattr(radiance, "frame_window", None)
    if window is None or mask.shape != tuple(window[2:]):
        return mask
    top, left, height, width = window
    full = np.zeros(radiance.data.shape[:2], dtype=bool)
    full[top:top + height, left:left + width] = mask
    return full


def _white_gains(radiance, config: "SceneConfig", model) -> np.ndarray:
    """White-balance gains of the frame's light (its white's camera RGB inverted, smallest 1),
    so the meter reads luminance as the develop will show it; ones where the light is unknown
    (a radiance without a resolved ``illuminant.spd = "auto"``) or for a monochrome sensor."""
    from .radiometry import white_response

    n = model.weights.shape[1]
    spd = config.illuminant.spd
    if spd == "auto":
        spd = (getattr(radiance, "meta", None) or {}).get("illuminant_spd")
    if n not in (3, 4) or spd is None:  # R, G, B (and an RGBW sensor's W)
        return np.ones(n)
    white = np.asarray(white_response(radiance, config, model, spd), dtype=np.float64)
    if not np.all(white > 0):
        return np.ones(n)
    return white.max() / white


def metering_images(data: np.ndarray, model, gains: np.ndarray, *, step: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """What the meter reads, per pixel of every ``step``-th row: the white-balanced luminance
    rate ¼R·g_R + ½G·g_G + ¼B·g_B and the brightest channel's raw rate (both e⁻/s, noise-free,
    with cos⁴). For a neutral surface both equal the rate of the channel with gain 1, whose
    saturation is the RAW's.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        float32 (rows, W) luminance and peak rates.

    References
    ----------
    .. [1] ISO 12232:2019, §4 (exposure of mid grey); EMVA 1288 Release 4.0, §2.1.
    """
    weights = np.asarray(model.weights, dtype=np.float32)
    n = weights.shape[1]
    if n == 3:
        mix = np.array([0.25, 0.5, 0.25]) * np.asarray(gains, float)
    elif n == 4:  # RGBW: the colour pixels' balanced luminance, in units of the white pixels (gain 1), which clip first
        mix = np.array([0.25, 0.5, 0.25, 0.0]) * np.asarray(gains, float)
    else:
        mix = np.full(n, 1.0 / n)
    rows = range(0, data.shape[0], step)
    lum = np.empty((len(rows), data.shape[1]), np.float32)
    peak = np.empty_like(lum)
    for i, row in enumerate(rows):
        rates = np.asarray(data[row], dtype=np.float32) @ weights  # (W, C)
        lum[i] = rates @ mix.astype(np.float32)
        peak[i] = rates.max(axis=1)
    if model.cos4 is not None:
        lum *= model.cos4[::step]
        peak *= model.cos4[::step]
    return lum, peak


def resolve_exposure(radiance: "SpectralImage", config: "SceneConfig", model, *,
                     white_mask: np.ndarray | None = None) -> tuple[float, float | None]:
    """The exposure time of a frame: ``exposure.time_s``, or, for ``"auto"``, the metered one.

    A camera's meter (``exposure.metering``, :mod:`spectral_cam.metering`) reads the
    white-balanced luminance and puts its grey-equivalent at
    :data:`~spectral_cam.metering.GREY_RAW` (10/78) of saturation × 2^``compensation_ev``:
    ``t = g_target·μ_e,sat / (r + I_d)`` with r the metered rate. ``etr`` (expose to the right)
    keeps the former rule: the mean max-channel rate over ``white_mask`` (e.g. the
    ColorChecker's white patch) or else the 99th percentile over the frame at
    ``exposure.auto_fraction`` (:func:`auto_exposure_time`). Above :data:`_AUTO_FULL_BELOW`
    pixels every :data:`_AUTO_STEP`-th row is read.

    Parameters
    ----------
    radiance : SpectralImage
        The frame's radiance.
    config : SceneConfig
        Uses ``exposure``, ``sensor`` and ``illuminant`` (the white the meter balances for).
    model : SignalModel
        The frame's signal model (:func:`spectral_cam.sensor.radiometry.signal_model`).
    white_mask : numpy.ndarray, optional
        Boolean (H, W) reference region for ``etr`` (default ``radiance.white_reference``).

    Returns
    -------
    (float, float or None)
        Exposure time (s) and the reference rate (e⁻/s; None when the time was given).

    Raises
    ------
    SensorError
        For a white mask of the wrong shape or without a pixel, or a frame without light.

    References
    ----------
    .. [1] ISO 12232:2019, §4–6 (mid grey at H = 10/S; S_sat = 78/H_sat; SOS).
    """
    from ..metering import GREY_RAW, metered_grey

    exposure, sensor = config.exposure, config.sensor
    if exposure.time_s != "auto":
        return float(exposure.time_s), None
    data = radiance.data
    saturation_e = saturation_electrons(sensor, system_gain(sensor, exposure.iso))
    step = 1 if data.shape[0] * data.shape[1] <= _AUTO_FULL_BELOW else _AUTO_STEP
    if exposure.metering == "etr":
        if white_mask is None:
            white_mask = getattr(radiance, "white_reference", None)
        if white_mask is not None:
            mask = _on_capture(np.asarray(white_mask, dtype=bool), radiance)
            if mask.shape != data.shape[:2] or not mask.any():
                raise SensorError(f"white_mask must be a boolean {data.shape[:2]} array with at least one True pixel")
            reference_rates = max_channel_rates(data, model.weights, cos4=model.cos4, mask=mask)
            percentile = None
        else:
            reference_rates = max_channel_rates(data, model.weights, cos4=model.cos4, step=step)
            percentile = 99.0
        return auto_exposure_time(reference_rates, saturation_e=saturation_e, fraction=exposure.auto_fraction,
                                  dark_current_e_per_s=sensor.dark_current_e_per_s, percentile=percentile)
    lum, peak = metering_images(data, model, _white_gains(radiance, config, model), step=step)
    metered = metered_grey(lum, exposure.metering, peak=peak, fraction=exposure.auto_fraction)
    if not metered > 0:
        raise SensorError("exposure.time_s = 'auto' found no light to meter; give exposure.time_s in seconds")
    target = GREY_RAW * 2.0 ** exposure.compensation_ev
    return target * saturation_e / (metered + sensor.dark_current_e_per_s), metered


def exposure_index(config: "SceneConfig") -> dict:
    """How the exposure is defined and what the rendering must add: the ISO definition, mid
    grey's place in the RAW and the BaselineExposure (stops) that the tone curve
    ``isp.tone`` needs to show that grey at 118/255 (``sos``), or 0 (``saturation``).

    The definition is recorded as ``rei`` (recommended exposure index: the user's own) when
    the exposure was compensated or exposed to the right, and as ``manual`` for a given time.

    Returns
    -------
    dict
        ``iso_definition``, ``metering``, ``grey_raw_fraction``, ``baseline_exposure_ev``,
        ``compensation_ev``, ``tone``.

    References
    ----------
    .. [1] ISO 12232:2019, §4–6; Adobe (2023). DNG Specification 1.7.1.0, BaselineExposure.
    """
    import math

    from ..isp.tone import grey_input
    from ..metering import GREY_RAW

    exposure, tone = config.exposure, config.isp.tone
    baseline = math.log2(grey_input(tone) / GREY_RAW) if exposure.iso_definition == "sos" else 0.0
    if exposure.time_s != "auto":
        definition = "manual"
    elif exposure.compensation_ev != 0 or exposure.metering == "etr":
        definition = "rei"
    else:
        definition = exposure.iso_definition
    return {"iso_definition": definition, "configured": exposure.iso_definition,
            "metering": exposure.metering if exposure.time_s == "auto" else None,
            "grey_raw_fraction": GREY_RAW * 2.0 ** exposure.compensation_ev,
            "baseline_exposure_ev": baseline, "compensation_ev": exposure.compensation_ev, "tone": tone}


def expected_electrons(radiance: "SpectralImage", config: "SceneConfig", *, exposure_s: float | None = None,
                       white_mask: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """Noise-free photo-electrons of every pixel through its CFA filter, and the exposure.

    Parameters
    ----------
    radiance, config
        As for :func:`expose`.
    exposure_s
        Exposure time (s); default the config's (``"auto"`` resolved as :func:`expose` does,
        by :func:`resolve_exposure`).
    white_mask
        Auto-exposure reference, as for :func:`expose`.

    Returns
    -------
    (numpy.ndarray, float)
        float32 (H, W) mean electrons (no dark current) and the exposure time (s).

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1 (μ_e = η·μ_p).
    """
    model = signal_model(radiance, config)
    rate = electron_rates(radiance.data, model.weights, cfa=config.sensor.cfa, cos4=model.cos4,
                          olpf_px=model.olpf_px, channel_gain=model.channel_gain)
    if exposure_s is None:
        exposure_s, _ = resolve_exposure(radiance, config, model, white_mask=white_mask)
    return rate * np.float32(exposure_s), float(exposure_s)
