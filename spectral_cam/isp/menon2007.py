"""Menon, Andriani & Calvagno (2007): demosaicing with directional filtering and a posteriori
decision (DDFAPD), with the paper's refining step, in float32 on the four CFA planes.

The algorithm is colour-demosaicing's (Mansencal et al.), step for step, rewritten so that a
24 MP frame develops in about a second and ``colour`` (whose import loads matplotlib, ~1 s) is
never imported. Every quantity lives on the CFA site where the algorithm uses it: the mosaic is
split into its four half-resolution planes (R, G in red rows, G in blue rows, B), and every
convolution of the full-resolution algorithm becomes a sum of a few neighbouring plane samples
(``at(plane, di, dj)``, a shifted view, no copy), so nothing is computed at a site that discards
it. Borders: the mosaic is mirror-padded once (about the edge pixel) by :data:`REACH_PX`, more
than the chain of steps reaches, and phase-shifted so the padded mosaic starts on a red site;
colour-demosaicing instead mirrors at each step, so the two differ in the outermost pixels only
(tests/isp/test_menon2007.py checks the interior against colour-demosaicing to float32 rounding,
and the border's accuracy against the reference's).

Steps, with G_H/G_V the directional green estimates and M the decision (1: horizontal):

1. Green at red and blue sites along the row and the column: [−¼, ½, ½, ½, −¼].
2. The colour differences C = D − G along each direction, their gradients |C(x) − C(x+2)|
   summed over the paper's 5×5 window; the direction with the smaller sum wins.
3. Red and blue at green sites from the neighbouring R − G, B − G; red at blue sites and blue
   at red sites from R − B along the chosen direction.
4. Refining: green at red/blue sites from R − G, B − G averaged over three pixels along the
   chosen direction; red/blue at green sites again; R − B at red/blue sites again.

References
----------
.. [1] Menon, D., Andriani, S., & Calvagno, G. (2007). Demosaicing with directional filtering
   and a posteriori decision. IEEE Trans. Image Process. 16(1), 132–141.
.. [2] Mansencal, T., et al. colour-demosaicing, ``demosaicing_CFA_Bayer_Menon2007`` and
   ``refining_step_Menon2007`` (BSD-3-Clause), the reference this module is tested against.
"""

from __future__ import annotations

import numpy as np

__all__ = ["menon2007_demosaic", "REACH_PX"]

_F32 = np.float32
#: Mirror padding (full-resolution pixels, even): each of the ~8 chained steps reads one plane
#: sample (two pixels) further, and the outermost ring of every plane is left unset.
REACH_PX = 20


def menon2007_demosaic(mosaic: np.ndarray, cfa: str, *, refining_step: bool = True) -> np.ndarray:
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
