"""Menon, Andriani & Calvagno (2007): demosaicing with directional filtering and a posteriori
decision (DDFAPD), with the paper's refining step, in float32 on the four CFA planes.

The algorithm is colour-demosaicing's (Mansencal et al.), step for step, rewritten so that a
12 MP frame demosaics in a fraction of a second and ``colour`` (whose import loads matplotlib,
~1 s) is never imported. Every quantity lives on the CFA site where the algorithm uses it: the
mosaic is split into its four half-resolution planes (R, G in red rows, G in blue rows, B), and
every convolution of the full-resolution algorithm becomes a sum of a few neighbouring plane
samples (``at(plane, di, dj)``, a shifted view, no copy), so nothing is computed at a site that
discards it. Each operation writes into a reused buffer (:data:`_SLOTS`), so that
:func:`spectral_cam.isp.demosaic.menon2007` can run :func:`menon2007_sites` on cache-sized row
bands on threads. Borders: the mosaic is mirror-padded once (about the edge pixel) by :data:`REACH_PX`, more
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

__all__ = ["REACH_PX", "menon2007_sites"]

_F32 = np.float32
#: Mirror padding (full-resolution pixels, even): each of the ~8 chained steps reads one plane
#: sample (two pixels) further, and the outermost ring of every plane is left unset.
REACH_PX = 20

#: The plane buffer (slot) of each quantity of one band: a quantity takes the slot of one that
#: is no longer needed, so a band works in 14 planes instead of 29 (less memory, more of it in
#: the CPU cache). The order of the steps in :func:`menon2007_sites` is what makes this valid.
_SLOTS = {
    "gh_r": "a", "gv_r": "b", "gh_b": "c", "gv_b": "d", "difference": "e",
    "dh_r": "f", "dh_b": "g", "dv_r": "h", "dv_b": "i",
    # g_r, g_b: where() writes into gv_r, gv_b; the refined ones take the same slots
    "g_r": "b", "g_b": "d",
    "rg": "a", "bg": "c", "r_gr": "e", "b_gr": "f", "b_gb": "g", "r_gb": "h",
    "e_gr": "i", "e_gb": "a", "r_b": "c", "b_r": "j",
    "f_gr": "i", "f_gb": "a", "f_r": "k", "h_gr": "l", "h_gb": "m", "h_b": "n",
    "e_b": "k", "e_r": "l",
}


def menon2007_sites(R, Gr, Gb, B, scratch, *, refining_step: bool = True):
    """The algorithm on the four planes of a mosaic padded by :data:`REACH_PX` that starts on
    a red site.

    Every expression of colour-demosaicing's algorithm is evaluated in the same order of
    float32 operations as NumPy evaluated it before (OpenCV's element-wise add, subtract and
    absdiff round exactly as NumPy's, and are about twice as fast on these strided views;
    products by a constant stay NumPy's), into buffers from ``scratch`` (slots: :data:`_SLOTS`)
    reused from band to band. A quantity that lives on a plane keeps a zero outermost ring, as
    in the whole-frame algorithm (``plane``).

    Parameters
    ----------
    R, Gr, Gb, B
        (h, w) float32 planes: red, green in red rows, green in blue rows, blue.
    scratch
        ``scratch(key, shape, dtype=float32)`` → a reusable C-contiguous buffer
        (:class:`spectral_cam.isp.scratch.Scratch`).
    refining_step
        Apply the paper's refining step.

    Returns
    -------
    tuple
        (r, g, b) at the R, G-in-red-rows, G-in-blue-rows and B sites, each (h, w); the outermost
        ring is not valid.
    """
    import cv2

    h, w = R.shape
    add, subtract, absdiff = cv2.add, cv2.subtract, cv2.absdiff

    def multiply(a, factor, dst):  # NumPy: OpenCV's multiply by a scalar is several times slower
        return np.multiply(a, factor, out=dst)

    def at(X, di, dj):
        return X[1 + di:h - 1 + di, 1 + dj:w - 1 + dj]

    def temp(key):  # an interior-sized temporary
        return scratch("menon:" + key, (h - 2, w - 2))

    def full(key):  # a plane-sized quantity, in its slot
        return scratch("menon:" + _SLOTS[key], (h, w))

    def plane(key, dtype=_F32):  # a plane-sized quantity with a zero ring, and its interior
        P = scratch("menon:" + _SLOTS.get(key, key), (h, w), dtype)
        P[0] = 0
        P[-1] = 0
        P[:, 0] = 0
        P[:, -1] = 0
        return P, P[1:h - 1, 1:w - 1]

    def where(mask, x, y):  # np.where(mask, x, y), into y
        cv2.copyTo(x, mask, dst=y)
        return y

    half, quarter, third, three = _F32(0.5), _F32(0.25), _F32(1.0 / 3.0), _F32(3.0)

    # 1. directional green at red and blue sites:
    #    half · (G1 + G2 + C) − quarter · (C1 + C2)
    def green(key, g1, g2, c, c1, c2):
        P, inner = plane(key)
        t, u = temp("t1"), temp("t2")
        multiply(add(add(g1, g2, dst=t), c, dst=t), half, dst=t)
        multiply(add(c1, c2, dst=u), quarter, dst=u)
        subtract(t, u, dst=inner)
        return P

    gh_r = green("gh_r", at(Gr, 0, -1), at(Gr, 0, 0), at(R, 0, 0), at(R, 0, -1), at(R, 0, 1))
    gv_r = green("gv_r", at(Gb, -1, 0), at(Gb, 0, 0), at(R, 0, 0), at(R, -1, 0), at(R, 1, 0))
    gh_b = green("gh_b", at(Gb, 0, 0), at(Gb, 0, 1), at(B, 0, 0), at(B, 0, -1), at(B, 0, 1))
    gv_b = green("gv_b", at(Gr, 0, 0), at(Gr, 1, 0), at(B, 0, 0), at(B, -1, 0), at(B, 1, 0))

    # 2. gradients of the colour differences C − G along each direction, summed over the
    #    5×5 window; the direction with the smaller sum wins (m: 1 = horizontal)
    def gradient(key, C, G, di, dj):
        difference = subtract(C, G, dst=full("difference"))
        P, inner = plane(key)
        absdiff(at(difference, 0, 0), at(difference, di, dj), dst=inner)
        return P

    dh_r = gradient("dh_r", R, gh_r, 0, 1)
    dh_b = gradient("dh_b", B, gh_b, 0, 1)
    dv_r = gradient("dv_r", R, gv_r, 1, 0)
    dv_b = gradient("dv_b", B, gv_b, 1, 0)

    def window(key, own, other, terms):
        """own(a) + own(b) + three · (own(c) + own(d)) + own(e) + own(f) + other(g) + other(h)"""
        (a, b, c, d, e, f), (g, k) = terms
        s, t = temp(key), temp("t1")
        add(at(own, *a), at(own, *b), dst=s)
        add(s, multiply(add(at(own, *c), at(own, *d), dst=t), three, dst=t), dst=s)
        for X, offset in ((own, e), (own, f), (other, g), (other, k)):
            add(s, at(X, *offset), dst=s)
        return s

    def decision(key, horizontal, vertical):
        M, inner = plane(key, np.uint8)
        cv2.compare(vertical, horizontal, cv2.CMP_GE, dst=inner)
        return M

    m_r = decision("m_r", window("sh", dh_r, dh_b, (((-1, -1), (-1, 0), (0, -1), (0, 0), (1, -1), (1, 0)),
                                                   ((-1, -1), (0, -1)))),
                   window("sv", dv_r, dv_b, (((-1, -1), (0, -1), (-1, 0), (0, 0), (-1, 1), (0, 1)),
                                             ((-1, -1), (-1, 0)))))
    m_b = decision("m_b", window("sh", dh_b, dh_r, (((-1, -1), (-1, 0), (0, -1), (0, 0), (1, -1), (1, 0)),
                                                   ((0, 0), (1, 0)))),
                   window("sv", dv_b, dv_r, (((-1, -1), (0, -1), (-1, 0), (0, 0), (-1, 1), (0, 1)),
                                             ((0, 0), (0, 1)))))
    g_r = where(m_r, gh_r, gv_r)  # into gv_r's buffer
    g_b = where(m_b, gh_b, gv_b)

    # 3. red and blue at the greens: G + half · (the two neighbouring C − G along the row or column)
    def greens(g_r, g_b):
        rg, bg = subtract(R, g_r, dst=full("rg")), subtract(B, g_b, dst=full("bg"))
        out = []
        for key, G, diff, (a, b) in (("r_gr", Gr, rg, ((0, 0), (0, 1))), ("b_gr", Gr, bg, ((-1, 0), (0, 0))),
                                     ("b_gb", Gb, bg, ((0, -1), (0, 0))), ("r_gb", Gb, rg, ((0, 0), (1, 0)))):
            P, inner = plane(key)
            t = temp("t1")
            add(at(G, 0, 0), multiply(add(at(diff, *a), at(diff, *b), dst=t), half, dst=t), dst=inner)
            out.append(P)
        return out

    #    then R at B and B at R: C ± weight · (R − B at the neighbours along the decision)
    def across(key, C, sign, weight, mask, horizontal, vertical):
        """C ± weight · where(mask, sum of horizontal terms, sum of vertical terms)"""
        x, y = temp("t1"), temp("t2")
        for terms, dst in ((horizontal, x), (vertical, y)):
            (X0, o0), (X1, o1) = terms[:2]
            add(at(X0, *o0), at(X1, *o1), dst=dst)
            for X, o in terms[2:]:
                add(dst, at(X, *o), dst=dst)
        multiply(where(at(mask, 0, 0), x, y), weight, dst=y)
        P, inner = plane(key)
        (add if sign > 0 else subtract)(at(C, 0, 0), y, dst=inner)
        return P

    r_gr, b_gr, b_gb, r_gb = greens(g_r, g_b)
    e_gr, e_gb = subtract(r_gr, b_gr, dst=full("e_gr")), subtract(r_gb, b_gb, dst=full("e_gb"))
    r_b = across("r_b", B, +1, half, m_b, ((e_gb, (0, 0)), (e_gb, (0, 1))), ((e_gr, (0, 0)), (e_gr, (1, 0))))
    b_r = across("b_r", R, -1, half, m_r, ((e_gr, (0, -1)), (e_gr, (0, 0))), ((e_gb, (-1, 0)), (e_gb, (0, 0))))
    if refining_step:
        # 4a. green at red/blue from the 3-pixel mean of R − G / B − G along the decision
        f_gr, f_gb = subtract(r_gr, Gr, dst=full("f_gr")), subtract(r_gb, Gb, dst=full("f_gb"))
        f_r = subtract(R, g_r, dst=full("f_r"))
        h_gr, h_gb = subtract(b_gr, Gr, dst=full("h_gr")), subtract(b_gb, Gb, dst=full("h_gb"))
        h_b = subtract(B, g_b, dst=full("h_b"))
        g_r = across("g_r", R, -1, third, m_r, ((f_gr, (0, -1)), (f_r, (0, 0)), (f_gr, (0, 0))),
                     ((f_gb, (-1, 0)), (f_r, (0, 0)), (f_gb, (0, 0))))
        g_b = across("g_b", B, -1, third, m_b, ((h_gb, (0, 0)), (h_b, (0, 0)), (h_gb, (0, 1))),
                     ((h_gr, (0, 0)), (h_b, (0, 0)), (h_gr, (1, 0))))
        # 4b. red and blue at greens again; 4c. R − B at red and blue sites again (e_b and e_r
        # first, which frees the slots of r_b and b_r)
        e_b, e_r = subtract(r_b, B, dst=full("e_b")), subtract(R, b_r, dst=full("e_r"))
        r_gr, b_gr, b_gb, r_gb = greens(g_r, g_b)
        e_gr, e_gb = subtract(r_gr, b_gr, dst=full("e_gr")), subtract(r_gb, b_gb, dst=full("e_gb"))
        r_b = across("r_b", B, +1, third, m_b, ((e_gb, (0, 0)), (e_b, (0, 0)), (e_gb, (0, 1))),
                     ((e_gr, (0, 0)), (e_b, (0, 0)), (e_gr, (1, 0))))
        b_r = across("b_r", R, -1, third, m_r, ((e_gr, (0, -1)), (e_r, (0, 0)), (e_gr, (0, 0))),
                     ((e_gb, (-1, 0)), (e_r, (0, 0)), (e_gb, (0, 0))))
    return (R, g_r, b_r), (r_gr, Gr, b_gr), (r_gb, Gb, b_gb), (r_b, g_b, B)
