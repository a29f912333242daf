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


def expected_electrons(radiance: "SpectralImage", config: "SceneConfig", *, exposure_s: float | None = None,
                       white_mask: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """Noise-free photo-electrons of every pixel through its CFA filter, and the exposure.

    Parameters
    ----------
    radiance, config
        As for :func:`expose`.
    exposure_s
        Exposure time (s); default the config's (``"auto"`` resolved as :func:`expose` does).
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
        exposure = config.exposure
        if exposure.time_s != "auto":
            exposure_s = float(exposure.time_s)
        else:
            saturation_e = saturation_electrons(config.sensor, system_gain(config.sensor, exposure.iso))
            if white_mask is not None:
                reference = max_channel_rates(radiance.data, model.weights, cos4=model.cos4, mask=white_mask)
                percentile = None
            else:
                reference = max_channel_rates(radiance.data, model.weights, cos4=model.cos4)
                percentile = 99.0
            exposure_s, _ = auto_exposure_time(reference, saturation_e=saturation_e, fraction=exposure.auto_fraction,
                                               dark_current_e_per_s=config.sensor.dark_current_e_per_s,
                                               percentile=percentile)
    return rate * np.float32(exposure_s), float(exposure_s)
