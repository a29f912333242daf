"""Demosaicing: a registry of Bayer interpolators with one call, :func:`demosaic`.

Every method takes the (white-balanced) float32 linear mosaic and returns (H, W, 3)
float32 linear RGB, unclipped, for any of the four Bayer phases and any image size
(odd included).

- ``bilinear``: normalised masked convolution (cv2.filter2D, float32). Mirror padding
  about the edge pixel (BORDER_REFLECT_101) keeps the CFA phase, so borders are exact
  bilinear too.
- ``malvar2004``: gradient-corrected linear interpolation, the four 5×5 kernels of Malvar,
  He & Cutler applied with cv2.filter2D in float32 and selected per CFA site.
- ``menon2007``: directional filtering with a posteriori decision, colour-demosaicing's
  algorithm in float32 OpenCV filters (:mod:`spectral_cam.isp.menon2007`).
- ``vng`` and ``ea``: OpenCV's variable number of gradients and edge-aware demosaicing.
  OpenCV's VNG accepts 8-bit input only (EA 8- or 16-bit). To keep the linear data's
  precision, the mosaic is split in two layers: a coarse layer, scaled to the image
  maximum and quantised (square-root encoded to 8 bits for VNG, linear 16 bits for EA),
  which OpenCV demosaics; and the residual the quantisation left, which is small and is
  interpolated bilinearly and added back. Measured samples are therefore kept exactly,
  and the result differs from a hypothetical float VNG only in how the sub-quantum
  residual is interpolated.

References
----------
.. [1] Malvar, H. S., He, L., & Cutler, R. (2004). High-quality linear interpolation for
   demosaicing of Bayer-patterned color images. Proc. IEEE ICASSP, vol. 3, 485–488.
.. [2] Menon, D., Andriani, S., & Calvagno, G. (2007). Demosaicing with directional
   filtering and a posteriori decision. IEEE Trans. Image Process. 16(1), 132–141.
.. [3] Chang, E., Cheung, S., & Pan, D. Y. (1999). Color filter array recovery using a
   threshold-based variable number of gradients. Proc. SPIE 3650, 36–43 (VNG).
.. [4] OpenCV documentation, imgproc "Color conversions", Bayer → RGB (bilinear, VNG, EA).
.. [5] Mansencal, T., et al. colour-demosaicing, https://github.com/colour-science/colour-demosaicing
"""

from __future__ import annotations

import numpy as np

from ..cfa import channel_index, channel_masks, check_cfa, opencv_bayer_code
from ..errors import ConfigError
from ..registry import Registry

__all__ = ["DEMOSAIC", "demosaic", "bilinear", "malvar2004", "menon2007", "vng", "ea"]

_F32 = np.float32
# bilinear kernels for green (4-neighbour) and red/blue (4 + 4 neighbours)
_K_G = np.array([[0, 1, 0], [1, 4, 1], [0, 1, 0]], _F32) / 4
_K_RB = np.array([[1, 2, 1], [2, 4, 2], [1, 2, 1]], _F32) / 4

# Malvar, He & Cutler (2004), Fig. 2, all divided by 8
_K_G_AT_RB = np.array([
    [0, 0, -1, 0, 0],
    [0, 0, 2, 0, 0],
    [-1, 2, 4, 2, -1],
    [0, 0, 2, 0, 0],
    [0, 0, -1, 0, 0]], _F32) / 8
# a colour at a green site whose horizontal neighbours have that colour
_K_ROW = np.array([
    [0, 0, 0.5, 0, 0],
    [0, -1, 0, -1, 0],
    [-1, 4, 5, 4, -1],
    [0, -1, 0, -1, 0],
    [0, 0, 0.5, 0, 0]], _F32) / 8
# a colour at a green site whose vertical neighbours have that colour
_K_COL = np.ascontiguousarray(_K_ROW.T)
# red at blue sites and blue at red sites
_K_DIAG = np.array([
    [0, 0, -1.5, 0, 0],
    [0, 2, 0, 2, 0],
    [-1.5, 0, 6, 0, -1.5],
    [0, 2, 0, 2, 0],
    [0, 0, -1.5, 0, 0]], _F32) / 8


