"""Highlight handling: keep clipped sensor regions neutral after white balance.

Where a sensor channel clipped, white balance scales the clipped channels by different
gains, so a clipped white becomes (g_R, 1, g_B)·saturation: magenta, for the usual gains
g_R, g_B > 1. With gains normalised so the smallest is 1 (see
:mod:`spectral_cam.isp.white_balance`), the highest level all three channels can still
represent after white balance is the saturation level itself; limiting the channels of
pixels near a clipped sample to that level makes fully clipped areas white and partly
clipped ones keep the hue of their unclipped channels (dcraw's ``-H 0``). Pixels away from
clipped samples are left untouched, so unclipped colours stay exact.

References
----------
.. [1] Coffin, D. dcraw.c, ``-H 0`` ("clip") and ``-H 1..2`` (unclip, blend) highlight modes.
.. [2] Adobe (2023). DNG Specification 1.7.1.0, WhiteLevel.
"""

from __future__ import annotations

import numpy as np

from ..registry import Registry

__all__ = ["HIGHLIGHTS", "clipped_mask", "handle_highlights"]


def clipped_mask(mosaic: np.ndarray, *, saturation: float = 1.0, threshold: float = 0.995,
                 radius_px: int = 2) -> np.ndarray:
    """Pixels whose demosaiced value depends on a clipped raw sample.

    Parameters
    ----------
    mosaic
        (H, W) normalised linear mosaic before white balance (1 = white level).
    saturation
        Normalised clipping level of the sensor.
    threshold
        A sample counts as clipped at ``threshold × saturation`` or above.
    radius_px
        Dilation radius, pixels: the demosaicing kernel's reach (2 for 5×5 kernels).

    Returns
    -------
    numpy.ndarray
        (H, W) bool mask.

    References
    ----------
    .. [1] Coffin, D. dcraw.c, highlight handling.
    """
    import cv2

    hit = (np.asarray(mosaic) >= threshold * saturation).astype(np.uint8)
    if radius_px > 0 and hit.any():
        size = 2 * int(radius_px) + 1
        hit = cv2.dilate(hit, np.ones((size, size), np.uint8))
    return hit.astype(bool)


def _none(rgb, mask, level):
    return rgb


def _clip(rgb, mask, level):
    if not mask.any():
        return rgb
    out = rgb.copy()
    out[mask] = np.minimum(out[mask], np.float32(level))
    return out


def _desaturate(rgb, mask, level):
    import cv2

    if not mask.any():
        return rgb
    clipped = _clip(rgb, mask, level)
    # blend clipped pixels smoothly towards neutral at their brightest channel
    weight = cv2.GaussianBlur(mask.astype(np.float32), (0, 0), 1.0)[..., None]
    weight = np.where(mask[..., None], 1.0, weight).astype(np.float32)
    neutral = np.repeat(clipped.max(axis=-1, keepdims=True), 3, axis=-1)
    return (1 - weight) * rgb + weight * neutral


#: Highlight handlers by name.
HIGHLIGHTS = Registry("highlight method")
HIGHLIGHTS.add("clip", _clip, description="limit masked pixels to the white-balanced saturation")
HIGHLIGHTS.add("desaturate", _desaturate, description="clip, then blend to neutral")
HIGHLIGHTS.add("none", _none, description="leave clipped pixels as they are")


def handle_highlights(rgb: np.ndarray, mask: np.ndarray, *, level: float = 1.0,
                      method: str = "clip") -> np.ndarray:
    """Make clipped regions neutral after white balance and demosaicing.

    Parameters
    ----------
    rgb
        (H, W, 3) float32 white-balanced camera RGB (1 = white level).
    mask
        (H, W) bool, from :func:`clipped_mask`.
    level
        The lowest white-balanced saturation over the channels, min_c(g_c)·saturation;
        1 with gains normalised to a smallest gain of 1.
    method
        ``"clip"``: limit every channel of masked pixels to ``level``; ``"desaturate"``:
        additionally blend masked pixels (feathered by a 1-px Gaussian) to neutral grey at
        their brightest clipped channel; ``"none"``: leave as is.

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32.

    Raises
    ------
    ConfigError
        For an unknown method (listing the valid ones).

    References
    ----------
    .. [1] Coffin, D. dcraw.c, ``-H`` highlight modes.
    """
    rgb = np.asarray(rgb, dtype=np.float32)
    return HIGHLIGHTS[method](rgb, np.asarray(mask, dtype=bool), float(level)).astype(np.float32, copy=False)
