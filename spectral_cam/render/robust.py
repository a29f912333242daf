"""Fireflies: a robust estimate of a pixel's radiance from the means of K independent passes.

A firefly is a pixel whose few samples found a rare, very bright path (a caustic through glass,
a glint off metal seen through a diffuse bounce): one pass's mean is far above the others'. The
plain mean keeps it (unbiased, but it takes thousands of samples to average away); the median
of the K pass means (median of means, MoN) drops it at the price of a downward bias wherever the
per-sample distribution is skewed. The adaptive rule (after Buisine et al. 2021, who gate MoN
by the Gini coefficient of the means) uses the plain mean where the pass means agree — a Gini
coefficient G ≤ :data:`GINI_THRESHOLD` — and the median of means only where one or two passes
stand out, so the estimate stays unbiased on smooth and moderately noisy pixels.

The passes are ranked by their band sum, and the selected passes' whole spectra are averaged,
so the result is always a spectrum that some passes rendered (no band-by-band mixing).

References
----------
.. [1] Buisine, J., Delepoulle, S., & Renaud, C. (2021). Firefly removal in Monte Carlo
   rendering with adaptive Median of meaNs. Eurographics Symposium on Rendering (EGSR),
   Digital Library Only track, 121–132.
.. [2] Jerrum, M. R., Valiant, L. G., & Vazirani, V. V. (1986). Random generation of
   combinatorial structures from a uniform distribution. Theor. Comput. Sci. 43, 169–188
   (the median-of-means estimator).
.. [3] Gini, C. (1912). Variabilità e mutabilità (the Gini coefficient).
"""

from __future__ import annotations

import numpy as np

from ..scene import RENDER_ESTIMATORS

__all__ = ["GINI_THRESHOLD", "gini", "adaptive_median_of_means", "ESTIMATORS"]

#: Above this Gini coefficient of a pixel's K pass means, its estimate is the median of means.
#: Gaussian noise of relative standard deviation c per pass gives G ≈ 0.56·c·(K−1)/K; one pass
#: holding all the light gives (K−1)/K (0.875 for K = 8). 0.4 leaves pixels with c below ~0.8
#: to the unbiased mean (chosen by measurement: docs/bench/fireflies.csv).
GINI_THRESHOLD = 0.4

#: render.estimator names (defined with the scene's other keys).
ESTIMATORS = RENDER_ESTIMATORS


def gini(values: np.ndarray, axis: int = 0) -> np.ndarray:
    """Gini coefficient of non-negative values along ``axis``:
    ``G = Σ_i Σ_j |x_i − x_j| / (2·K²·mean)`` (0 where all are zero).

    Examples
    --------
    >>> import numpy as np
    >>> float(gini(np.array([1.0, 1.0, 1.0, 1.0]))), float(gini(np.array([0.0, 0.0, 0.0, 4.0])))
    (0.0, 0.75)
    """
    x = np.sort(np.asarray(values, dtype=np.float64), axis=axis)
    k = x.shape[axis]
    shape = [1] * x.ndim
    shape[axis] = k
    ranks = np.arange(1, k + 1, dtype=np.float64).reshape(shape)
    total = x.sum(axis=axis)
    weighted = (ranks * x).sum(axis=axis)
    with np.errstate(invalid="ignore", divide="ignore"):
        g = 2.0 * weighted / (k * total) - (k + 1.0) / k
    return np.where(total > 0, g, 0.0)


def adaptive_median_of_means(passes: np.ndarray, *, threshold: float = GINI_THRESHOLD
                             ) -> tuple[np.ndarray, float]:
    """The adaptive median-of-means estimate of K equal passes.

    Parameters
    ----------
    passes : numpy.ndarray
        (K, H, W, C) float32 pass means (equal samples each), K ≥ 3.
    threshold : float
        Gini coefficient above which a pixel takes the median of means.

    Returns
    -------
    (numpy.ndarray, float)
        (H, W, C) float32 estimate, and the share of pixels that took the median of means.

    References
    ----------
    .. [1] Buisine, J., Delepoulle, S., & Renaud, C. (2021). EGSR 2021, 121–132.

    Examples
    --------
    Eight passes agree on a pixel but for one bright outlier; the estimate drops it:

    >>> import numpy as np
    >>> passes = np.full((8, 1, 2, 1), 1.0, np.float32)
    >>> passes[3, 0, 1, 0] = 100.0
    >>> estimate, share = adaptive_median_of_means(passes)
    >>> estimate[0, :, 0].tolist(), share
    ([1.0, 1.0], 0.5)
    """
    stack = np.asarray(passes)
    k = stack.shape[0]
    if stack.ndim != 4 or k < 3:
        raise ValueError(f"adaptive_median_of_means needs (K >= 3, H, W, C) passes; got shape {stack.shape}")
    out = stack.mean(axis=0, dtype=np.float32)
    score = stack.sum(axis=-1, dtype=np.float64)  # (K, H, W): each pass's band sum ranks it
    flagged = gini(score, axis=0) > threshold
    rows, cols = np.nonzero(flagged)
    if rows.size:
        order = np.argsort(score[:, rows, cols], axis=0)  # (K, n)
        middle = order[(k - 1) // 2: k // 2 + 1]  # the median pass (odd K) or the two middle ones
        picked = stack[middle, rows[None, :], cols[None, :]]  # (1 or 2, n, C)
        out[rows, cols] = picked.mean(axis=0)
    return out, float(flagged.mean())
