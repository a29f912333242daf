"""Ratio-corrected demosaicing (RCD, Luis Sanz Rodríguez 2017), followed by one 3 × 3 median of
the colour differences R − G and B − G (false-colour suppression, as dcraw's ``-m`` does).

Why (issue 37 #7): the bundled scenes are box-filtered renders with no optical low-pass filter,
so a leaf's or a shadow's edge is a sharp step at any sub-pixel position and angle. menon2007
gives red and blue at a pixel as its green plus the mean R − G, B − G of its neighbours along
the chosen direction (½ and ⅓ weights), whichever side of the edge they lie on; between a
saturated leaf and neutral soil those differences jump, so the leaf's edge pixels take the
soil's (red and blue too high: magenta) and the soil's take the leaf's (blue below zero, clipped
after the colour matrix: a dark rim). On the noise-free vegetation render its red and blue err by
5.9 % and 5.7 % of their mean on edge pixels (green 2.5 %), and 3.6 % of edge pixels have a negative
linear sRGB channel (0.34 % in the noise-free image). RCD estimates each missing value from the
colour differences (and, for green, the ratio-corrected greens) on both sides, each weighted by
the inverse gradient towards it, and blends the directions softly: the side across the edge
counts little (red, blue 4.8 %, 4.3 %; 1.6 % negative). The median removes most of the rest.

Steps (every quantity evaluated on a mirror-padded row band, R at the band's (0, 0)):

1. Vertical and horizontal discrimination: the squared high-pass
   (x₋₃ − x₋₁ − x₊₁ + x₊₃) − 3 (x₋₂ + x₊₂) + 6 x₀ along each axis, summed over three pixels along
   it: VH = V / (V + H) (1: vertical variation, interpolate horizontally).
2. The low-pass x₀ + ½ Σ(4-neighbours) + ¼ Σ(diagonals) of the mosaic (clamped at 0 for the ratios).
3. Green at red and blue sites: each cardinal neighbour's green times
   1 + (lpf₀ − lpf₂) / (lpf₀ + lpf₂) (lpf₂: the low-pass two pixels further), the opposite pair
   weighted by their gradients, then the two axes blended by VH (or by the mean VH of the
   diagonal neighbours, whichever is more decided).
4. Red at blue and blue at red sites from the diagonal neighbours' colour differences, the
   diagonals blended by their own discrimination (step 1 along the diagonals); then red and blue
   at green sites from the cardinal neighbours' colour differences, blended by VH.
5. One 3 × 3 median of R − G and of B − G, green kept.

Written from the algorithm's description (the reference implementation is C in RawTherapee and
darktable, GPL-3; nothing of it is copied here): NumPy on float32 row bands on threads, unclipped
(the reference clips to [0, 1]: a white-balanced linear mosaic exceeds 1 and noise goes below 0),
so the low-pass is clamped at zero only where it forms a ratio.

References
----------
.. [1] Sanz Rodríguez, L. (2017). RCD: Ratio Corrected Demosaicing, v2.3.
   https://github.com/LuisSR/RCD-Demosaicing (the algorithm; RawTherapee's and darktable's default
   Bayer demosaic for non-AMaZE use).
.. [2] Coffin, D. dcraw.c, ``median_filter`` (``-m``: 3 × 3 medians of R − G and B − G).
.. [3] Freeman, W. T. (1988). Median filter for reconstructing missing color samples.
   US Patent 4,724,395.
"""

from __future__ import annotations

import numpy as np

__all__ = ["REACH_PX", "rcd_band", "rcd"]

_F32 = np.float32
_EPS = _F32(1e-5)
_EPSSQ = _F32(1e-10)
#: Context (pixels, even) a band needs on each side: the chained steps read 13 pixels away
#: (step 1: 4 + 1, step 3: 4, step 4: 3 + 3 on the diagonal and cardinal passes, the median: 1).
REACH_PX = 16
#: The widest offset any one expression reads (the interior margin of every intermediate).
_M = 4


