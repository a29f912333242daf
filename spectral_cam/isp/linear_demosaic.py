"""The linear demosaicers on the four CFA planes: ``bilinear`` and ``malvar2004`` (Malvar, He &
Cutler's gradient-corrected kernels), each value computed only at the CFA sites that keep it and
run on row bands by :func:`spectral_cam.isp.plane_bands.by_planes`.

References
----------
.. [1] Malvar, H. S., He, L., & Cutler, R. (2004). High-quality linear interpolation for
   demosaicing of Bayer-patterned color images. Proc. IEEE ICASSP, vol. 3, 485–488.
.. [2] Gunturk, B. K., et al. (2005). Demosaicking: color filter array interpolation.
   IEEE Signal Processing Magazine 22(1), 44–54.
"""

from __future__ import annotations

import numpy as np

from .plane_bands import by_planes, check_bayer_mosaic

__all__ = ["bilinear", "malvar2004"]


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
    mosaic, cfa = check_bayer_mosaic(mosaic, cfa)
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
    mosaic, cfa = check_bayer_mosaic(mosaic, cfa)
    return by_planes(mosaic, cfa, _malvar_sites, pad=2, offset=1)

