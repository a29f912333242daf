"""A camera's light meter: one number from a frame's linear luminance, read as mid grey.

Every mode returns the *grey-equivalent* value g of a frame: the exposure that puts g at
:data:`GREY_RAW` of saturation is the metered exposure. The one-shot auto exposure
(:mod:`spectral_cam.sensor.metered_exposure`, ``exposure.metering``) and the sequence controller
(:mod:`spectral_cam.control.exposure_loop`) both use it, so a render, a dataset item and a
sequence frame meter alike.

- ``average``: the mean luminance (the meter ISO 2720 calibrates, K = 12.5);
- ``centre_weighted``: a Gaussian weight, σ = ¼ of the frame's diagonal;
- ``spot``: the central 5 % of the area;
- ``highlight``: highlight-protecting: the average, unless the 99th percentile of the
  brightest channel would land above ``fraction`` of saturation, in which case that
  percentile is placed there (a camera's highlight-weighted mode);
- ``etr``: expose to the right: the 99th percentile of the brightest channel (or a white
  reference's mean) at ``fraction`` of saturation, whatever grey becomes (the simulator's
  exposure before issue 23: high-key, the least shot noise).

**Where grey lands in the RAW.** ISO 12232 meters mid grey at a focal-plane exposure
H = 10/S and defines the saturation-based speed by S_sat = 78/H_sat, so a metered grey sits at
10/78 = 12.8 % of saturation: 2.96 EV below clipping, half a stop above a perfect white
diffuser at 18 % grey's exposure. The standard output sensitivity then asks the rendering to
show that grey at 118/255 (the develop's BaselineExposure does it).

References
----------
.. [1] ISO 12232:2019, Photography — Digital still cameras — Determination of exposure index,
   ISO speed ratings, standard output sensitivity, and recommended exposure index, §4–6
   (H = 10/S for mid grey; S_sat = 78/H_sat; S_SOS: 118 of 255 in sRGB).
.. [2] ISO 2720:1974, General purpose photographic exposure meters (K = 12.5 cd·m⁻²).
"""

from __future__ import annotations

import math

import numpy as np

from .errors import ConfigError
from .registry import Registry

__all__ = ["METERING", "GREY_RAW", "metered_grey", "centre_weights", "ISO_DEFINITIONS", "bayer_luminance"]

#: Mid grey's place in a metered RAW, as a fraction of saturation: ISO 12232's 10/78.
GREY_RAW = 10.0 / 78.0

#: ``exposure.iso_definition``: how the exposure index is defined (ISO 12232:2019): ``sos``,
#: standard output sensitivity (the metered grey renders at 118/255: the RAW carries the
#: BaselineExposure that does it); ``saturation``, saturation-based speed (the RAW alone: no
#: BaselineExposure, the rendering shows grey where its curve puts 12.8 %).
ISO_DEFINITIONS = ("sos", "saturation")

METERING = Registry("metering mode")


def centre_weights(shape) -> np.ndarray:
    """Gaussian weights over a frame, σ = ¼ of its diagonal, centred."""
    h, w = shape
    y, x = np.mgrid[0:h, 0:w]
    sigma = 0.25 * math.hypot(h, w)
    return np.exp(-(((y - (h - 1) / 2) ** 2 + (x - (w - 1) / 2) ** 2) / (2 * sigma * sigma)))


def _spot(lum: np.ndarray) -> float:
    h, w = lum.shape
    side_h, side_w = max(1, round(h * math.sqrt(0.05))), max(1, round(w * math.sqrt(0.05)))
    top, left = (h - side_h) // 2, (w - side_w) // 2
    return float(np.mean(lum[top:top + side_h, left:left + side_w]))


def _percentile(peak: np.ndarray) -> float:
    return float(np.percentile(peak, 99.0))


METERING.add("average", lambda lum, peak, fraction: float(np.mean(lum)), description="mean of the frame")
METERING.add("centre_weighted", lambda lum, peak, fraction: float(np.average(lum, weights=centre_weights(lum.shape))),
             description="Gaussian weight, σ = ¼ of the diagonal")
METERING.add("spot", lambda lum, peak, fraction: _spot(lum), description="the central 5 % of the area")
METERING.add("highlight",
             lambda lum, peak, fraction: max(float(np.mean(lum)), _percentile(peak) * GREY_RAW / fraction),
             description="average, but the 99th percentile of the brightest channel kept at or below the "
                         "highlight fraction of saturation")
METERING.add("etr", lambda lum, peak, fraction: _percentile(peak) * GREY_RAW / fraction,
             description="expose to the right: the 99th percentile of the brightest channel at the fraction "
                         "of saturation")


def metered_grey(luminance: np.ndarray, mode: str = "average", *, peak: np.ndarray | None = None,
                 fraction: float = 0.8) -> float:
    """The grey-equivalent value of a frame: the exposure that puts it at :data:`GREY_RAW`
    of saturation is the metered one.

    Parameters
    ----------
    luminance : numpy.ndarray
        (H, W) linear luminance (any unit; a fraction of saturation in a RAW).
    mode : str
        A :data:`METERING` name.
    peak : numpy.ndarray, optional
        (H, W) brightest channel per pixel, in the same unit (default ``luminance``): what
        ``highlight`` and ``etr`` keep from clipping.
    fraction : float
        Fraction of saturation for the 99th percentile of ``peak`` (``highlight``, ``etr``).

    Returns
    -------
    float
        The grey-equivalent value, in the unit of ``luminance``.

    Raises
    ------
    ConfigError
        For an unknown mode (listing the valid ones) or a frame without pixels.

    References
    ----------
    .. [1] ISO 12232:2019, §4–6; ISO 2720:1974.

    Examples
    --------
    A flat 18 % grey field meters as itself in every mode:

    >>> import numpy as np
    >>> [round(metered_grey(np.full((8, 8), 0.18), m), 3) for m in ("average", "centre_weighted", "spot")]
    [0.18, 0.18, 0.18]
    """
    lum = np.asarray(luminance, dtype=np.float64)
    if lum.ndim != 2 or lum.size == 0:
        raise ConfigError(f"metering needs a non-empty 2-D luminance image; got shape {lum.shape}")
    if not 0 < fraction <= 1:
        raise ConfigError(f"metering fraction {fraction!r}: must lie in (0, 1]")
    peak = lum if peak is None else np.asarray(peak, dtype=np.float64)
    return METERING[mode](lum, peak, fraction)


def bayer_luminance(rgb: np.ndarray) -> np.ndarray:
    """A meter's luminance from camera RGB: ¼R + ½G + ¼B (a Bayer cell's mean)."""
    rgb = np.asarray(rgb)
    return 0.25 * rgb[..., 0] + 0.5 * rgb[..., 1] + 0.25 * rgb[..., 2]
