"""Menon, Andriani & Calvagno (2007): demosaicing with directional filtering and a posteriori
decision (DDFAPD), with the paper's refining step, in float32 on the four CFA planes.

The algorithm is colour-demosaicing's (Mansencal et al.), step for step, rewritten so that a
12 MP frame demosaics in a fraction of a second and ``colour`` (whose import loads matplotlib,
~1 s) is never imported. Every quantity lives on the CFA site where the algorithm uses it: the
mosaic is split into its four half-resolution planes (R, G in red rows, G in blue rows, B), and
every convolution of the full-resolution algorithm becomes a sum of a few neighbouring plane
samples (``at(plane, di, dj)``, a shifted view, no copy), so nothing is computed at a site that
discards it. Each operation writes into a reused buffer (:data:`_SLOTS`), so that
:func:`menon2007` can run :func:`menon2007_sites` on cache-sized row bands on threads
(:func:`spectral_cam.isp.plane_bands.by_planes`). Borders: the mosaic is mirror-padded once (about the edge pixel) by :data:`REACH_PX`, more
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

from .plane_bands import by_planes, check_bayer_mosaic

__all__ = ["REACH_PX", "MENON_BAND_ROWS", "menon2007_sites", "menon2007"]

_F32 = np.float32
#: Mirror padding (full-resolution pixels, even): each of the ~8 chained steps reads one plane
#: sample (two pixels) further, and the outermost ring of every plane is left unset.
REACH_PX = 20
#: Output rows per band, whose bands overlap by 2 × REACH_PX rows.
MENON_BAND_ROWS = 256

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


_HALF, _QUARTER, _THIRD, _THREE = _F32(0.5), _F32(0.25), _F32(1.0 / 3.0), _F32(3.0)


class _Band:
    """One band's four planes, its buffers, and the operations every step is written in: shifted
    views of the planes (``at``), buffers by slot (``full``, ``plane``, ``temp``), and the paper's
    recurring expressions, each into a buffer.

    OpenCV's element-wise add, subtract and absdiff round exactly as NumPy's and are about twice as
    fast on these strided views; products by a constant stay NumPy's (OpenCV's multiply by a
    scalar is several times slower).
    """

    def __init__(self, R, Gr, Gb, B, scratch):
        import cv2

        self.cv2 = cv2
        self.R, self.Gr, self.Gb, self.B, self.scratch = R, Gr, Gb, B, scratch
        self.h, self.w = R.shape

    def at(self, X, di, dj):
        return X[1 + di:self.h - 1 + di, 1 + dj:self.w - 1 + dj]

    def temp(self, key):  # an interior-sized temporary
        return self.scratch("menon:" + key, (self.h - 2, self.w - 2))

    def full(self, key):  # a plane-sized quantity, in its slot
        return self.scratch("menon:" + _SLOTS[key], (self.h, self.w))

    def plane(self, key, dtype=_F32):  # a plane-sized quantity with a zero ring, and its interior
        h, w = self.h, self.w
        P = self.scratch("menon:" + _SLOTS.get(key, key), (h, w), dtype)
        P[0] = 0
        P[-1] = 0
        P[:, 0] = 0
        P[:, -1] = 0
        return P, P[1:h - 1, 1:w - 1]

    def where(self, mask, x, y):  # np.where(mask, x, y), into y
        self.cv2.copyTo(x, mask, dst=y)
        return y

    def green(self, key, g1, g2, c, c1, c2):
        """Step 1 in one direction: half · (G1 + G2 + C) − quarter · (C1 + C2)."""
        add, subtract = self.cv2.add, self.cv2.subtract
        P, inner = self.plane(key)
        t, u = self.temp("t1"), self.temp("t2")
        np.multiply(add(add(g1, g2, dst=t), c, dst=t), _HALF, out=t)
        np.multiply(add(c1, c2, dst=u), _QUARTER, out=u)
        subtract(t, u, dst=inner)
        return P

    def gradient(self, key, C, G, di, dj):
        """|C − G at a site − C − G one plane sample along (di, dj)|."""
        difference = self.cv2.subtract(C, G, dst=self.full("difference"))
        P, inner = self.plane(key)
        self.cv2.absdiff(self.at(difference, 0, 0), self.at(difference, di, dj), dst=inner)
        return P

    def window(self, key, own, other, terms):
        """own(a) + own(b) + three · (own(c) + own(d)) + own(e) + own(f) + other(g) + other(h)"""
        add, at = self.cv2.add, self.at
        (a, b, c, d, e, f), (g, k) = terms
        s, t = self.temp(key), self.temp("t1")
        add(at(own, *a), at(own, *b), dst=s)
        add(s, np.multiply(add(at(own, *c), at(own, *d), dst=t), _THREE, out=t), dst=s)
        for X, offset in ((own, e), (own, f), (other, g), (other, k)):
            add(s, at(X, *offset), dst=s)
        return s

    def decision(self, key, horizontal, vertical):
        M, inner = self.plane(key, np.uint8)
        self.cv2.compare(vertical, horizontal, self.cv2.CMP_GE, dst=inner)
        return M

    def greens(self, g_r, g_b):
        """Red and blue at the greens: G + half · (the two neighbouring C − G along the row or column)."""
        add, at = self.cv2.add, self.at
        rg = self.cv2.subtract(self.R, g_r, dst=self.full("rg"))
        bg = self.cv2.subtract(self.B, g_b, dst=self.full("bg"))
        out = []
        for key, G, diff, (a, b) in (("r_gr", self.Gr, rg, ((0, 0), (0, 1))), ("b_gr", self.Gr, bg, ((-1, 0), (0, 0))),
                                     ("b_gb", self.Gb, bg, ((0, -1), (0, 0))), ("r_gb", self.Gb, rg, ((0, 0), (1, 0)))):
            P, inner = self.plane(key)
            t = self.temp("t1")
            add(at(G, 0, 0), np.multiply(add(at(diff, *a), at(diff, *b), dst=t), _HALF, out=t), dst=inner)
            out.append(P)
        return out

    def across(self, key, C, sign, weight, mask, horizontal, vertical):
        """C ± weight · where(mask, sum of horizontal terms, sum of vertical terms)"""
        add, at = self.cv2.add, self.at
        x, y = self.temp("t1"), self.temp("t2")
        for terms, dst in ((horizontal, x), (vertical, y)):
            (X0, o0), (X1, o1) = terms[:2]
            add(at(X0, *o0), at(X1, *o1), dst=dst)
            for X, o in terms[2:]:
                add(dst, at(X, *o), dst=dst)
        np.multiply(self.where(at(mask, 0, 0), x, y), weight, out=y)
        P, inner = self.plane(key)
        (add if sign > 0 else self.cv2.subtract)(at(C, 0, 0), y, dst=inner)
        return P

    def differences(self, first, a, b, second, c, d):
        """first = a − b and second = c − d, each into its slot."""
        subtract = self.cv2.subtract
        return subtract(a, b, dst=self.full(first)), subtract(c, d, dst=self.full(second))


def _directional_greens(band: _Band):
    """Step 1: green at red and blue sites along the row (h) and the column (v)."""
    at, R, Gr, Gb, B = band.at, band.R, band.Gr, band.Gb, band.B
    gh_r = band.green("gh_r", at(Gr, 0, -1), at(Gr, 0, 0), at(R, 0, 0), at(R, 0, -1), at(R, 0, 1))
    gv_r = band.green("gv_r", at(Gb, -1, 0), at(Gb, 0, 0), at(R, 0, 0), at(R, -1, 0), at(R, 1, 0))
    gh_b = band.green("gh_b", at(Gb, 0, 0), at(Gb, 0, 1), at(B, 0, 0), at(B, 0, -1), at(B, 0, 1))
    gv_b = band.green("gv_b", at(Gr, 0, 0), at(Gr, 1, 0), at(B, 0, 0), at(B, -1, 0), at(B, 1, 0))
    return gh_r, gv_r, gh_b, gv_b


#: Step 2's 5 × 5 windows: the own plane's six offsets and the other plane's two, per direction
#: and site (r, b).
_WINDOW_OWN_H = ((-1, -1), (-1, 0), (0, -1), (0, 0), (1, -1), (1, 0))
_WINDOW_OWN_V = ((-1, -1), (0, -1), (-1, 0), (0, 0), (-1, 1), (0, 1))
_WINDOW_OTHER = {("h", "r"): ((-1, -1), (0, -1)), ("v", "r"): ((-1, -1), (-1, 0)),
                 ("h", "b"): ((0, 0), (1, 0)), ("v", "b"): ((0, 0), (0, 1))}


def _decisions(band: _Band, gh_r, gv_r, gh_b, gv_b):
    """Step 2: gradients of the colour differences C − G along each direction, summed over the
    5×5 window; the direction with the smaller sum wins (m: 1 = horizontal)."""
    dh_r = band.gradient("dh_r", band.R, gh_r, 0, 1)
    dh_b = band.gradient("dh_b", band.B, gh_b, 0, 1)
    dv_r = band.gradient("dv_r", band.R, gv_r, 1, 0)
    dv_b = band.gradient("dv_b", band.B, gv_b, 1, 0)
    m_r = band.decision("m_r", band.window("sh", dh_r, dh_b, (_WINDOW_OWN_H, _WINDOW_OTHER["h", "r"])),
                        band.window("sv", dv_r, dv_b, (_WINDOW_OWN_V, _WINDOW_OTHER["v", "r"])))
    m_b = band.decision("m_b", band.window("sh", dh_b, dh_r, (_WINDOW_OWN_H, _WINDOW_OTHER["h", "b"])),
                        band.window("sv", dv_b, dv_r, (_WINDOW_OWN_V, _WINDOW_OTHER["v", "b"])))
    return m_r, m_b


def _red_and_blue(band: _Band, g_r, g_b, m_r, m_b):
    """Step 3: red and blue at the greens, then R at B and B at R: C ± ½ · (R − B at the
    neighbours along the decision)."""
    r_gr, b_gr, b_gb, r_gb = band.greens(g_r, g_b)
    e_gr, e_gb = band.differences("e_gr", r_gr, b_gr, "e_gb", r_gb, b_gb)
    r_b = band.across("r_b", band.B, +1, _HALF, m_b, ((e_gb, (0, 0)), (e_gb, (0, 1))), ((e_gr, (0, 0)), (e_gr, (1, 0))))
    b_r = band.across("b_r", band.R, -1, _HALF, m_r, ((e_gr, (0, -1)), (e_gr, (0, 0))),
                      ((e_gb, (-1, 0)), (e_gb, (0, 0))))
    return r_gr, b_gr, b_gb, r_gb, r_b, b_r


def _refine(band: _Band, g_r, g_b, m_r, m_b, colours):
    """Step 4, the refining step: (a) green at red/blue from the 3-pixel mean of R − G / B − G along
    the decision; (b) red and blue at greens again; (c) R − B at red and blue sites again (e_b and
    e_r first, which frees the slots of r_b and b_r)."""
    R, Gr, Gb, B = band.R, band.Gr, band.Gb, band.B
    r_gr, b_gr, b_gb, r_gb, r_b, b_r = colours
    f_gr, f_gb = band.differences("f_gr", r_gr, Gr, "f_gb", r_gb, Gb)
    f_r = band.cv2.subtract(R, g_r, dst=band.full("f_r"))
    h_gr, h_gb = band.differences("h_gr", b_gr, Gr, "h_gb", b_gb, Gb)
    h_b = band.cv2.subtract(B, g_b, dst=band.full("h_b"))
    g_r = band.across("g_r", R, -1, _THIRD, m_r, ((f_gr, (0, -1)), (f_r, (0, 0)), (f_gr, (0, 0))),
                      ((f_gb, (-1, 0)), (f_r, (0, 0)), (f_gb, (0, 0))))
    g_b = band.across("g_b", B, -1, _THIRD, m_b, ((h_gb, (0, 0)), (h_b, (0, 0)), (h_gb, (0, 1))),
                      ((h_gr, (0, 0)), (h_b, (0, 0)), (h_gr, (1, 0))))
    e_b, e_r = band.differences("e_b", r_b, B, "e_r", R, b_r)
    r_gr, b_gr, b_gb, r_gb = band.greens(g_r, g_b)
    e_gr, e_gb = band.differences("e_gr", r_gr, b_gr, "e_gb", r_gb, b_gb)
    r_b = band.across("r_b", B, +1, _THIRD, m_b, ((e_gb, (0, 0)), (e_b, (0, 0)), (e_gb, (0, 1))),
                      ((e_gr, (0, 0)), (e_b, (0, 0)), (e_gr, (1, 0))))
    b_r = band.across("b_r", R, -1, _THIRD, m_r, ((e_gr, (0, -1)), (e_r, (0, 0)), (e_gr, (0, 0))),
                      ((e_gb, (-1, 0)), (e_r, (0, 0)), (e_gb, (0, 0))))
    return g_r, g_b, (r_gr, b_gr, b_gb, r_gb, r_b, b_r)


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
    band = _Band(R, Gr, Gb, B, scratch)
    gh_r, gv_r, gh_b, gv_b = _directional_greens(band)
    m_r, m_b = _decisions(band, gh_r, gv_r, gh_b, gv_b)
    g_r = band.where(m_r, gh_r, gv_r)  # into gv_r's buffer
    g_b = band.where(m_b, gh_b, gv_b)
    colours = _red_and_blue(band, g_r, g_b, m_r, m_b)
    if refining_step:
        g_r, g_b, colours = _refine(band, g_r, g_b, m_r, m_b, colours)
    r_gr, b_gr, b_gb, r_gb, r_b, b_r = colours
    return (R, g_r, b_r), (r_gr, Gr, b_gr), (r_gb, Gb, b_gb), (r_b, g_b, B)


def menon2007(mosaic: np.ndarray, cfa: str = "RGGB", *, refining_step: bool = True) -> np.ndarray:
    """Directional filtering with a posteriori decision (Menon, Andriani & Calvagno 2007).

    colour-demosaicing's algorithm in float32 on the four CFA planes
    (:func:`menon2007_sites`, without importing colour), on row
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
    mosaic, cfa = check_bayer_mosaic(mosaic, cfa)

    def sites(R, Gr, Gb, B, scratch):
        return menon2007_sites(R, Gr, Gb, B, scratch, refining_step=refining_step)

    return by_planes(mosaic, cfa, sites, pad=REACH_PX, offset=0, band_rows=MENON_BAND_ROWS)
