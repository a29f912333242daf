"""Blur measurement: the diameter of a uniform-disc blur, by second moments or by fitting.

Two independent measurements, each tested against the thin-lens circle of confusion:

- :func:`disc_diameter_from_moments`: second moments add under convolution and a uniform
  disc of diameter c has ⟨r²⟩ = c²/8, so c = √(8·(⟨r²⟩_blurred − ⟨r²⟩_sharp)) whatever the
  source's own size and the pixel aperture (small isolated sources on black);
- :func:`measure_blur`: the disc whose transfer function best turns a sharp image into the
  blurred one over a region (any texture, e.g. a checker plane).

References
----------
.. [1] Bracewell, R. N. (2000). The Fourier Transform and Its Applications, 3rd ed., ch. 8
   (second moments add under convolution).
.. [2] Pentland, A. P. (1987). A new sense for depth of field. IEEE TPAMI 9(4), 523–531.
"""

from __future__ import annotations

import math

import numpy as np

from ..optics import defocus_otf

__all__ = ["second_moment", "disc_diameter_from_moments", "measure_blur"]


def second_moment(image: np.ndarray) -> tuple[float, float, float]:
    """Centroid (column, row) in pixel coordinates (pixel centres at +0.5) and radial
    second moment ⟨r²⟩ (px²) of a non-negative image; NaNs for an all-zero image.

    Examples
    --------
    >>> image = np.zeros((5, 5)); image[2, 2] = 1.0
    >>> second_moment(image)
    (2.5, 2.5, 0.0)
    """
    weights = np.asarray(image, dtype=np.float64)
    total = weights.sum()
    if not total > 0:
        return float("nan"), float("nan"), float("nan")
    rows, cols = np.indices(weights.shape)
    cx = float((weights * (cols + 0.5)).sum() / total)
    cy = float((weights * (rows + 0.5)).sum() / total)
    m2 = float((weights * ((cols + 0.5 - cx) ** 2 + (rows + 0.5 - cy) ** 2)).sum() / total)
    return cx, cy, m2


def disc_diameter_from_moments(blurred: np.ndarray, sharp: np.ndarray | float) -> float:
    """Diameter (px) of the uniform disc that blurred ``sharp`` into ``blurred``.

    Parameters
    ----------
    blurred : numpy.ndarray
        (H, W) image of an isolated source through the lens.
    sharp : numpy.ndarray or float
        The same source unblurred (e.g. through a pinhole of the same geometry), or its
        second moment ⟨r²⟩ in px² when known analytically (a disc of radius r pixels,
        pixel-integrated: r²/2 + 2/12).

    Returns
    -------
    float
        c = √(8·(⟨r²⟩_blurred − ⟨r²⟩_sharp)), pixels (0 when the difference is not positive).

    References
    ----------
    .. [1] Bracewell (2000), ch. 8 (second moments add under convolution).
    """
    reference = float(sharp) if np.ndim(sharp) == 0 else second_moment(sharp)[2]
    difference = second_moment(blurred)[2] - reference
    return float(math.sqrt(8.0 * difference)) if difference > 0 else 0.0


def measure_blur(sharp: np.ndarray, blurred: np.ndarray, mask: np.ndarray, *,
                 max_diameter_px: float) -> float:
    """The disc diameter that best turns the sharp image into the blurred one on a mask.

    Minimises ``Σ_mask (D_c ⊛ sharp − blurred)²`` over c ∈ [0, max], with the disc blur
    D_c applied as its transfer function (:func:`spectral_cam.optics.defocus_otf`) to the sharp image's spectrum
    (edges mirrored): both images already integrate over their pixels (the render's box
    filter), so the disc itself must not be pixel-integrated a second time. A coarse scan,
    then golden-section refinement. For a plane at one depth the thin-lens image is the
    pinhole image convolved with the CoC disc, so c is the measured blur diameter.

    Parameters
    ----------
    sharp, blurred
        (H, W) linear images at the same exposure (e.g. the all-in-focus and the main
        item's clean camera RGB summed over channels).
    mask
        (H, W) bool: the pixels compared (away from occlusion edges and the frame).
    max_diameter_px
        Upper end of the search (pixels).

    Returns
    -------
    float
        Diameter (pixels); NaN when the mask is empty.

    References
    ----------
    .. [1] Pentland, A. P. (1987). A new sense for depth of field. IEEE TPAMI 9(4), 523–531
       (blur estimated by comparing a sharp and a defocused image).
    .. [2] Kiefer, J. (1953). Sequential minimax search for a maximum. Proc. AMS 4(3),
       502–506 (golden-section search).
    """
    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        return float("nan")
    sharp = np.asarray(sharp, dtype=np.float64)
    height, width = sharp.shape
    top = max(float(max_diameter_px), 1.0)
    pad = int(min(math.ceil(top / 2) + 4, max(height, width)))
    padded = np.pad(sharp, pad, mode="symmetric")
    spectrum = np.fft.rfft2(padded)
    radial = np.hypot(np.fft.fftfreq(padded.shape[0])[:, None], np.fft.rfftfreq(padded.shape[1])[None, :])
    target = np.asarray(blurred, dtype=np.float64)[mask]

    def cost(c: float) -> float:
        image = np.fft.irfft2(spectrum * defocus_otf(radial, c), s=padded.shape)[pad:pad + height, pad:pad + width]
        return float(np.sum((image[mask] - target) ** 2))

    grid = np.linspace(0.0, top, 33)
    costs = [cost(c) for c in grid]
    best = int(np.argmin(costs))
    lo, hi = grid[max(best - 1, 0)], grid[min(best + 1, len(grid) - 1)]
    ratio = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
    fa, fb = cost(a), cost(b)
    while hi - lo > 0.01:
        if fa <= fb:
            hi, b, fb = b, a, fa
            a = hi - ratio * (hi - lo)
            fa = cost(a)
        else:
            lo, a, fa = a, b, fb
            b = lo + ratio * (hi - lo)
            fb = cost(b)
    candidates = [(costs[best], float(grid[best])), (fa, a), (fb, b)]
    return float(min(candidates)[1])