def rcd_band(band: np.ndarray, *, median: bool = True) -> np.ndarray:
    """RCD on a mosaic band that starts on a red site (RGGB at its (0, 0)).

    Parameters
    ----------
    band
        (h, w) float32 mosaic with at least :data:`REACH_PX` pixels of real or mirrored context on
        every side of the rows and columns wanted.
    median
        Finish with one 3 × 3 median of R − G and B − G.

    Returns
    -------
    numpy.ndarray
        (h, w, 3) float32; valid :data:`REACH_PX` pixels in from every side.
    """
    import cv2

    band = np.ascontiguousarray(band, dtype=_F32)
    h, w = band.shape
    m = _M

    def at(a, dy=0, dx=0):
        return a[m + dy:h - m + dy, m + dx:w - m + dx]

    def store(value):  # a full-size array from its interior (a zero margin of width _M)
        out = np.zeros((h, w), _F32)
        out[m:h - m, m:w - m] = value
        return out

    y_odd = (np.arange(h) % 2 == 1)[:, None]
    x_odd = (np.arange(w) % 2 == 1)[None, :]
    is_green = at(y_odd != x_odd)
    is_red = at(~y_odd & ~x_odd)
    is_blue = at(y_odd & x_odd)
    x = band

    def high_pass_sq(dy, dx):  # squared colour-difference high-pass along (dy, dx)
        a = (at(x, -3 * dy, -3 * dx) - at(x, -dy, -dx) - at(x, dy, dx) + at(x, 3 * dy, 3 * dx)
             - 3 * (at(x, -2 * dy, -2 * dx) + at(x, 2 * dy, 2 * dx)) + 6 * at(x))
        return store(a * a)

    def decided(d):  # the pixel's discrimination, or its diagonal neighbours' mean where more decided
        d = store(d)
        neighbours = _F32(0.25) * (at(d, -1, -1) + at(d, -1, 1) + at(d, 1, -1) + at(d, 1, 1))
        centre = at(d)
        return np.where(np.abs(_F32(0.5) - centre) < np.abs(_F32(0.5) - neighbours), neighbours, centre)

    # 1. vertical / horizontal discrimination
    bv, bh = high_pass_sq(1, 0), high_pass_sq(0, 1)
    v_stat = np.maximum(_EPSSQ, at(bv, -1, 0) + at(bv) + at(bv, 1, 0))
    h_stat = np.maximum(_EPSSQ, at(bh, 0, -1) + at(bh) + at(bh, 0, 1))
    vh = store(decided(v_stat / (v_stat + h_stat)))
    del bv, bh, v_stat, h_stat

    # 2. the low-pass, clamped at zero where it forms a ratio
    lpf = store(np.maximum(at(x) + _F32(0.5) * (at(x, -1, 0) + at(x, 1, 0) + at(x, 0, -1) + at(x, 0, 1))
                           + _F32(0.25) * (at(x, -1, -1) + at(x, -1, 1) + at(x, 1, -1) + at(x, 1, 1)), 0))

    # 3. green at red and blue sites
    def cardinal_gradient(dy, dx):
        return (_EPS + np.abs(at(x, dy, dx) - at(x, -dy, -dx)) + np.abs(at(x) - at(x, 2 * dy, 2 * dx))
                + np.abs(at(x, dy, dx) - at(x, 3 * dy, 3 * dx))
                + np.abs(at(x, 2 * dy, 2 * dx) - at(x, 4 * dy, 4 * dx)))

    def ratio_estimate(dy, dx):
        far = at(lpf, 2 * dy, 2 * dx)
        return at(x, dy, dx) * (1 + (at(lpf) - far) / (_EPS + at(lpf) + far))

    n, s = cardinal_gradient(-1, 0), cardinal_gradient(1, 0)
    vertical = (s * ratio_estimate(-1, 0) + n * ratio_estimate(1, 0)) / (n + s)
    wg, e = cardinal_gradient(0, -1), cardinal_gradient(0, 1)
    horizontal = (e * ratio_estimate(0, -1) + wg * ratio_estimate(0, 1)) / (e + wg)
    d = at(vh)
    green = store(np.where(is_green, at(x), d * horizontal + (1 - d) * vertical))
    del lpf, n, s, wg, e, vertical, horizontal

    # 4a. red at blue and blue at red sites, along the diagonals
    bp, bq = high_pass_sq(1, 1), high_pass_sq(1, -1)
    p_stat = np.maximum(_EPSSQ, at(bp, -1, -1) + at(bp) + at(bp, 1, 1))
    q_stat = np.maximum(_EPSSQ, at(bq, -1, 1) + at(bq) + at(bq, 1, -1))
    pq = decided(p_stat / (p_stat + q_stat))
    del bp, bq, p_stat, q_stat
    g = green
    colours = []
    for own, other in ((is_red, is_blue), (is_blue, is_red)):
        c = store(np.where(own, at(x), 0))

        def diagonal_gradient(dy, dx):
            return (_EPS + np.abs(at(c, dy, dx) - at(c, -dy, -dx)) + np.abs(at(c, dy, dx) - at(c, 3 * dy, 3 * dx))
                    + np.abs(at(g) - at(g, 2 * dy, 2 * dx)))

        nw, ne, sw, se = (diagonal_gradient(-1, -1), diagonal_gradient(-1, 1), diagonal_gradient(1, -1),
                          diagonal_gradient(1, 1))
        diff = store(at(c) - at(g))
        p_est = (nw * at(diff, 1, 1) + se * at(diff, -1, -1)) / (nw + se)
        q_est = (ne * at(diff, 1, -1) + sw * at(diff, -1, 1)) / (ne + sw)
        colours.append(store(np.where(other, at(g) + (1 - pq) * p_est + pq * q_est, at(c))))

    # 4b. red and blue at green sites, along the row and the column
    n1, s1 = _EPS + np.abs(at(g) - at(g, -2, 0)), _EPS + np.abs(at(g) - at(g, 2, 0))
    w1, e1 = _EPS + np.abs(at(g) - at(g, 0, -2)), _EPS + np.abs(at(g) - at(g, 0, 2))
    out = np.empty((h, w, 3), _F32)
    out[..., 1] = g
    for channel, c in zip((0, 2), colours):
        column, row = np.abs(at(c, -1, 0) - at(c, 1, 0)), np.abs(at(c, 0, -1) - at(c, 0, 1))
        n = n1 + column + np.abs(at(c, -1, 0) - at(c, -3, 0))
        s = s1 + column + np.abs(at(c, 1, 0) - at(c, 3, 0))
        wg = w1 + row + np.abs(at(c, 0, -1) - at(c, 0, -3))
        e = e1 + row + np.abs(at(c, 0, 1) - at(c, 0, 3))
        diff = store(at(c) - at(g))
        vertical = (n * at(diff, 1, 0) + s * at(diff, -1, 0)) / (n + s)
        horizontal = (e * at(diff, 0, -1) + wg * at(diff, 0, 1)) / (e + wg)
        out[..., channel] = store(np.where(is_green, at(g) + (1 - d) * vertical + d * horizontal, at(c)))

    # 5. false-colour suppression: one 3 × 3 median of each colour difference, green kept
    if median:
        for channel in (0, 2):
            difference = np.ascontiguousarray(out[..., channel] - g)
            out[..., channel] = g + cv2.medianBlur(difference, 3)
    return out


