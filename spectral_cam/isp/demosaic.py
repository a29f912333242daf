"""Demosaicing: a registry of interpolators with one call, :func:`demosaic`.

Larger tiles (X-Trans, Quad Bayer; :data:`spectral_cam.cfa.EXTENDED_PATTERNS`) have their own
methods, ``colour_difference`` (any CFA), ``quad_binning`` and ``quad_remosaic``, listed in
:data:`CFA_METHODS`; :func:`method_for` picks one when a Bayer method is asked of another tile.

Every method takes the (white-balanced) float32 linear mosaic and returns (H, W, 3)
float32 linear RGB, unclipped, for any of the four Bayer phases and any image size
(odd included).

``bilinear``, ``malvar2004`` and ``menon2007`` are written on the four CFA planes (R, G in red
rows, G in blue rows, B), so each value is computed only at the sites that keep it, and run by
:func:`by_planes` on cache-sized row bands on threads, whose per-site colours ``cv2.merge``
interleaves straight into the output. Mirror padding about the edge pixel (BORDER_REFLECT_101)
keeps the CFA phase, so borders are exact too.

- ``bilinear``: the mean of the nearest 2 or 4 samples of each missing colour (normalised
  masked convolution, to float32 rounding).
- ``malvar2004``: gradient-corrected linear interpolation, the four 5×5 kernels of Malvar,
  He & Cutler, each evaluated at the sites that use it.
- ``menon2007``: directional filtering with a posteriori decision, colour-demosaicing's
  algorithm in float32 (:mod:`spectral_cam.isp.menon2007`).
- ``rcd`` (the default, issue 37 #7): ratio-corrected demosaicing and one 3 × 3 median of the
  colour differences (:mod:`spectral_cam.isp.rcd`): no dark magenta rims at sharp, off-grid edges
  of high contrast, where menon2007's Laplacian-corrected green undershoots.
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
.. [6] Sanz Rodríguez, L. (2017). RCD: Ratio Corrected Demosaicing, v2.3.
"""

from __future__ import annotations

import numpy as np

from ..cfa import channel_index, check_cfa, is_bayer, opencv_bayer_code
from ..errors import ConfigError
from ..registry import Registry

__all__ = ["DEMOSAIC", "demosaic", "bilinear", "malvar2004", "menon2007", "rcd", "vng", "ea", "colour_difference",
           "quad_binning", "quad_remosaic", "rgbw_fusion", "method_for", "CFA_METHODS", "bayer_methods"]

_F32 = np.float32

from .scratch import Scratch as _Scratch, band_edges, run_bands

#: Output rows per band for the linear methods: a band's planes and intermediates stay in the
#: CPU cache, and the bands are shared among threads.
BAND_ROWS = 64


