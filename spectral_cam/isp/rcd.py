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
darktable, GPL-3; nothing of it is copied here), unclipped (the reference clips to [0, 1]: a
white-balanced linear mosaic exceeds 1 and noise goes below 0), so the low-pass is clamped at zero
only where it forms a ratio.

Speed (as menon2007, issue 37 #7 follow-up): row bands (in tiles of about 2048 columns) on threads,
each thread reusing its float32 buffers; step 1, the same at every pixel, runs on the band; every
other quantity lives on the CFA plane of the sites that keep it (R, G in red rows, G in blue rows, B),
each neighbour a shifted view, so nothing is computed at a site that discards it (the first version
formed every step at every pixel and selected with ``np.where``); only the median runs on the
interleaved colour differences. Every expression keeps the float32 order of operations of that
first, full-resolution NumPy version (OpenCV's element-wise add, subtract, absdiff, multiply and
divide round as NumPy's), so the result is the same bit for bit: RCD is sensitive to rounding in
flat regions, where its gradients meet ε = 10⁻⁵ (reordered sums and OpenCV filters moved outputs
by up to 2·10⁻⁴ of full scale beside noise-free edges). A gradient |x[k] − x[k − 1]| along an
axis, and ε plus it, are formed once for every step that reads them. 12 MP on 2 loaded CPUs,
medians: 3.35 s → 0.60 s (menon2007 0.21 s, malvar2004 0.09 s in the same run); 24 MP 4.95 s →
1.32 s (menon2007 0.48 s).

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

__all__ = ["REACH_PX", "BAND_ROWS", "rcd_band", "rcd"]

_F32 = np.float32
_EPS = 1e-5  # ε, as float32 wherever it meets a float32 array (OpenCV converts a scalar to the array's type)
_EPSSQ = _F32(1e-10)
_EPSSQ_D = float(_EPSSQ)
#: Context (pixels, even) a band needs on each side: the chained steps read 13 pixels away
#: (step 1: 4 + 1, step 3: 4, step 4: 3 + 3 on the diagonal and cardinal passes, the median: 1;
#: bands cut at 14 still give the whole frame's result, at 12 they do not).
REACH_PX = 16
#: Output rows per band, and columns per tile of a band, about.
BAND_ROWS = 256
TILE_COLUMNS = 2048
#: The margin (plane samples) that every plane quantity leaves unset: the widest shift any one
#: expression reads is 2.
_M = 2


class _Band:
    """A band X (h, w even, a red site at (0, 0)), its four planes R, Gr, Gb, B, its buffers, and the
    operations RCD's steps are written in: OpenCV's add, subtract, absdiff, multiply and divide
    (``ops``; they round as NumPy's), shifted views of plane quantities (``at``, ``along``), and the
    recurring sums in a fixed left-to-right float32 order."""

    def __init__(self, X, R, Gr, Gb, B, scratch):
        import cv2

        self.cv2, self.X, self.R, self.Gr, self.Gb, self.B, self.scratch = cv2, X, R, Gr, Gb, B, scratch
        self.h, self.w = X.shape
        self.hq, self.wq = self.h // 2, self.w // 2
        self.ops = cv2.add, cv2.subtract, cv2.absdiff, cv2.multiply, cv2.divide

    def buf(self, key, shape=None, dtype=_F32):
        return self.scratch("rcd:" + key, shape or (self.hq, self.wq), dtype)

    def at(self, P, di=0, dj=0):
        m = _M
        return P[m + di:self.hq - m + di, m + dj:self.wq - m + dj]

    def along(self, P, axis, k):  # at(P) shifted by k samples along axis
        return self.at(P, k, 0) if axis == 0 else self.at(P, 0, k)

    def plane(self, key):  # a plane quantity (its margin unset) and its interior
        P = self.buf(key)
        return P, self.at(P)

    def temp(self, key):  # an interior-sized temporary
        return self.buf("tmp:" + key, (self.hq - 2 * _M, self.wq - 2 * _M))

    def view(self, F, dy=0, dx=0):  # a full-resolution quantity 4 pixels in, shifted by (dy, dx)
        return F[4 + dy:self.h - 4 + dy, 4 + dx:self.w - 4 + dx]

    def chain(self, first, *terms, dst):  # ((first + t₁) + t₂) + …, left to right
        add = self.cv2.add
        add(first, terms[0], dst=dst)
        for term in terms[1:]:
            add(dst, term, dst=dst)
        return dst

    def weighted(self, a, x, b, y, dst, t):  # (a·x + b·y) / (a + b)
        add, multiply = self.cv2.add, self.cv2.multiply
        add(multiply(a, x, dst=dst), multiply(b, y, dst=t), dst=dst)
        return self.cv2.divide(dst, add(a, b, dst=t), dst=dst)

    def blend(self, d, one_minus_d, x, y, dst, t):  # d·x + (1 − d)·y
        multiply = self.cv2.multiply
        return self.cv2.add(multiply(d, x, dst=dst), multiply(one_minus_d, y, dst=t), dst=dst)

    def high_pass(self, terms, six_x0, dst, t):
        """((((x₋₃ − x₋₁) − x₊₁) + x₊₃) − 3 (x₋₂ + x₊₂)) + 6 x₀ (a constant region: exactly zero)"""
        add, subtract = self.cv2.add, self.cv2.subtract
        m3, m1, p1, p3, m2, p2 = terms
        add(subtract(subtract(m3, m1, dst=dst), p1, dst=dst), p3, dst=dst)
        np.multiply(add(m2, p2, dst=t), _F32(3), out=t)
        return add(subtract(dst, t, dst=dst), six_x0, dst=dst)

    def interleave(self, planes, F):  # four plane quantities → the band at full resolution
        for rows, pair in ((F[0::2], planes[:2]), (F[1::2], planes[2:])):
            dst = rows.reshape(self.hq, self.wq, 2)
            if self.cv2.merge(pair, dst=dst) is not dst:  # pragma: no cover
                raise RuntimeError("cv2.merge did not write into the band")
        return F


def _discrimination(band: _Band):
    """Step 1: the vertical / horizontal discrimination VH at every site, as d (``d_at``) and
    1 − d (``omd_at``, interior) per plane; the band-sized buffers a, b, v, s, t it used."""
    cv2, X = band.cv2, band.X
    add, subtract, absdiff, multiply, divide = band.ops
    at, buf, chain = band.at, band.buf, band.chain
    h, w, hq, wq, view, high_pass = band.h, band.w, band.hq, band.wq, band.view, band.high_pass

    # 1. vertical / horizontal discrimination, at every pixel of the band (4 pixels in)
    a, b, v, s, t = (buf(key, (h, w)) for key in ("a", "b", "v", "s", "t"))
    for F in (a, b, v):  # the margins that the sums and means below read: zero, as in the whole frame
        F[:4], F[-4:], F[:, :4], F[:, -4:] = 0, 0, 0, 0
    six_x = np.multiply(view(X), _F32(6), out=view(s))
    for F, (dy, dx) in ((a, (1, 0)), (b, (0, 1))):
        high_pass([view(X, k * dy, k * dx) for k in (-3, -1, 1, 3, -2, 2)], six_x, view(F), view(t))
        multiply(view(F), view(F), dst=view(F))
    v_stat = cv2.max(chain(view(a, -1, 0), view(a), view(a, 1, 0), dst=view(v)), _EPSSQ_D, dst=view(v))
    h_stat = cv2.max(chain(view(b, 0, -1), view(b), view(b, 0, 1), dst=view(s)), _EPSSQ_D, dst=view(s))
    vh = divide(v_stat, add(v_stat, h_stat, dst=view(t)), dst=view(v))
    neighbours = np.multiply(chain(view(v, -1, -1), view(v, -1, 1), view(v, 1, -1), view(v, 1, 1), dst=view(a)),
                             _F32(0.25), out=view(a))
    mask = cv2.compare(absdiff(vh, 0.5, dst=view(b)), absdiff(neighbours, 0.5, dst=view(s)), cv2.CMP_LT,
                       dst=buf("mask", vh.shape, np.uint8))
    cv2.copyTo(neighbours, mask, dst=vh)
    d_at = {}
    for rows, keys in ((v[0::2], ("r", "gr")), (v[1::2], ("gb", "b"))):
        pairs = rows.reshape(hq, wq, 2)
        for c, key in enumerate(keys):
            d_at[key] = cv2.extractChannel(pairs, c, dst=buf("vh_" + key))
    omd_at = {key: subtract(1.0, at(d), dst=buf("omd_" + key, at(d).shape)) for key, d in d_at.items()}
    return (a, b, v, s, t), d_at, omd_at


def _low_pass(band: _Band):
    """Step 2: the low-pass at red and blue sites, clamped at zero."""
    cv2, R, Gr, Gb, B = band.cv2, band.R, band.Gr, band.Gb, band.B
    add = band.cv2.add
    at, plane, temp, chain = band.at, band.plane, band.temp, band.chain

    # 2. the low-pass, clamped at zero where it forms a ratio, at red and blue sites:
    #    (x₀ + ½ (((N + S) + W) + E)) + ¼ (((NW + NE) + SW) + SE); o is the site's offset in the planes
    #    of the other colours (N = Pv[k − 1 + o], S = Pv[k + o] on the vertical neighbours' plane)
    low = {}
    for site, C, Pv, Ph, other, o in (("r", R, Gb, Gr, B, 0), ("b", B, Gr, Gb, R, 1)):
        L, inner = plane("l_" + site)
        t1 = np.multiply(chain(at(Pv, o - 1, 0), at(Pv, o, 0), at(Ph, 0, o - 1), at(Ph, 0, o), dst=temp("l1")),
                         _F32(0.5), out=temp("l1"))
        t2 = np.multiply(chain(at(other, o - 1, o - 1), at(other, o - 1, o), at(other, o, o - 1), at(other, o, o),
                               dst=temp("l2")), _F32(0.25), out=temp("l2"))
        cv2.max(add(add(at(C), t1, dst=inner), t2, dst=inner), 0.0, dst=inner)
        low[site] = L
    return low


def _green(band: _Band, low, d_at, omd_at):
    """Step 3: green at red and blue sites (``g_at``); the gradients along each axis (``grad``) and ε plus
    the greens' (``e_green``), which step 4b reads again."""
    R, Gr, Gb, B = band.R, band.Gr, band.Gb, band.B
    add, subtract, absdiff, multiply, divide = band.ops
    at, along, plane, temp, chain = band.at, band.along, band.plane, band.temp, band.chain
    weighted, blend = band.weighted, band.blend

    # 3. green at red and blue sites. Along an axis, with P the green plane of the neighbours and o
    #    the site's offset in it (x₋₁ = P[k − 1 + o], x₊₁ = P[k + o]), a[k] = |P[k] − P[k − 1]|,
    #    c[k] = |C[k] − C[k − 1]| on the site's own plane and e = ε + a:
    #    north gradient ((e[k + o] + c[k]) + a[k − 1 + o]) + c[k − 1],
    #    south          ((e[k + o] + c[k + 1]) + a[k + 1 + o]) + c[k + 2];
    #    with D[k] = L[k] − L[k − 1] of the low-pass L at C's sites: north estimate
    #    x₋₁ (1 + D[k] / ((ε + L[k]) + L[k − 1])), south x₊₁ (1 − D[k + 1] / ((ε + L[k]) + L[k + 1]))
    grad = {}  # |P[k] − P[k − 1]| along each axis on each plane, read again by step 4b
    e_green = {}
    g_at = {}
    for site, C, o, greens in (("r", R, 0, (("gb", Gb), ("gr", Gr))), ("b", B, 1, (("gr", Gr), ("gb", Gb)))):
        L = low[site]
        eL = add(at(L), _EPS, dst=temp("eL"))
        directional = []
        for axis, (gname, P) in enumerate(greens):
            aG, inner = plane(f"grad_{gname}{axis}")
            absdiff(at(P), along(P, axis, -1), dst=inner)
            aC, inner = plane(f"grad_{site}{axis}")
            absdiff(at(C), along(C, axis, -1), dst=inner)
            grad[gname, axis], grad[site, axis] = aG, aC
            e, inner = plane(f"e_{gname}{axis}")  # ε + a, read again by step 4b
            add(at(aG), _EPS, dst=inner)
            e_green[gname, axis] = e
            north = chain(along(e, axis, o), at(aC), along(aG, axis, o - 1), along(aC, axis, -1), dst=temp("n"))
            south = chain(along(e, axis, o), along(aC, axis, 1), along(aG, axis, o + 1), along(aC, axis, 2),
                          dst=temp("s"))
            D, inner = plane("D")
            subtract(at(L), along(L, axis, -1), dst=inner)
            ratio = divide(at(D), add(eL, along(L, axis, -1), dst=temp("r")), dst=temp("r"))
            e_north = multiply(along(P, axis, o - 1), add(ratio, 1.0, dst=ratio), dst=temp("e1"))
            ratio = divide(along(D, axis, 1), add(eL, along(L, axis, 1), dst=temp("r")), dst=temp("r"))
            e_south = multiply(along(P, axis, o), subtract(1.0, ratio, dst=ratio), dst=temp("e2"))
            directional.append(weighted(south, e_north, north, e_south, temp(f"dir{axis}"), temp("r")))
        vertical, horizontal = directional
        G, inner = plane("g_" + site)
        blend(at(d_at[site]), omd_at[site], horizontal, vertical, inner, temp("r"))
        g_at[site] = G
    return g_at, grad, e_green


def _diagonal_discrimination(band: _Band):
    """Step 4a's first half: the diagonal discrimination PQ at red and blue sites (interior)."""
    cv2, R, B = band.cv2, band.R, band.B
    add, _, absdiff, multiply, divide = band.ops
    at, plane, temp, buf, chain = band.at, band.plane, band.temp, band.buf, band.chain
    high_pass = band.high_pass

    # 4a. red at blue and blue at red sites, along the diagonals: first the diagonal discrimination
    #     at both (p: (1, 1), q: (1, −1)), from the squared diagonal high-pass summed over three
    #     pixels along each diagonal (o: the site's offset in the other colour's plane)
    high = {}
    six = {"r": np.multiply(R, _F32(6), out=buf("six_r")), "b": np.multiply(B, _F32(6), out=buf("six_b"))}
    for site, own, other, o in (("r", R, B, 0), ("b", B, R, 1)):
        for name, other_at, own_at in (("p", ((-2, -2), (-1, -1), (0, 0), (1, 1)), ((-1, -1), (1, 1))),
                                       ("q", ((-2, 1), (-1, 0), (0, -1), (1, -2)), ((-1, 1), (1, -1)))):
            P, inner = plane(f"hp_{name}{site}")
            terms = [at(other, dy + o, dx + o) for dy, dx in other_at] + [at(own, dy, dx) for dy, dx in own_at]
            high_pass(terms, at(six[site]), inner, temp("hp"))
            multiply(inner, inner, dst=inner)
            high[name, site] = P
    pq_raw = {}
    for site, other, o in (("r", "b", 0), ("b", "r", 1)):
        bp, bq = high["p", other], high["q", other]
        p_stat = cv2.max(chain(at(bp, o - 1, o - 1), at(high["p", site]), at(bp, o, o), dst=temp("p")), _EPSSQ_D,
                         dst=temp("p"))
        q_stat = cv2.max(chain(at(bq, o - 1, o), at(high["q", site]), at(bq, o, o - 1), dst=temp("q")), _EPSSQ_D,
                         dst=temp("q"))
        P, inner = plane("pq_raw_" + site)
        divide(p_stat, add(p_stat, q_stat, dst=q_stat), dst=inner)
        pq_raw[site] = P
    pq = {}
    for site, other, o in (("r", "b", 0), ("b", "r", 1)):
        N = pq_raw[other]
        neighbours = np.multiply(chain(at(N, o - 1, o - 1), at(N, o - 1, o), at(N, o, o - 1), at(N, o, o),
                                       dst=temp("nb")), _F32(0.25), out=temp("nb"))
        centre = at(pq_raw[site])
        mask = cv2.compare(absdiff(centre, 0.5, dst=temp("d1")), absdiff(neighbours, 0.5, dst=temp("d2")),
                           cv2.CMP_LT, dst=buf("mask", centre.shape, np.uint8))
        P = temp("pq_" + site)
        np.copyto(P, centre)
        cv2.copyTo(neighbours, mask, dst=P)
        pq[site] = P
    return pq


def _colour_at_other_sites(band: _Band, g_at, pq):
    """Step 4a's second half: red at blue sites and blue at red sites (``colour_at``), and the colour
    differences to green at red and blue sites (``diff_at``)."""
    R, B = band.R, band.B
    add, subtract, absdiff, multiply = band.ops[:4]
    at, plane, temp, buf, chain = band.at, band.plane, band.temp, band.buf, band.chain
    weighted = band.weighted

    #     then each colour at the other's sites: with C the colour's plane, g, pq at the other's
    #     sites, o the site's offset in C, a[k] = |C[k] − C[k − s]| and b[k] = |g[k] − g[k − s]| for
    #     the diagonal step s, e = ε + a: NW = (e[k + o] + a[k + o − 1]) + b[k],
    #     SE = (e[k + o] + a[k + o + 1]) + b[k + 1] (k ± 1: one step along the diagonal)
    diff_at = {"r": subtract(R, g_at["r"], dst=buf("diff_r")), "b": subtract(B, g_at["b"], dst=buf("diff_b"))}
    colour_at = {}
    for colour, C, site, o in (("r", R, "b", 1), ("b", B, "r", 0)):
        g, dC = g_at[site], diff_at[colour]
        estimates = []
        for sy, sx in ((-1, -1), (-1, 1)):  # p, q: the step to the previous sample along the diagonal
            aC, inner = plane("ac")
            absdiff(at(C), at(C, sy, sx), dst=inner)
            ag, inner = plane("ag")
            absdiff(at(g), at(g, sy, sx), dst=inner)
            e, inner = plane("e")
            add(at(aC), _EPS, dst=inner)
            # the offsets (rows, columns) of k + o, k + o − 1 and k + o + 1 along the diagonal
            centre = (o, o) if sx < 0 else (o, o - 1)
            before = (centre[0] - 1, centre[1] - 1) if sx < 0 else (centre[0] - 1, centre[1] + 1)
            after = (centre[0] + 1, centre[1] + 1) if sx < 0 else (centre[0] + 1, centre[1] - 1)
            step = (1, 1) if sx < 0 else (1, -1)
            first = chain(at(e, *centre), at(aC, *before), at(ag), dst=temp("nw"))
            second = chain(at(e, *centre), at(aC, *after), at(ag, *step), dst=temp("se"))
            # the differences one site along (+) and one back (−): dC at k + o and k + o − 1 along it
            plus = centre
            minus = (centre[0] - 1, centre[1] - 1) if sx < 0 else (centre[0] - 1, centre[1] + 1)
            estimates.append(weighted(first, at(dC, *plus), second, at(dC, *minus), temp(f"est{sx}"), temp("w")))
        p_est, q_est = estimates
        value, inner = plane("colour_" + colour)
        pq_ = pq[site]
        add(at(g), multiply(subtract(1.0, pq_, dst=temp("w")), p_est, dst=p_est), dst=inner)
        add(inner, multiply(pq_, q_est, dst=q_est), dst=inner)
        colour_at[colour] = value
    diff_at["r_at_b"] = subtract(colour_at["r"], g_at["b"], dst=buf("diff_rb"))
    diff_at["b_at_r"] = subtract(colour_at["b"], g_at["r"], dst=buf("diff_br"))
    return colour_at, diff_at


def _colour_at_greens(band: _Band, grad, e_green, colour_at, diff_at, d_at, omd_at):
    """Step 4b: red and blue at the two green sites (``out_at[colour, green site]``)."""
    R, Gr, Gb, B = band.R, band.Gr, band.Gb, band.B
    add, _, absdiff, multiply = band.ops[:4]
    at, along, plane, temp, chain = band.at, band.along, band.plane, band.temp, band.chain
    weighted = band.weighted

    # 4b. red and blue at green sites, along the row and the column: at a green site with P the
    #     colour's plane along the axis and o the site's offset in it, c[k] = |P[k] − P[k − 1]|,
    #     e₁ = ε + a with a[k] = |G[k] − G[k − 1]| on the green's own plane: north (west) gradient
    #     (e₁[k] + c[k + o]) + c[k − 1 + o], south (east) (e₁[k + 1] + c[k + o]) + c[k + 1 + o]
    e1 = e_green
    out_at = {}
    for colour, at_r, at_b, D_r, D_b in (("r", R, colour_at["r"], diff_at["r"], diff_at["r_at_b"]),
                                         ("b", colour_at["b"], B, diff_at["b_at_r"], diff_at["b"])):
        grads = {}
        for where, P in (("r", at_r), ("b", at_b)):
            for axis in (0, 1):
                if P is R or P is B:  # a measured plane: step 3 formed its gradients
                    grads[where, axis] = grad[where, axis]
                else:
                    c, inner = plane(f"c4_{where}{axis}")
                    absdiff(at(P), along(P, axis, -1), dst=inner)
                    grads[where, axis] = c
        for gsite, G, layout in (("gr", Gr, {0: ("b", 0), 1: ("r", 1)}), ("gb", Gb, {0: ("r", 1), 1: ("b", 0)})):
            directional = []
            for axis in (0, 1):
                where, o = layout[axis]
                c, D, e = grads[where, axis], (D_r if where == "r" else D_b), e1[gsite, axis]
                north = chain(at(e), along(c, axis, o), along(c, axis, o - 1), dst=temp("n"))
                south = chain(along(e, axis, 1), along(c, axis, o), along(c, axis, o + 1), dst=temp("s"))
                directional.append(weighted(north, along(D, axis, o), south, along(D, axis, o - 1), temp(f"dir{axis}"),
                                            temp("w")))
            vertical, horizontal = directional
            value, inner = plane(f"out_{colour}{gsite}")
            add(at(G), multiply(omd_at[gsite], vertical, dst=vertical), dst=inner)
            add(inner, multiply(at(d_at[gsite]), horizontal, dst=horizontal), dst=inner)
            out_at[colour, gsite] = value
    return out_at


def _finish(band: _Band, full, g_at, colour_at, diff_at, out_at, median: bool):
    """Step 5: the band's red, green and blue at full resolution, red and blue through one 3 × 3
    median of their difference from green when ``median``."""
    cv2, R, Gr, Gb, B = band.cv2, band.R, band.Gr, band.Gb, band.B
    add, subtract = band.ops[:2]
    at = band.at
    a, b, v, s, t = full
    interleave = band.interleave

    # 5. false-colour suppression: one 3 × 3 median of each colour difference, green kept
    green = interleave((g_at["r"], Gr, Gb, g_at["b"]), a)
    out = [None, green, None]
    for channel, colour, D_r, D_b in ((0, "r", diff_at["r"], diff_at["r_at_b"]),
                                      (2, "b", diff_at["b_at_r"], diff_at["b"])):
        if median:
            for gsite, G in (("gr", Gr), ("gb", Gb)):
                E = out_at[colour, gsite]
                subtract(at(E), at(G), dst=at(E))
            difference = interleave((D_r, out_at[colour, "gr"], out_at[colour, "gb"], D_b), s)
            out[channel] = add(green, cv2.medianBlur(difference, 3, dst=t), dst=b if channel == 0 else v)
        else:
            planes = ((R, out_at["r", "gr"], out_at["r", "gb"], colour_at["r"]) if colour == "r" else
                      (colour_at["b"], out_at["b", "gr"], out_at["b", "gb"], B))
            out[channel] = interleave(planes, b if channel == 0 else v)
    return out
    return out


def _rcd_planes(X, R, Gr, Gb, B, scratch, median: bool):
    """RCD of a band X (h, w even, a red site at (0, 0)) whose four planes are R, Gr, Gb, B.

    Every expression is evaluated in the order of float32 operations of the full-resolution
    NumPy formulation (left to right; OpenCV's add, subtract, absdiff, multiply and divide round
    as NumPy's), so the result equals it: RCD's gradients meet ε = 10⁻⁵ in flat regions, where a
    different rounding of a green (6·10⁻⁸) would move a weight by 1 %. A sum that two expressions
    share (ε + |x₋₁ − x₊₁|) is formed once; the gradient |x[k] − x[k − 1]| along an axis on a
    plane serves every step that reads it.

    Returns the (h, w) red, green and blue of the band (scratch buffers), valid :data:`REACH_PX`
    pixels in from every side.
    """
    band = _Band(X, R, Gr, Gb, B, scratch)
    full, d_at, omd_at = _discrimination(band)
    low = _low_pass(band)
    g_at, grad, e_green = _green(band, low, d_at, omd_at)
    pq = _diagonal_discrimination(band)
    colour_at, diff_at = _colour_at_other_sites(band, g_at, pq)
    out_at = _colour_at_greens(band, grad, e_green, colour_at, diff_at, d_at, omd_at)
    return _finish(band, full, g_at, colour_at, diff_at, out_at, median)


def _band_planes(X, scratch):
    """The four planes of a band X (h, w even) that starts on a red site."""
    import cv2

    hq, wq = X.shape[0] // 2, X.shape[1] // 2
    planes = [scratch("rcd:" + key, (hq, wq)) for key in ("R", "Gr", "Gb", "B")]
    cv2.split(X[0::2].reshape(hq, wq, 2), planes[:2])
    cv2.split(X[1::2].reshape(hq, wq, 2), planes[2:])
    return planes


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

    from .scratch import Scratch as _Scratch

    h, w = band.shape
    X = cv2.copyMakeBorder(np.ascontiguousarray(band, dtype=_F32), 0, h % 2, 0, w % 2, cv2.BORDER_REFLECT_101)
    scratch = _Scratch()
    rgb = _rcd_planes(X, *_band_planes(X, scratch), scratch, median)
    return np.stack([c[:h, :w] for c in rgb], axis=-1)


def rcd(mosaic: np.ndarray, cfa: str = "RGGB", *, median: bool = True, band_rows: int = BAND_ROWS,
        workers: int | None = None) -> np.ndarray:
    """RCD of a Bayer mosaic of any phase and size, on row bands on threads.

    The mosaic is mirror-padded about its edge pixels (BORDER_REFLECT_101, which keeps the CFA
    phase) by :data:`REACH_PX` plus the phase shift that puts a red site at the padded band's
    (0, 0); each band of output rows is demosaiced with that much context (made only for the band:
    the padded frame is never formed), so the result does not depend on the cut into bands. As
    :func:`spectral_cam.isp.plane_bands.by_planes`, each thread runs its share of the bands in order,
    reusing its buffers, and ``cv2.merge`` writes the band's three channels into the output.

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

    from .scratch import band_edges, run_bands

    mosaic = np.ascontiguousarray(mosaic, dtype=_F32)
    height, width = mosaic.shape
    ry, rx = divmod(cfa.index("R"), 2)
    pad = REACH_PX
    out = np.empty((height, width, 3), _F32)
    edges, workers = band_edges(height, band_rows, max(1, workers or os.cpu_count() or 1))
    # each band in tiles of about TILE_COLUMNS columns, starting on even columns (the CFA's phase)
    n_tiles = max(1, round(width / TILE_COLUMNS))
    columns = sorted({width * k // n_tiles // 2 * 2 for k in range(n_tiles)} | {width})

    def span(a0: int, a1: int, shift: int, size: int) -> tuple[int, int, int, int]:
        """Padded [p0, p1) (even, starting on the CFA's phase) around [a0, a1) of an axis whose
        red sites are at ``shift`` mod 2: the frame's [first, last) in it and the mirrored ends."""
        lead = pad + shift
        p0 = (a0 + lead - pad) // 2 * 2
        p1 = -(-(a1 + lead + pad) // 2) * 2
        first, last = max(p0 - lead, 0), min(p1 - lead, size)
        return p0 - lead, first, last, (first - (p0 - lead), (p1 - lead) - last)

    def band(y0: int, y1: int, scratch) -> None:
        top, first, last, (above, below) = span(y0, y1, ry, height)
        for x0, x1 in zip(columns, columns[1:]):
            left, cfirst, clast, (before, after) = span(x0, x1, rx, width)
            X = scratch("rcd:padded", (last - first + above + below, clast - cfirst + before + after))
            # mirrored only past the frame's edges
            cv2.copyMakeBorder(mosaic[first:last, cfirst:clast], above, below, before, after,
                               cv2.BORDER_REFLECT_101, dst=X)
            rgb = _rcd_planes(X, *_band_planes(X, scratch), scratch, median)
            rows, cols = slice(y0 - top, y1 - top), slice(x0 - left, x1 - left)
            dst = out[y0:y1, x0:x1]
            if cv2.merge([c[rows, cols] for c in rgb], dst=dst) is not dst:  # pragma: no cover
                raise RuntimeError("cv2.merge did not write into the output")

    run_bands(band, edges, workers)
    return out
