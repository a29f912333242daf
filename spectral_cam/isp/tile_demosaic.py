"""Demosaicers for the larger tiles (:data:`spectral_cam.cfa.EXTENDED_PATTERNS`): ``colour_difference``
(any CFA: X-Trans, Quad Bayer, Bayer), ``quad_remosaic`` and ``quad_binning`` (Quad Bayer, as a phone's
full-resolution and binned modes) and ``rgbw_fusion`` (white pixels for luminance). Each is registered in
:data:`spectral_cam.isp.demosaic.DEMOSAIC` with the tiles it takes.

References
----------
.. [1] Adams, J. E. (1997). Design of practical color filter array interpolation algorithms for
   digital cameras. Proc. SPIE 3028, 117–125 (colour-difference interpolation).
.. [2] Knutsson, H., & Westin, C.-F. (1993). Normalized and differential convolution. Proc. CVPR, 515–523.
.. [3] Sony Semiconductor Solutions (2018), IMX586 Quad Bayer coding.
.. [4] Compton & Hamilton (2007), US 8,139,130 (panchromatic and colour pixels combined).
"""

from __future__ import annotations

import numpy as np

from ..cfa import channel_index, check_cfa
from ..errors import ConfigError
from .menon2007 import menon2007

__all__ = ["colour_difference", "quad_binning", "quad_remosaic", "rgbw_fusion"]

_F32 = np.float32


def _masked_mean(values: np.ndarray, mask: np.ndarray, radius: int) -> np.ndarray:
    """Normalised masked convolution with a separable tent of ``radius`` px: the weighted mean of the
    samples where ``mask`` is set, near each pixel (mirror padding keeps the CFA's phase at edges)."""
    import cv2

    tent = np.array([radius + 1 - abs(k) for k in range(-radius, radius + 1)], dtype=_F32)
    tent /= tent.sum()
    border = cv2.BORDER_REFLECT_101
    num = cv2.sepFilter2D(values * mask, -1, tent, tent, borderType=border)
    den = cv2.sepFilter2D(mask, -1, tent, tent, borderType=border)
    return num / np.maximum(den, 1e-12)