def by_planes(mosaic: np.ndarray, cfa: str, sites, *, pad: int, offset: int, band_rows: int = BAND_ROWS,
              workers: int | None = None) -> np.ndarray:
    """Run a demosaicer written on the four CFA planes over row bands on parallel threads.

    The mosaic is mirror-padded about its edge pixels (BORDER_REFLECT_101, which keeps the
    CFA phase) by ``pad`` pixels and shifted so that the padded mosaic starts on a red site;
    each band of output rows is cut from it with ``pad`` rows of context on either side (made
    only for the band: the padded frame is never formed), split into its R, G-in-red-rows,
    G-in-blue-rows and B planes, and handed to ``sites``, whose per-site colours are
    interleaved straight into the output with ``cv2.merge`` (no full-frame masks, no per-channel
    strided writes). Bands run in order on each thread and reuse that thread's buffers.

    Parameters
    ----------
    mosaic
        (H, W) float32 mosaic, C-contiguous.
    cfa
        Bayer tile at the top-left pixel (checked).
    sites
        ``sites(R, Gr, Gb, B, scratch) -> (at_R, at_Gr, at_Gb, at_B)``, each a triple of
        (r, g, b) arrays of the band's plane grid, whose element ``[i, j]`` is plane sample
        ``[i + offset, j + offset]``; ``scratch`` is :class:`_Scratch`.
    pad
        Context (pixels, even): the output at a pixel depends on the mosaic within ``pad``.
    offset
        Plane samples that ``sites`` leaves out at the band's top and left.
    band_rows
        Output rows per band, about (the frame is cut into equal bands, as many for each thread).
    workers
        Threads (default: the CPUs).
    """
    import os

    import cv2

    height, width = mosaic.shape
    ry, rx = divmod(cfa.index("R"), 2)
    top, left = pad + ry, pad + rx
    right = pad + (width + left) % 2
    wq = (width + left + right) // 2
    out = np.empty((height, width, 3), _F32)
    edges, workers = band_edges(height, band_rows, max(1, workers or os.cpu_count() or 1))
    pairs = width // 2
    # the output's pixel pairs (x, x + 1), x even, as sites (b, j) of the padded planes
    b0, j0 = left % 2, left // 2 - offset
    b1, j1 = (left + 1) % 2, (left + 1) // 2 - offset

    def band(y0: int, y1: int, scratch: _Scratch) -> None:
        p0 = (y0 + top - pad) // 2 * 2  # padded rows [p0, p1) around output rows [y0, y1)
        p1 = -(-(y1 + top + pad) // 2) * 2
        first, last = max(p0 - top, 0), min(p1 - top, height)
        hq = (p1 - p0) // 2
        padded = scratch("padded", (2 * hq, 2 * wq))
        # mirrored rows are added only at the frame's top and bottom (first = 0, last = H)
        cv2.copyMakeBorder(mosaic[first:last], first - (p0 - top), p1 - top - last, left, right,
                           cv2.BORDER_REFLECT_101, dst=padded)
        planes = [scratch(key, (hq, wq)) for key in ("R", "Gr", "Gb", "B")]
        cv2.split(padded[0::2].reshape(hq, wq, 2), planes[:2])
        cv2.split(padded[1::2].reshape(hq, wq, 2), planes[2:])
        values = sites(*planes, scratch)
        for ys in range(y0, min(y0 + 2, y1)):
            parity = (ys + top) % 2
            i = (ys + top - p0) // 2 - offset
            rows = slice(i, i + (y1 - ys + 1) // 2)
            first_site, second_site = values[2 * parity + b0], values[2 * parity + b1]
            if pairs:
                # every other row, each row's pixel pairs as 6 channels: a view of the output
                dst = out[ys:y1:2, :2 * pairs].reshape(-1, pairs, 6)
                src = ([c[rows, j0:j0 + pairs] for c in first_site]
                       + [c[rows, j1:j1 + pairs] for c in second_site])
                if not np.may_share_memory(dst, out) or cv2.merge(src, dst=dst) is not dst:  # pragma: no cover
                    raise RuntimeError("cv2.merge did not write into the output")
            if width % 2:
                x = width - 1
                site, j = values[2 * parity + (x + left) % 2], (x + left) // 2 - offset
                for c in range(3):
                    out[ys:y1:2, x, c] = site[c][rows, j]

    run_bands(band, edges, workers)
    return out


def _check(mosaic: np.ndarray, cfa: str) -> tuple[np.ndarray, str]:
    mosaic = np.ascontiguousarray(mosaic, dtype=_F32)
    if mosaic.ndim != 2:
        raise ConfigError(f"demosaicing needs a 2-D mosaic; got shape {mosaic.shape}")
    if min(mosaic.shape) < 2:
        raise ConfigError(f"a Bayer mosaic needs at least 2×2 pixels; got {mosaic.shape}")
    return mosaic, check_cfa(cfa)


def _bilinear_sites(R, Gr, Gb, B, scratch):
    """Bilinear interpolation on the four planes (one sample of context): each missing colour
    is the mean of its 2 or 4 nearest samples, as pair means of pair means."""
    import cv2

    hq, wq = R.shape
    hi, wi = hq - 2, wq - 2

    def at(X, di, dj):
        return X[1 + di:hq - 1 + di, 1 + dj:wq - 1 + dj]

    def mean(key, a, b, rows=hi):
        return cv2.addWeighted(a, 0.5, b, 0.5, 0.0, dst=scratch(key, (rows, wi)))

    # R between horizontal R pairs (at G in red rows), on one extra row for R at blue sites
    r_gr = mean("r_gr", R[1:, 1:-1], R[1:, 2:], hq - 1)
    r_b = mean("r_b", r_gr[:-1], r_gr[1:])
    r_gb = mean("r_gb", at(R, 0, 0), at(R, 1, 0))
    # B between horizontal B pairs (at G in blue rows), on one extra row for B at red sites
    b_gb = mean("b_gb", B[:-1, :-2], B[:-1, 1:-1], hq - 1)
    b_r = mean("b_r", b_gb[:-1], b_gb[1:])
    b_gr = mean("b_gr", at(B, -1, 0), at(B, 0, 0))
    g_r = mean("g_r", mean("gh", at(Gr, 0, -1), at(Gr, 0, 0)), mean("gv", at(Gb, -1, 0), at(Gb, 0, 0)))
    g_b = mean("g_b", mean("gh", at(Gr, 0, 0), at(Gr, 1, 0)), mean("gv", at(Gb, 0, 0), at(Gb, 0, 1)))
    return ((at(R, 0, 0), g_r, b_r), (r_gr[:-1], at(Gr, 0, 0), b_gr), (r_gb, at(Gb, 0, 0), b_gb[1:]),
            (r_b, g_b, at(B, 0, 0)))


def bilinear(mosaic: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
    """Bilinear demosaicing: each missing colour is the mean of its nearest 2 or 4 samples.

    Computed on the four CFA planes in cache-sized row bands on threads (:func:`by_planes`),
    so only the missing sites are computed. Mirror padding about the edge pixel
    (BORDER_REFLECT_101) keeps the CFA phase, so borders are exact bilinear too; the result
    equals normalised masked convolution with the kernels [[0, 1, 0], [1, 4, 1], [0, 1, 0]]/4
    (green) and [[1, 2, 1], [2, 4, 2], [1, 2, 1]]/4 (red, blue) to float32 rounding.

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
    return by_planes(mosaic, cfa, _bilinear_sites, pad=2, offset=1)


def _malvar_sites(R, Gr, Gb, B, scratch):
    """Malvar, He & Cutler's 5×5 kernels (Fig. 2, all /8) evaluated only at the sites that use
    them, on the four planes (one sample of context)."""
    import cv2

    hq, wq = R.shape
    hi, wi = hq - 2, wq - 2

    def at(X, di, dj):
        return X[1 + di:hq - 1 + di, 1 + dj:wq - 1 + dj]

    def add(key, a, b, rows=hi):
        return cv2.add(a, b, dst=scratch(key, (rows, wi)))

    def weighted(key, a, wa, b, wb):
        return cv2.addWeighted(a, wa, b, wb, 0.0, dst=scratch(key, (hi, wi)))

    def scale_add(a, w, b):  # b += w·a, in place
        cv2.scaleAdd(a, w, b, dst=b)
        return b

    # the four same-colour samples two pixels away, summed, at red and at blue sites
    s_r = add("s_r", add("t1", at(R, -1, 0), at(R, 1, 0)), add("t2", at(R, 0, -1), at(R, 0, 1)))
    s_b = add("s_b", add("t1", at(B, -1, 0), at(B, 1, 0)), add("t2", at(B, 0, -1), at(B, 0, 1)))
    # horizontal pairs, with one more row: [:-1] and [1:] are the pairs in the rows the comments name
    gr_h = add("gr_h", Gr[1:, :-2], Gr[1:, 1:-1], hq - 1)  # Gr(0, −1) + Gr(0, 0): rows 0, +1
    gb_h = add("gb_h", Gb[:-1, 1:-1], Gb[:-1, 2:], hq - 1)  # Gb(0, 0) + Gb(0, 1): rows −1, 0
    r_h = add("r_h", R[1:, 1:-1], R[1:, 2:], hq - 1)  # R(0, 0) + R(0, 1): rows 0, +1
    b_h = add("b_h", B[:-1, :-2], B[:-1, 1:-1], hq - 1)  # B(0, −1) + B(0, 0): rows −1, 0
    # green at red and blue sites: ½·C + ¼·(the 4 greens) − ⅛·(the 4 samples of C two away)
    g_r = weighted("g_r", at(R, 0, 0), 0.5, add("t1", gr_h[:-1], add("t2", at(Gb, -1, 0), at(Gb, 0, 0))), 0.25)
    scale_add(s_r, -0.125, g_r)
    g_b = weighted("g_b", at(B, 0, 0), 0.5, add("t1", gb_h[1:], add("t2", at(Gr, 0, 0), at(Gr, 1, 0))), 0.25)
    scale_add(s_b, -0.125, g_b)
    # blue at red and red at blue: ¾·C + ¼·(the 4 diagonal samples) − 3/16·(the 4 samples of C two away)
    b_r = scale_add(s_r, -0.1875, weighted("b_r", at(R, 0, 0), 0.75, add("t1", b_h[:-1], b_h[1:]), 0.25))
    r_b = scale_add(s_b, -0.1875, weighted("r_b", at(B, 0, 0), 0.75, add("t1", r_h[:-1], r_h[1:]), 0.25))
    # at a green site, the colour of its row's (column's) neighbours: ⅝·G − ⅛·(the 4 diagonal
    # greens) + ½·(the row (column) pair) − ⅛·(the greens two away along the row (column))
    # + 1/16·(the greens two away along the column (row))
    greens = []
    for name, G, diagonal, row_pair, column_pair in (
            ("gr", Gr, (gb_h[:-1], gb_h[1:]), r_h[:-1], (at(B, -1, 0), at(B, 0, 0))),
            ("gb", Gb, (gr_h[:-1], gr_h[1:]), b_h[1:], (at(R, 0, 0), at(R, 1, 0)))):
        common = weighted(name + "_c", at(G, 0, 0), 0.625, add("t1", *diagonal), -0.125)
        along_row = add("t1", at(G, 0, -1), at(G, 0, 1))
        along_column = add("t2", at(G, -1, 0), at(G, 1, 0))
        row_colour = weighted(name + "_row", row_pair, 0.5, common, 1.0)
        scale_add(along_column, 0.0625, scale_add(along_row, -0.125, row_colour))
        column_colour = weighted(name + "_col", add("t3", *column_pair), 0.5, common, 1.0)
        scale_add(along_row, 0.0625, scale_add(along_column, -0.125, column_colour))
        greens.append((row_colour, column_colour))
    (r_gr, b_gr), (b_gb, r_gb) = greens
    return ((at(R, 0, 0), g_r, b_r), (r_gr, at(Gr, 0, 0), b_gr), (r_gb, at(Gb, 0, 0), b_gb),
            (r_b, g_b, at(B, 0, 0)))


def malvar2004(mosaic: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
    """Gradient-corrected bilinear demosaicing (Malvar, He & Cutler 2004).

    The paper's four fixed 5×5 kernels (Fig. 2), each evaluated only at the CFA sites that use
    it, on the four CFA planes in cache-sized row bands on threads (:func:`by_planes`); linear
    in the data and exact on constant and linearly varying colour fields. Borders mirror
    about the edge pixel (BORDER_REFLECT_101), which keeps the CFA phase.

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
    return by_planes(mosaic, cfa, _malvar_sites, pad=2, offset=1)


def menon2007(mosaic: np.ndarray, cfa: str = "RGGB", *, refining_step: bool = True) -> np.ndarray:
    """Directional filtering with a posteriori decision (Menon, Andriani & Calvagno 2007).

    colour-demosaicing's algorithm in float32 on the four CFA planes
    (:func:`spectral_cam.isp.menon2007.menon2007_sites`, without importing colour), on row
    bands of :data:`MENON_BAND_ROWS` on threads (:func:`by_planes`); the result is the same for
    any cut into bands and threads.

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
    from .menon2007 import REACH_PX, menon2007_sites

    mosaic, cfa = _check(mosaic, cfa)

    def sites(R, Gr, Gb, B, scratch):
        return menon2007_sites(R, Gr, Gb, B, scratch, refining_step=refining_step)

    return by_planes(mosaic, cfa, sites, pad=REACH_PX, offset=0, band_rows=MENON_BAND_ROWS)


#: Output rows per band for menon2007, whose bands overlap by 2 × REACH_PX rows.
MENON_BAND_ROWS = 256


def rcd(mosaic: np.ndarray, cfa: str = "RGGB", *, median: bool = True) -> np.ndarray:
    """Ratio-corrected demosaicing (Sanz Rodríguez 2017) and one 3 × 3 median of R − G and B − G.

    Green at red and blue sites from the four neighbouring greens, each scaled by a ratio of
    low-passes and weighted by inverse gradients, the two axes blended by a soft decision; red
    and blue from colour differences along the diagonals and axes; then dcraw's false-colour
    median (:mod:`spectral_cam.isp.rcd`). The default: on the sharp, off-grid edges of the
    bundled renders (no optical low-pass filter) it leaves 0.66× menon2007's chroma error
    (vegetation, noise-free, mean ΔC*ab on edge pixels 5.97 → 3.93) and no dark magenta rims; on
    pixel-aligned grey checkers 0.08× its false colour.

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic.
    cfa
        Bayer tile name read from the top-left pixel.
    median
        Finish with the colour-difference median (as the registered method does).

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 linear RGB, unclipped; without the median, measured samples are kept
        (the median moves red and blue by their colour difference's 3 × 3 median).

    References
    ----------
    .. [1] Sanz Rodríguez, L. (2017). RCD: Ratio Corrected Demosaicing, v2.3.
    .. [2] Coffin, D. dcraw.c, ``median_filter`` (``-m``).
    """
    from .rcd import rcd as _rcd

    mosaic, cfa = _check(mosaic, cfa)
    return _rcd(mosaic, cfa, median=median)


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


# ----------------------------------------------------------------------------- larger tiles
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


def bayer_methods() -> list[str]:
    """The registered methods that take a 2×2 Bayer mosaic (all but the Quad Bayer ones)."""
    return [name for name in DEMOSAIC if name not in ("quad_binning", "quad_remosaic", "rgbw_fusion")]


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


#: The methods that take each larger tile, the first its default (:func:`method_for`).
CFA_METHODS = {"XTRANS": ("colour_difference",), "QUAD_RGGB": ("quad_remosaic", "quad_binning", "colour_difference"),
               "RGBW": ("rgbw_fusion",)}


def method_for(cfa: str, asked: str) -> str:
    """``asked`` where it takes ``cfa``, else the tile's default: a Bayer method on an X-Trans or Quad
    Bayer mosaic becomes ``colour_difference`` or ``quad_remosaic`` (the develop records it)."""
    name = check_cfa(cfa, allow_extended=True)
    if is_bayer(name):
        if asked in ("quad_binning", "quad_remosaic", "rgbw_fusion"):
            raise ConfigError(f"demosaic {asked!r} needs a {'RGBW' if asked == 'rgbw_fusion' else 'QUAD_RGGB'} "
                              f"mosaic; this one is {name}")
        return asked
    return asked if asked in CFA_METHODS[name] else CFA_METHODS[name][0]


#: Demosaicing methods by name (``isp.demosaic``); a new method is one entry here.
DEMOSAIC = Registry("demosaic method")
DEMOSAIC.add("bilinear", bilinear, description="normalised masked convolution")
DEMOSAIC.add("malvar2004", malvar2004, description="gradient-corrected linear (Malvar, He & Cutler 2004)")
DEMOSAIC.add("menon2007", menon2007, description="directional filtering, a posteriori decision (Menon et al. 2007)")
DEMOSAIC.add("rcd", rcd, description="ratio-corrected demosaicing (Sanz Rodríguez 2017) + colour-difference median")
DEMOSAIC.add("vng", vng, description="OpenCV variable number of gradients")
DEMOSAIC.add("ea", ea, description="OpenCV edge-aware")
DEMOSAIC.add("colour_difference", colour_difference,
             description="any CFA (X-Trans, Quad Bayer, Bayer): green, then colour differences, masked convolution")
DEMOSAIC.add("quad_remosaic", quad_remosaic, description="Quad Bayer remosaiced to RGGB, then menon2007")
DEMOSAIC.add("quad_binning", quad_binning, description="Quad Bayer 2×2 cells binned, menon2007, upsampled")
DEMOSAIC.add("rgbw_fusion", rgbw_fusion, description="RGBW: white pixels for luminance, colour differences")


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
        One of :data:`DEMOSAIC`: ``"bilinear"``, ``"malvar2004"``, ``"menon2007"``, ``"rcd"``,
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
