"""The demosaicers as they were before they moved to the CFA planes in row bands (git
05607e8), kept verbatim as references: ``menon2007`` must still equal its previous whole-frame
implementation bit for bit, ``malvar2004`` and ``bilinear`` theirs to float32 rounding
(tests/isp/test_demosaic_planes.py)."""

from __future__ import annotations

import numpy as np

from spectral_cam.cfa import channel_index, channel_masks

_F32 = np.float32
#: Mirror padding (full-resolution pixels, even) of the previous menon2007.
REACH_PX = 20

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


def bilinear_reference(mosaic: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
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
    mosaic = np.ascontiguousarray(mosaic, dtype=_F32)
    masks = channel_masks(mosaic.shape, cfa)
    out = np.empty(mosaic.shape + (3,), _F32)
    for c, kernel in ((0, _K_RB), (1, _K_G), (2, _K_RB)):
        out[..., c] = _filter(mosaic * masks[..., c], kernel)
    return out


def malvar2004_reference(mosaic: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
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
    mosaic = np.ascontiguousarray(mosaic, dtype=_F32)
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


def menon2007_reference(mosaic: np.ndarray, cfa: str, *, refining_step: bool = True) -> np.ndarray:
    """DDFAPD demosaicing of a float32 Bayer mosaic (see the module docstring).

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic, H and W ≥ 2.
    cfa
        Bayer tile read from the top-left pixel (``"RGGB"``, ``"BGGR"``, ``"GRBG"``, ``"GBRG"``),
        already checked.
    refining_step
        Apply the paper's refining step (§III-C).

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 linear RGB, unclipped; measured samples are kept.

    References
    ----------
    .. [1] Menon, D., Andriani, S., & Calvagno, G. (2007). IEEE TIP 16(1), 132–141.
    """
    import cv2

    height, width = mosaic.shape
    ry, rx = divmod(cfa.index("R"), 2)
    pad = REACH_PX
    # pad so that the padded mosaic starts on a red site (canonical RGGB) and has even sides
    top, left = pad + ry, pad + rx
    bottom = pad + (height + top) % 2
    right = pad + (width + left) % 2
    d = cv2.copyMakeBorder(np.ascontiguousarray(mosaic, dtype=_F32), top, bottom, left, right, cv2.BORDER_REFLECT_101)
    R, Gr, Gb, B = (np.ascontiguousarray(d[a::2, b::2]) for a, b in ((0, 0), (0, 1), (1, 0), (1, 1)))
    h, w = R.shape
    inner = (slice(1, h - 1), slice(1, w - 1))

    def at(X, di, dj):
        return X[1 + di:h - 1 + di, 1 + dj:w - 1 + dj]

    def plane(expression):
        out = np.zeros((h, w), _F32)
        out[inner] = expression
        return out

    half, quarter, third = _F32(0.5), _F32(0.25), _F32(1.0 / 3.0)
    # 1. directional green at red and blue sites
    gh_r = plane(half * (at(Gr, 0, -1) + at(Gr, 0, 0) + at(R, 0, 0)) - quarter * (at(R, 0, -1) + at(R, 0, 1)))
    gv_r = plane(half * (at(Gb, -1, 0) + at(Gb, 0, 0) + at(R, 0, 0)) - quarter * (at(R, -1, 0) + at(R, 1, 0)))
    gh_b = plane(half * (at(Gb, 0, 0) + at(Gb, 0, 1) + at(B, 0, 0)) - quarter * (at(B, 0, -1) + at(B, 0, 1)))
    gv_b = plane(half * (at(Gr, 0, 0) + at(Gr, 1, 0) + at(B, 0, 0)) - quarter * (at(B, -1, 0) + at(B, 1, 0)))
    # 2. gradients of the colour differences, summed over the 5×5 window
    ch_r, cv_r, ch_b, cv_b = R - gh_r, R - gv_r, B - gh_b, B - gv_b
    dh_r = plane(np.abs(at(ch_r, 0, 0) - at(ch_r, 0, 1)))
    dh_b = plane(np.abs(at(ch_b, 0, 0) - at(ch_b, 0, 1)))
    dv_r = plane(np.abs(at(cv_r, 0, 0) - at(cv_r, 1, 0)))
    dv_b = plane(np.abs(at(cv_b, 0, 0) - at(cv_b, 1, 0)))
    del ch_r, cv_r, ch_b, cv_b
    three = _F32(3.0)
    sum_h_r = (at(dh_r, -1, -1) + at(dh_r, -1, 0) + three * (at(dh_r, 0, -1) + at(dh_r, 0, 0)) + at(dh_r, 1, -1)
               + at(dh_r, 1, 0) + at(dh_b, -1, -1) + at(dh_b, 0, -1))
    sum_h_b = (at(dh_b, -1, -1) + at(dh_b, -1, 0) + three * (at(dh_b, 0, -1) + at(dh_b, 0, 0)) + at(dh_b, 1, -1)
               + at(dh_b, 1, 0) + at(dh_r, 0, 0) + at(dh_r, 1, 0))
    sum_v_r = (at(dv_r, -1, -1) + at(dv_r, 0, -1) + three * (at(dv_r, -1, 0) + at(dv_r, 0, 0)) + at(dv_r, -1, 1)
               + at(dv_r, 0, 1) + at(dv_b, -1, -1) + at(dv_b, -1, 0))
    sum_v_b = (at(dv_b, -1, -1) + at(dv_b, 0, -1) + three * (at(dv_b, -1, 0) + at(dv_b, 0, 0)) + at(dv_b, -1, 1)
               + at(dv_b, 0, 1) + at(dv_r, 0, 0) + at(dv_r, 0, 1))
    m_r = plane(sum_v_r >= sum_h_r).astype(bool)
    m_b = plane(sum_v_b >= sum_h_b).astype(bool)
    del sum_h_r, sum_h_b, sum_v_r, sum_v_b, dh_r, dh_b, dv_r, dv_b
    g_r = np.where(m_r, gh_r, gv_r)
    g_b = np.where(m_b, gh_b, gv_b)
    del gh_r, gv_r, gh_b, gv_b

    def greens(g_r, g_b):
        rg, bg = R - g_r, B - g_b
        r_gr = plane(at(Gr, 0, 0) + half * (at(rg, 0, 0) + at(rg, 0, 1)))
        b_gr = plane(at(Gr, 0, 0) + half * (at(bg, -1, 0) + at(bg, 0, 0)))
        b_gb = plane(at(Gb, 0, 0) + half * (at(bg, 0, -1) + at(bg, 0, 0)))
        r_gb = plane(at(Gb, 0, 0) + half * (at(rg, 0, 0) + at(rg, 1, 0)))
        return r_gr, b_gr, r_gb, b_gb

    # 3. red and blue at greens, then R at B and B at R from R − B along the decision
    r_gr, b_gr, r_gb, b_gb = greens(g_r, g_b)
    e_gr, e_gb = r_gr - b_gr, r_gb - b_gb
    r_b = plane(at(B, 0, 0) + half * np.where(at(m_b, 0, 0), at(e_gb, 0, 0) + at(e_gb, 0, 1),
                                              at(e_gr, 0, 0) + at(e_gr, 1, 0)))
    b_r = plane(at(R, 0, 0) - half * np.where(at(m_r, 0, 0), at(e_gr, 0, -1) + at(e_gr, 0, 0),
                                              at(e_gb, -1, 0) + at(e_gb, 0, 0)))
    if refining_step:
        # 4a. green at red/blue from the 3-pixel mean of R − G / B − G along the decision
        f_gr, f_gb, f_r = r_gr - Gr, r_gb - Gb, R - g_r
        h_gr, h_gb, h_b = b_gr - Gr, b_gb - Gb, B - g_b
        g_r = plane(at(R, 0, 0) - third * np.where(
            at(m_r, 0, 0), at(f_gr, 0, -1) + at(f_r, 0, 0) + at(f_gr, 0, 0),
            at(f_gb, -1, 0) + at(f_r, 0, 0) + at(f_gb, 0, 0)))
        g_b = plane(at(B, 0, 0) - third * np.where(
            at(m_b, 0, 0), at(h_gb, 0, 0) + at(h_b, 0, 0) + at(h_gb, 0, 1),
            at(h_gr, 0, 0) + at(h_b, 0, 0) + at(h_gr, 1, 0)))
        del f_gr, f_gb, f_r, h_gr, h_gb, h_b
        # 4b. red and blue at greens again; 4c. R − B at red and blue sites again
        r_gr, b_gr, r_gb, b_gb = greens(g_r, g_b)
        e_gr, e_gb, e_b, e_r = r_gr - b_gr, r_gb - b_gb, r_b - B, R - b_r
        r_b = plane(at(B, 0, 0) + third * np.where(
            at(m_b, 0, 0), at(e_gb, 0, 0) + at(e_b, 0, 0) + at(e_gb, 0, 1),
            at(e_gr, 0, 0) + at(e_b, 0, 0) + at(e_gr, 1, 0)))
        b_r = plane(at(R, 0, 0) - third * np.where(
            at(m_r, 0, 0), at(e_gr, 0, -1) + at(e_r, 0, 0) + at(e_gr, 0, 0),
            at(e_gb, -1, 0) + at(e_r, 0, 0) + at(e_gb, 0, 0)))

    out = np.empty(d.shape + (3,), _F32)
    for c, sites in enumerate(((R, r_gr, r_gb, r_b), (g_r, Gr, Gb, g_b), (b_r, b_gr, b_gb, B))):
        for (a, b), values in zip(((0, 0), (0, 1), (1, 0), (1, 1)), sites):
            out[a::2, b::2, c] = values
    return out[top:top + height, left:left + width]
