"""Menon, Andriani & Calvagno (2007): demosaicing with directional filtering and a posteriori
decision (DDFAPD), with the paper's refining step, in float32 with OpenCV filters.

The algorithm is colour-demosaicing's (Mansencal et al.), step for step, rewritten so that a
24 MP frame develops in well under a second: every convolution is a small OpenCV filter on
the whole frame, every "where this CFA site" is a strided slice instead of a full-frame mask,
and ``colour`` (whose import loads matplotlib, ~1 s) is never imported. Borders: the mosaic
is mirror-padded once (about the edge pixel, which keeps the CFA phase) by more than the
algorithm's reach, so every output pixel is computed from the same neighbourhood shape;
colour-demosaicing instead mirrors at each step, so the two differ in the outermost pixels
only (tests/isp/test_menon2007.py checks the interior against colour-demosaicing to float32
rounding).

Steps, with D the mosaic and R, G, B the planes being filled:

1. Green at red and blue sites, horizontally and vertically: D filtered by
   [−¼, ½, ½, ½, −¼] along the row or the column.
2. The decision: colour differences C = D − G along each direction, their gradients
   |C(x) − C(x+2)| summed over the paper's 5×5 window; the direction with the smaller sum wins
   (M = 1: horizontal).
3. Red and blue at green sites from the neighbouring colour differences (bilinear in R − G,
   B − G); red at blue sites and blue at red sites from R − B along the chosen direction.
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
#: How far (pixels) an output pixel's value reaches into the mosaic, rounded up to even:
#: green 2, gradients 2 more, the 5×5 window 2, then four 1-pixel steps, plus margin.
REACH_PX = 12

_GREEN_FIR = np.array([[-0.25, 0.5, 0.5, 0.5, -0.25]], _F32)
_PAIR = np.array([[0.5, 0.0, 0.5]], _F32)
_MEAN3 = np.full((1, 3), 1.0 / 3.0, _F32)
# colour-demosaicing convolves the gradients with this kernel (scipy.ndimage.convolve, zeros
# outside); OpenCV's filter2D correlates, so it gets the kernel flipped both ways
_WINDOW = np.array([[0, 0, 1, 0, 1],
                    [0, 0, 0, 1, 0],
                    [0, 0, 3, 0, 3],
                    [0, 0, 0, 1, 0],
                    [0, 0, 1, 0, 1]], _F32)


def _filter(image: np.ndarray, kernel: np.ndarray, out: np.ndarray, *, border=None) -> np.ndarray:
    """cv2.filter2D (a correlation) into a preallocated float32 buffer: a fresh 100 MB output
    per call costs as much in page faults as the filtering itself."""
    import cv2

    border = cv2.BORDER_REFLECT_101 if border is None else border
    return cv2.filter2D(image, cv2.CV_32F, kernel, dst=out, borderType=border)


_GREEN_FIR_V = np.ascontiguousarray(_GREEN_FIR.T)
_PAIR_V = np.ascontiguousarray(_PAIR.T)
_MEAN3_V = np.ascontiguousarray(_MEAN3.T)


def _select(horizontal: np.ndarray, across: np.ndarray, down: np.ndarray) -> np.ndarray:
    """``across`` where ``horizontal`` (a 0/1 float32 plane) else ``down``, by arithmetic
    (np.where on strided planes is ~10× slower)."""
    return down + horizontal * (across - down)


def _sites(cfa: str) -> dict[str, tuple[slice, slice]]:
    """Strided slices of the four CFA sites: R, B, green in red rows (Gr) and in blue rows (Gb)."""
    ry, rx = divmod(cfa.index("R"), 2)
    by, bx = divmod(cfa.index("B"), 2)

    def at(y, x):
        return slice(y, None, 2), slice(x, None, 2)

    return {"R": at(ry, rx), "B": at(by, bx), "Gr": at(ry, 1 - rx), "Gb": at(by, 1 - bx)}


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
    pad = REACH_PX
    # pad to an even size too, so every site slice has the same shape
    d = cv2.copyMakeBorder(np.ascontiguousarray(mosaic, dtype=_F32), pad, pad + height % 2, pad, pad + width % 2,
                           cv2.BORDER_REFLECT_101)
    s = _sites(cfa)
    across, down = np.empty_like(d), np.empty_like(d)  # filter outputs, reused throughout

    # 1. directional green at red and blue sites (green sites keep their sample)
    g_h, g_v = d.copy(), d.copy()
    _filter(d, _GREEN_FIR, across)
    _filter(d, _GREEN_FIR_V, down)
    for site in (s["R"], s["B"]):
        g_h[site], g_v[site] = across[site], down[site]

    # 2. decision from the colour-difference gradients over the 5×5 window
    np.subtract(d, g_h, out=across)  # C_H: zero at green sites
    np.subtract(d, g_v, out=down)
    grad_h, grad_v = np.zeros_like(d), np.zeros_like(d)
    np.subtract(across[:, :-2], across[:, 2:], out=grad_h[:, :-2])
    np.subtract(down[:-2, :], down[2:, :], out=grad_v[:-2, :])
    np.abs(grad_h, out=grad_h)
    np.abs(grad_v, out=grad_v)
    _filter(grad_h, np.ascontiguousarray(_WINDOW[::-1, ::-1]), across, border=cv2.BORDER_CONSTANT)
    _filter(grad_v, np.ascontiguousarray(_WINDOW.T[::-1, ::-1]), down, border=cv2.BORDER_CONSTANT)
    del grad_h, grad_v
    # M = 1 (horizontal) where the vertical gradients sum to at least the horizontal ones
    horizontal = {name: (down[s[name]] >= across[s[name]]).astype(_F32) for name in ("R", "B")}
    green = d.copy()
    for name in ("R", "B"):
        green[s[name]] = _select(horizontal[name], g_h[s[name]], g_v[s[name]])
    red, blue = g_h, g_v  # reuse the buffers
    del g_h, g_v
    buffers = (across, down)

    # 3. red and blue at green sites from R − G, B − G; then R at B and B at R from R − B
    _fill_at_greens(d, green, red, blue, s, _PAIR, _PAIR_V, buffers)
    _fill_r_at_b_and_b_at_r(d, red, blue, horizontal, s, _PAIR, _PAIR_V, buffers, refining=False)

    if refining_step:
        # 4a. green at red and blue sites from R − G and B − G averaged along the direction
        for colour_plane, name in ((red, "R"), (blue, "B")):
            site = s[name]
            difference = np.subtract(colour_plane, green, out=across)
            left_right = _filter(difference, _MEAN3, down)[site]
            up_down = _filter(difference, _MEAN3_V, across)[site]  # difference no longer needed
            green[site] = d[site] - _select(horizontal[name], left_right, up_down)
        # 4b. red and blue at green sites again; 4c. R − B at red and blue sites again
        _fill_at_greens(d, green, red, blue, s, _PAIR, _PAIR_V, buffers)
        _fill_r_at_b_and_b_at_r(d, red, blue, horizontal, s, _MEAN3, _MEAN3_V, buffers, refining=True)

    out = np.empty((height, width, 3), _F32)
    crop = (slice(pad, pad + height), slice(pad, pad + width))
    for c, plane in enumerate((red, green, blue)):
        out[..., c] = plane[crop]
    return out


def _fill_at_greens(d, green, red, blue, s, kernel, kernel_v, buffers):
    """Red and blue at both green sites: G plus the neighbouring (R − G) or (B − G)."""
    across, down = buffers
    red[s["R"]], blue[s["B"]] = d[s["R"]], d[s["B"]]
    difference = np.subtract(d, green, out=down)  # R − G at red sites, B − G at blue sites
    _filter(difference, kernel, across)
    # green in a red row: red neighbours left/right, blue neighbours above/below
    np.add(green[s["Gr"]], across[s["Gr"]], out=red[s["Gr"]])
    np.add(green[s["Gb"]], across[s["Gb"]], out=blue[s["Gb"]])
    _filter(difference.copy(), kernel_v, down)
    np.add(green[s["Gr"]], down[s["Gr"]], out=blue[s["Gr"]])
    np.add(green[s["Gb"]], down[s["Gb"]], out=red[s["Gb"]])


def _fill_r_at_b_and_b_at_r(d, red, blue, horizontal, s, kernel, kernel_v, buffers, *, refining):
    """Red at blue sites and blue at red sites from R − B along the chosen direction.

    Before refining the kernel is [½, 0, ½] over the green neighbours; in the refining step
    it is the 3-pixel mean, which includes the site's own R − B estimate."""
    across, down = buffers
    difference = red - blue
    if not refining:
        difference[s["R"]] = 0.0  # unused by the [½, 0, ½] kernel at these sites
        difference[s["B"]] = 0.0
    _filter(difference, kernel, across)
    _filter(difference, kernel_v, down)
    b, r = s["B"], s["R"]
    red[b] = d[b] + _select(horizontal["B"], across[b], down[b])
    blue[r] = d[r] - _select(horizontal["R"], across[r], down[r])