def rcd(mosaic: np.ndarray, cfa: str = "RGGB", *, median: bool = True, band_rows: int = 128,
        workers: int | None = None) -> np.ndarray:
    """RCD of a Bayer mosaic of any phase and size, on row bands on threads.

    The mosaic is mirror-padded about its edge pixels (BORDER_REFLECT_101, which keeps the CFA
    phase) by :data:`REACH_PX` plus the phase shift that puts a red site at the padded band's
    (0, 0); each band of output rows is demosaiced with that much context (the result does not
    depend on the cut into bands).

    Parameters
    ----------
    mosaic
        (H, W) float32 mosaic (checked by the caller).
    cfa
        Bayer tile at the top-left pixel.
    median
        Finish with one 3 × 3 median of R − G and B − G (the ``rcd`` method's default).
    band_rows
        Output rows per band, about.
    workers
        Threads (default: the CPUs).

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 linear RGB, unclipped.
    """
    import os

    import cv2

    height, width = mosaic.shape
    ry, rx = divmod(cfa.index("R"), 2)
    pad = REACH_PX
    top, left = pad + ry, pad + rx
    out = np.empty((height, width, 3), _F32)
    n_bands = max(1, -(-height // band_rows))
    edges = [height * k // n_bands for k in range(n_bands + 1)]
    edges = sorted({e - e % 2 if 0 < e < height else e for e in edges})  # even starts keep the phase
    workers = max(1, min(workers or os.cpu_count() or 1, len(edges) - 1))

    def band(k: int) -> None:
        y0, y1 = edges[k], edges[k + 1]
        # rows [y0 − top, y1 + pad) (y0 even: the band starts on a red row), mirrored only past
        # the frame's top and bottom
        lo, hi = y0 - top, y1 + pad
        above, below = max(-lo, 0), max(hi - height, 0)
        padded = cv2.copyMakeBorder(np.ascontiguousarray(mosaic[max(lo, 0):min(hi, height)]), above, below, left,
                                    pad, cv2.BORDER_REFLECT_101)
        rgb = rcd_band(padded, median=median)
        out[y0:y1] = rgb[top:top + y1 - y0, left:left + width]

    if workers == 1:
        for k in range(len(edges) - 1):
            band(k)
    else:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(max_workers=workers) as pool:
            list(pool.map(band, range(len(edges) - 1)))
    return out