def _filter(image: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    import cv2

    # filter2D computes a correlation; every kernel here is symmetric, so it equals the
    # convolution. REFLECT_101 mirrors about the edge pixel, which keeps the CFA phase.
    return cv2.filter2D(image, cv2.CV_32F, kernel, borderType=cv2.BORDER_REFLECT_101)


def _check(mosaic: np.ndarray, cfa: str) -> tuple[np.ndarray, str]:
    mosaic = np.ascontiguousarray(mosaic, dtype=_F32)
    if mosaic.ndim != 2:
        raise ConfigError(f"demosaicing needs a 2-D mosaic; got shape {mosaic.shape}")
    if min(mosaic.shape) < 2:
        raise ConfigError(f"a Bayer mosaic needs at least 2×2 pixels; got {mosaic.shape}")
    return mosaic, check_cfa(cfa)


def bilinear(mosaic: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
    """Bilinear demosaicing by normalised masked convolution.

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic.
    cfa
        Bayer tile name read from the top-left pixel.

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 linear RGB; measured samples are kept.

    References
    ----------
    .. [1] Gunturk, B. K., et al. (2005). Demosaicking: color filter array interpolation.
       IEEE Signal Processing Magazine 22(1), 44–54, §"Bilinear interpolation".
    """
    mosaic, cfa = _check(mosaic, cfa)
    masks = channel_masks(mosaic.shape, cfa)
    out = np.empty(mosaic.shape + (3,), _F32)
    for c, kernel in ((0, _K_RB), (1, _K_G), (2, _K_RB)):
        out[..., c] = _filter(mosaic * masks[..., c], kernel)
    return out


def _green_neighbour_masks(shape, cfa):
    """Masks of green sites whose horizontal neighbours are red (``g_r``) or blue."""
    index = channel_index(shape, cfa)
    # the colour of the horizontal neighbour of (y, x) is the colour at (y, x ^ 1)
    tile = np.array([{"R": 0, "G": 1, "B": 2}[c] for c in cfa]).reshape(2, 2)
    rows = np.arange(shape[0])[:, None] % 2
    cols = np.arange(shape[1])[None, :] % 2
    neighbour = tile[rows, 1 - cols]
    green = index == 1
    return index, green & (neighbour == 0), green & (neighbour == 2)


def malvar2004(mosaic: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
    """Gradient-corrected bilinear demosaicing (Malvar, He & Cutler 2004).

    Four fixed 5×5 kernels (cv2.filter2D, float32) are evaluated over the whole mosaic
    and selected per CFA site; linear in the data and exact on constant and linearly
    varying colour fields.

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic.
    cfa
        Bayer tile name read from the top-left pixel.

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 linear RGB, unclipped (the kernels can overshoot at edges);
        measured samples are kept.

    References
    ----------
    .. [1] Malvar, H. S., He, L., & Cutler, R. (2004). Proc. IEEE ICASSP, vol. 3, 485–488.
    """
    mosaic, cfa = _check(mosaic, cfa)
    index, g_rrow, g_brow = _green_neighbour_masks(mosaic.shape, cfa)
    g_at_rb = _filter(mosaic, _K_G_AT_RB)
    along_row = _filter(mosaic, _K_ROW)
    along_col = _filter(mosaic, _K_COL)
    diagonal = _filter(mosaic, _K_DIAG)
    red, blue = index == 0, index == 2
    r = np.where(red, mosaic, np.where(blue, diagonal, np.where(g_rrow, along_row, along_col)))
    g = np.where(index == 1, mosaic, g_at_rb)
    b = np.where(blue, mosaic, np.where(red, diagonal, np.where(g_brow, along_row, along_col)))
    return np.stack([r, g, b], axis=-1).astype(_F32, copy=False)


def menon2007(mosaic: np.ndarray, cfa: str = "RGGB", *, refining_step: bool = True) -> np.ndarray:
    """Directional filtering with a posteriori decision (Menon, Andriani & Calvagno 2007).

    colour-demosaicing's algorithm, computed with OpenCV filters in float32
    (:mod:`spectral_cam.isp.menon2007`; ~30× faster, and without importing colour).

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic.
    cfa
        Bayer tile name read from the top-left pixel.
    refining_step
        Apply the paper's refining step.

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 linear RGB, unclipped; measured samples are kept.

    References
    ----------
    .. [1] Menon, D., Andriani, S., & Calvagno, G. (2007). IEEE Trans. Image Process.
       16(1), 132–141.
    """
    from .menon2007 import REACH_PX, menon2007_demosaic

    mosaic, cfa = _check(mosaic, cfa)
    return in_strips(mosaic, cfa, lambda part, tile: menon2007_demosaic(part, tile, refining_step=refining_step),
                     reach_px=REACH_PX)


#: Frames at least this large (pixels) are demosaiced in row strips on parallel threads.
STRIP_MIN_PIXELS = 2_000_000


def in_strips(mosaic: np.ndarray, cfa: str, method, *, reach_px: int, workers: int | None = None) -> np.ndarray:
    """Run a demosaicer whose output at a pixel depends only on the mosaic within ``reach_px``
    on row strips in parallel threads (NumPy releases the GIL in its loops), each strip read with
    ``reach_px`` real rows of overlap on either side, so the result equals the whole-frame one.

    Parameters
    ----------
    mosaic
        (H, W) float32 mosaic.
    cfa
        Bayer tile at the top-left pixel.
    method
        ``method(part, tile) -> (h, w, 3)`` for a sub-mosaic and its own top-left tile.
    reach_px
        How far (pixels, even) the method's output depends on the mosaic.
    workers
        Threads (default: the CPUs; one strip per thread).
    """
    import os
    from concurrent.futures import ThreadPoolExecutor

    from ..cfa import cfa_at

    height = mosaic.shape[0]
    workers = workers or os.cpu_count() or 1
    if workers < 2 or mosaic.size < STRIP_MIN_PIXELS or height < 4 * reach_px * workers:
        return method(mosaic, cfa)
    edges = [2 * round(height * k / workers / 2) for k in range(workers)] + [height]
    out = np.empty(mosaic.shape + (3,), _F32)

    def strip(k):
        top, bottom = edges[k], edges[k + 1]
        first, last = max(top - reach_px, 0), min(bottom + reach_px, height)
        part = method(mosaic[first:last], cfa_at(cfa, first, 0))
        out[top:bottom] = part[top - first:bottom - first]

    with ThreadPoolExecutor(max_workers=workers) as pool:
        list(pool.map(strip, range(workers)))
    return out


#: Mirror padding (pixels, even) around the mosaic for OpenCV's Bayer conversions.
_OPENCV_PAD = 4


def _opencv_layers(mosaic: np.ndarray, cfa: str, method: str, bits: int, sqrt_encode: bool) -> np.ndarray:
    """OpenCV demosaicing of a quantised coarse layer plus bilinear interpolation of the
    quantisation residual (see the module docstring)."""
    import cv2

    top = float(np.max(mosaic))
    if not np.isfinite(top) or top <= 0:
        return bilinear(mosaic, cfa)
    levels = float(2 ** bits - 1)
    unit = np.clip(mosaic / _F32(top), 0.0, 1.0)
    encoded = np.sqrt(unit) if sqrt_encode else unit
    code = np.rint(encoded * levels).astype(np.uint8 if bits == 8 else np.uint16)

    def decode(values):
        v = values.astype(_F32) / _F32(levels)
        return (v * v if sqrt_encode else v) * _F32(top)

    # OpenCV fills its outermost rows and columns by copying; pad by an even width with
    # mirror padding (which keeps the CFA phase) so every output pixel is interpolated
    pad = _OPENCV_PAD
    padded = cv2.copyMakeBorder(code, pad, pad, pad, pad, cv2.BORDER_REFLECT_101)
    coarse = decode(cv2.cvtColor(padded, opencv_bayer_code(cfa, method))[pad:-pad, pad:-pad])
    residual = mosaic - decode(code)
    return (coarse + bilinear(residual, cfa)).astype(_F32, copy=False)


def vng(mosaic: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
    """OpenCV's variable-number-of-gradients demosaicing (8-bit core, see module notes).

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic.
    cfa
        Bayer tile name read from the top-left pixel (OpenCV's name is derived with
        :func:`~spectral_cam.cfa.opencv_bayer_name`).

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 linear RGB.

    References
    ----------
    .. [1] Chang, E., Cheung, S., & Pan, D. Y. (1999). Proc. SPIE 3650, 36–43.
    .. [2] OpenCV documentation, COLOR_Bayer**2RGB_VNG (8-bit only).
    """
    mosaic, cfa = _check(mosaic, cfa)
    return _opencv_layers(mosaic, cfa, "VNG", 8, True)


def ea(mosaic: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
    """OpenCV's edge-aware demosaicing, run on 16 bits (see module notes).

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic.
    cfa
        Bayer tile name read from the top-left pixel.

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 linear RGB.

    References
    ----------
    .. [1] OpenCV documentation, COLOR_Bayer**2RGB_EA.
    """
    mosaic, cfa = _check(mosaic, cfa)
    return _opencv_layers(mosaic, cfa, "EA", 16, False)


#: Demosaicing methods by name.
#: Demosaicing methods by name (``isp.demosaic``); a new method is one entry here.
DEMOSAIC = Registry("demosaic method")
DEMOSAIC.add("bilinear", bilinear, description="normalised masked convolution")
DEMOSAIC.add("malvar2004", malvar2004, description="gradient-corrected linear (Malvar, He & Cutler 2004)")
DEMOSAIC.add("menon2007", menon2007, description="directional filtering, a posteriori decision (Menon et al. 2007)")
DEMOSAIC.add("vng", vng, description="OpenCV variable number of gradients")
DEMOSAIC.add("ea", ea, description="OpenCV edge-aware")


def demosaic(mosaic: np.ndarray, cfa: str = "RGGB", *, method: str = "malvar2004") -> np.ndarray:
    """Demosaic a Bayer mosaic with the named method.

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic (usually white-balanced).
    cfa
        Bayer tile name read from the top-left pixel: ``"RGGB"``, ``"BGGR"``, ``"GRBG"``
        or ``"GBRG"``.
    method
        One of :data:`DEMOSAIC`: ``"bilinear"``, ``"malvar2004"``, ``"menon2007"``,
        ``"vng"``, ``"ea"``.

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 linear RGB.

    Raises
    ------
    ConfigError
        For an unknown method or CFA (listing the valid ones).

    References
    ----------
    .. [1] Malvar, H. S., He, L., & Cutler, R. (2004). Proc. IEEE ICASSP, 485–488.
    .. [2] Menon, D., Andriani, S., & Calvagno, G. (2007). IEEE TIP 16(1), 132–141.
    """
    return DEMOSAIC[method](mosaic, cfa)