#: Interpolation radius (px) per colour for a tile: every pixel sees a sample of each colour within it.
def _radii(cfa: str) -> tuple[int, int, int]:
    from ..cfa import cfa_period

    rows, _ = cfa_period(cfa)
    return {2: (1, 1, 1), 4: (2, 2, 2), 6: (2, 1, 2)}.get(rows, (rows // 2,) * 3)


def colour_difference(mosaic: np.ndarray, cfa: str) -> np.ndarray:
    """Any CFA (Bayer, X-Trans, Quad Bayer; RGBW without its white): green by normalised masked convolution, then R − G and
    B − G at the red and blue sites interpolated the same way and added to green — colour varies
    more slowly than luminance, so the differences interpolate with fewer fringes than the colours
    themselves (Adams 1997). Measured samples are kept.

    References
    ----------
    .. [1] Adams, J. E. (1997). Design of practical color filter array interpolation algorithms for
       digital cameras. Proc. SPIE 3028, 117–125 (colour-difference interpolation).
    .. [2] Knutsson, H., & Westin, C.-F. (1993). Normalized and differential convolution. Proc. CVPR,
       515–523.
    """
    mosaic = np.ascontiguousarray(mosaic, dtype=_F32)
    if mosaic.ndim != 2:
        raise ConfigError(f"demosaicing needs a 2-D mosaic; got shape {mosaic.shape}")
    name = check_cfa(cfa, allow_extended=True)
    index = channel_index(mosaic.shape, name)
    masks = [(index == c).astype(_F32) for c in range(3)]
    radius_r, radius_g, radius_b = _radii(name)
    green = np.where(masks[1] > 0, mosaic, _masked_mean(mosaic, masks[1], radius_g))
    out = np.empty((*mosaic.shape, 3), dtype=_F32)
    out[..., 1] = green
    for c, radius in ((0, radius_r), (2, radius_b)):
        difference = _masked_mean(mosaic - green, masks[c], radius)
        out[..., c] = np.where(masks[c] > 0, mosaic, green + difference)
    return out


def _quad_cells(mosaic: np.ndarray) -> np.ndarray:
    """Each 2×2 same-colour cell of a Quad Bayer mosaic averaged: an RGGB Bayer mosaic of half size."""
    h, w = (mosaic.shape[0] // 4) * 4, (mosaic.shape[1] // 4) * 4
    return mosaic[:h, :w].reshape(h // 2, 2, w // 2, 2).mean(axis=(1, 3)).astype(_F32)


def quad_binning(mosaic: np.ndarray, cfa: str) -> np.ndarray:
    """Quad Bayer binned: each 2×2 cell's mean (4× the signal, half the resolution, as a phone's
    low-light mode reads it), an RGGB mosaic demosaiced by ``menon2007``, brought back to full size
    by bilinear interpolation (pixel centres aligned).

    References
    ----------
    .. [1] Sony Semiconductor Solutions (2018), IMX586 Quad Bayer coding (binning mode).
    """
    import cv2

    mosaic = np.ascontiguousarray(mosaic, dtype=_F32)
    if check_cfa(cfa, allow_extended=True) != "QUAD_RGGB":
        raise ConfigError(f"quad_binning needs a QUAD_RGGB mosaic; this one is {cfa}: use colour_difference")
    if mosaic.shape[0] < 8 or mosaic.shape[1] < 8:
        raise ConfigError(f"a Quad Bayer mosaic needs at least 8×8 pixels; got {mosaic.shape}")
    half = menon2007(_quad_cells(mosaic), "RGGB")
    full = cv2.resize(half, (half.shape[1] * 2, half.shape[0] * 2), interpolation=cv2.INTER_LINEAR)
    out = np.empty((*mosaic.shape, 3), dtype=_F32)
    out[:full.shape[0], :full.shape[1]] = full
    out[full.shape[0]:, :full.shape[1]] = full[-1:]  # rows and columns past the last whole tile
    out[:, full.shape[1]:] = out[:, full.shape[1] - 1:full.shape[1]]
    return out


def quad_remosaic(mosaic: np.ndarray, cfa: str) -> np.ndarray:
    """Quad Bayer remosaiced to full-resolution RGGB (as a phone's full-resolution mode does): the
    colour-difference estimate of every colour, sampled through an RGGB tile — the Quad samples
    that already sit on their Bayer colour kept — then demosaiced by ``menon2007``.

    References
    ----------
    .. [1] Sony Semiconductor Solutions (2018), IMX586 Quad Bayer coding (remosaic to Bayer).
    """
    mosaic = np.ascontiguousarray(mosaic, dtype=_F32)
    if check_cfa(cfa, allow_extended=True) != "QUAD_RGGB":
        raise ConfigError(f"quad_remosaic needs a QUAD_RGGB mosaic; this one is {cfa}: use colour_difference")
    full = colour_difference(mosaic, cfa)
    bayer = np.take_along_axis(full, channel_index(mosaic.shape, "RGGB").astype(np.intp)[..., None], axis=2)[..., 0]
    return menon2007(np.ascontiguousarray(bayer), "RGGB")


def rgbw_fusion(mosaic: np.ndarray, cfa: str) -> np.ndarray:
    """RGBW fused: the white (panchromatic) pixels, half the mosaic, give the luminance detail; each
    colour is white plus its difference from white, interpolated over that colour's sparse sites
    (normalised masked convolution). After white balance a neutral has R = G = B = W, so the
    differences are the chroma, which varies slowly — the fusion of a panchromatic CFA's two halves.

    References
    ----------
    .. [1] Compton & Hamilton (2007), US 8,139,130 (panchromatic and colour pixels combined).
    .. [2] Adams (1997), Proc. SPIE 3028 (colour-difference interpolation).
    """
    from ..cfa import WHITE

    mosaic = np.ascontiguousarray(mosaic, dtype=_F32)
    if check_cfa(cfa, allow_extended=True) != "RGBW":
        raise ConfigError(f"rgbw_fusion needs an RGBW mosaic; this one is {cfa}")
    index = channel_index(mosaic.shape, cfa)
    white_mask = (index == WHITE).astype(_F32)
    white = np.where(white_mask > 0, mosaic, _masked_mean(mosaic, white_mask, 1))
    out = np.empty((*mosaic.shape, 3), dtype=_F32)
    for c, radius in ((0, 3), (1, 2), (2, 3)):
        mask = (index == c).astype(_F32)
        out[..., c] = np.where(mask > 0, mosaic, white + _masked_mean(mosaic - white, mask, radius))
    return out
