"""Exposure: the time that puts the brightest relevant region at a fraction of saturation,
and the noise-free electrons of a frame at that exposure.

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


def resolve_exposure(radiance: "SpectralImage", config: "SceneConfig", model, *,
                     white_mask: np.ndarray | None = None) -> tuple[float, float | None]:
    """The exposure time of a frame: ``exposure.time_s``, or, for ``"auto"``, the time that
    puts the reference region at ``exposure.auto_fraction`` of saturation
    (:func:`auto_exposure_time`). The reference is the mean max-channel rate over
    ``white_mask`` (e.g. the ColorChecker's white patch), else the 99th percentile over the
    frame (every :data:`_AUTO_STEP`-th row above :data:`_AUTO_FULL_BELOW` pixels).

    Parameters
    ----------
    radiance : SpectralImage
        The frame's radiance.
    config : SceneConfig
        Uses ``exposure`` and ``sensor``.
    model : SignalModel
        The frame's signal model (:func:`spectral_cam.sensor.radiometry.signal_model`).
    white_mask : numpy.ndarray, optional
        Boolean (H, W) reference region (default ``radiance.white_reference``).

    Returns
    -------
    (float, float or None)
        Exposure time (s) and the reference rate (e⁻/s; None when the time was given).

    Raises
    ------
    SensorError
        For a white mask of the wrong shape or without a pixel, or a reference without light.

    References
    ----------
    .. [1] ISO 12232:2019 (saturation-based exposure).
    """
    exposure, sensor = config.exposure, config.sensor
    if exposure.time_s != "auto":
        return float(exposure.time_s), None
    data = radiance.data
    if white_mask is None:
        white_mask = getattr(radiance, "white_reference", None)
    if white_mask is not None:
        mask = _on_capture(np.asarray(white_mask, dtype=bool), radiance)
        if mask.shape != data.shape[:2] or not mask.any():
            raise SensorError(f"white_mask must be a boolean {data.shape[:2]} array with at least one True pixel")
        reference_rates = max_channel_rates(data, model.weights, cos4=model.cos4, mask=mask)
        percentile = None
    else:
        step = 1 if data.shape[0] * data.shape[1] <= _AUTO_FULL_BELOW else _AUTO_STEP
        reference_rates = max_channel_rates(data, model.weights, cos4=model.cos4, step=step)
        percentile = 99.0
    saturation_e = saturation_electrons(sensor, system_gain(sensor, exposure.iso))
    return auto_exposure_time(reference_rates, saturation_e=saturation_e, fraction=exposure.auto_fraction,
                              dark_current_e_per_s=sensor.dark_current_e_per_s, percentile=percentile)


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
    rate = electron_rates(radiance.data, model.weights, cfa=config.sensor.cfa, cos4=model.cos4)
    if exposure_s is None:
        exposure_s, _ = resolve_exposure(radiance, config, model, white_mask=white_mask)
    return rate * np.float32(exposure_s), float(exposure_s)
