"""A pixel's radiance robust to fireflies, from the means of K independent passes.

A firefly is a pixel whose few samples found a rare, very bright path (a caustic through glass,
a glint off metal seen through a diffuse bounce): one pass's mean is far above the others'. The
plain mean keeps it (unbiased, but it takes thousands of samples to average away); the median
of the K pass means (median of means, MoN) drops it at the price of a downward bias wherever the
per-sample distribution is skewed. The adaptive rule (after Buisine et al. 2021, who gate MoN
by the Gini coefficient of the means) uses the plain mean where the pass means agree — a Gini
coefficient G ≤ :data:`GINI_THRESHOLD` — and the median of means only where one or two passes
stand out, so the estimate stays unbiased on smooth and moderately noisy pixels.

The passes are ranked by their band sum, and a pixel's estimate is always a scaled average of
whole pass spectra (no band-by-band mixing). Where the median is taken, its band sum is the
middle passes', its spectral shape the mean of every pass ranked at or below the upper median
(K/2 + 1 of K): the median trusts those, and the middle 2 alone carry √(5/2) ≈ 1.6× the chroma
noise of 5 independent passes (each path carries 4 wavelengths, so a few caustic paths make a
pass strongly coloured).

A caustic found once in a pass that is 3–8× its others (Gini 0.2–0.4 for K = 8) escapes the
Gini gate and, carrying few wavelengths, lands as a coloured speckle 10–20 ΔE*ab off its
neighbours: the tabletop's sun-lit ground beside its glossy objects. :func:`lone_outlier` finds
it with a leave-one-out prediction interval (Student's t on the other K − 1 pass means) and the
pixel takes the mean of the other K − 1 passes.

What the median removes is real light, only found too rarely: the glass sphere's caustic is a
field of rare paths around a bright core, and the median alone dropped 8 % of the frame's light
there. :func:`spread_removed_light` gives it back, in the spirit of Zirr et al. (2018), who
re-weight rare bright samples instead of discarding them: each pixel's removed light (the mean
minus the estimate) is spread by a Gaussian just wide enough that its peak adds at most
:data:`SPREAD_PEAK` of the light already around it, so the frame keeps the mean's light
(unbiased in total), a caustic's rare paths become its glow, and no pixel stands out.

References
----------
.. [1] Buisine, J., Delepoulle, S., & Renaud, C. (2021). Firefly removal in Monte Carlo
   rendering with adaptive Median of meaNs. Eurographics Symposium on Rendering (EGSR),
   Digital Library Only track, 121–132.
.. [2] Jerrum, M. R., Valiant, L. G., & Vazirani, V. V. (1986). Random generation of
   combinatorial structures from a uniform distribution. Theor. Comput. Sci. 43, 169–188
   (the median-of-means estimator).
.. [3] Gini, C. (1912). Variabilità e mutabilità (the Gini coefficient).
.. [4] Hahn, G. J., & Meeker, W. Q. (1991). Statistical Intervals: A Guide for Practitioners.
   Wiley (the prediction interval for one further observation of a normal sample).
.. [5] Wilkie, A., Nawaz, S., Droske, M., Weidlich, A., & Hanika, J. (2014). Hero wavelength
   spectral sampling. Computer Graphics Forum 33(4), 123–131 (4 wavelengths per path, as
   Mitsuba 3's spectral variants sample).
.. [6] Zirr, T., Hanika, J., & Dachsbacher, C. (2018). Re-weighting firefly samples for improved
   finite-sample Monte Carlo estimates. Computer Graphics Forum 37(6), 410–421.
"""

from __future__ import annotations

import numpy as np

from ..scene import RENDER_ESTIMATORS

__all__ = ["GINI_THRESHOLD", "OUTLIER_FALSE_ALARM", "SPREAD_PEAK", "SPREAD_SCALES_PX", "gini", "lone_outlier",
           "adaptive_median_of_means", "spread_removed_light", "ESTIMATORS"]

#: Above this Gini coefficient of a pixel's K pass means, its estimate is the median of means.
#: Gaussian noise of relative standard deviation c per pass gives G ≈ 0.56·c·(K−1)/K; one pass
#: holding all the light gives (K−1)/K (0.875 for K = 8). 0.4 leaves pixels with c below ~0.8
#: to the unbiased mean (chosen by measurement: docs/bench/fireflies.csv).
GINI_THRESHOLD = 0.4

#: False-alarm rate per pixel of :func:`lone_outlier` for normal pass means: its t threshold is
#: 15.3 for K = 8 (Bonferroni over the K passes), 316 for K = 4 (never in practice), 7.6 for
#: K = 16. Chosen by measurement on the tabletop at its defaults (seeds 0–2 against 1024 spp):
#: 2e-5 flags 0.2 % of the pixels, 1e-4 0.5 % for little more gain.
OUTLIER_FALSE_ALARM = 2e-5

#: :func:`spread_removed_light`: the most a pixel's spread light adds to the light around it
#: (a fraction). Chosen on the glass sphere at its defaults against 1024 spp (bench_fireflies):
#: 0.25 leaves its caustic field a smooth glow; 1.0 leaves 3–5 px blobs where single paths landed.
SPREAD_PEAK = 0.25
#: Gaussian standard deviations (px) the removed light is spread with: each pixel's the smallest
#: that meets :data:`SPREAD_PEAK`, the widest where even that one does not.
SPREAD_SCALES_PX = (1.0, 2.0, 4.0, 8.0, 16.0, 32.0)
#: The neighbourhood (Gaussian σ, px) whose light a spread is measured against.
_AROUND_PX = 4.0

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


def lone_outlier(score: np.ndarray, *, false_alarm: float = OUTLIER_FALSE_ALARM) -> np.ndarray:
    """Where the brightest of K pass values lies outside the prediction interval of the other K − 1.

    ``t = (x_max − m) / (s·√(1 + 1/(K − 1)))`` with m, s the mean and standard deviation of the
    other K − 1 values follows Student's t with K − 2 degrees of freedom for normal pass means;
    the pass is an outlier where t exceeds its ``1 − false_alarm/K`` quantile (Bonferroni over
    the K candidates).

    Parameters
    ----------
    score : numpy.ndarray
        (K, ...) pass values (a pixel's band sum per pass), K ≥ 3.
    false_alarm : float
        Share of pixels with normal pass means that are flagged.

    Returns
    -------
    numpy.ndarray
        Boolean (...) mask.

    References
    ----------
    .. [1] Hahn, G. J., & Meeker, W. Q. (1991). Statistical Intervals. Wiley.

    Examples
    --------
    >>> import numpy as np
    >>> lone_outlier(np.array([[1.0, 1.0], [1.1, 1.1], [0.9, 0.9], [1.0, 1.0], [1.05, 1.05],
    ...                        [0.95, 0.95], [1.0, 1.0], [1.3, 4.0]])).tolist()
    [False, True]
    """
    from scipy.special import stdtrit  # Student's t quantile (lighter to import than scipy.stats)

    x = np.sort(np.asarray(score, dtype=np.float64), axis=0)
    k = x.shape[0]
    rest = x[:-1]
    mean = rest.mean(axis=0)
    # a floor at float32 resolution: passes equal but for rounding are not an outlier
    spread = np.maximum(rest.std(axis=0, ddof=1), 1e-6 * np.abs(mean)) * np.sqrt(1.0 + 1.0 / (k - 1))
    excess = x[-1] - mean
    critical = -stdtrit(k - 2, false_alarm / k)  # the upper quantile, from the accurate lower tail
    return (excess > 0) & (excess > critical * spread)


def adaptive_median_of_means(passes: np.ndarray, *, threshold: float = GINI_THRESHOLD,
                             false_alarm: float = OUTLIER_FALSE_ALARM) -> tuple[np.ndarray, float]:
    """The adaptive median-of-means estimate of K equal passes.

    Per pixel, passes ranked by band sum: where their Gini coefficient exceeds ``threshold``,
    the median's band sum with the spectral shape of the passes ranked at or below the upper
    median; else, where the brightest pass is a :func:`lone_outlier`, the mean of the other
    K − 1; else the mean.

    Parameters
    ----------
    passes : numpy.ndarray
        (K, H, W, C) float32 pass means (equal samples each), K ≥ 3.
    threshold : float
        Gini coefficient above which a pixel takes the median of means.
    false_alarm : float
        :func:`lone_outlier`'s false-alarm rate (0 turns the test off).

    Returns
    -------
    (numpy.ndarray, float)
        (H, W, C) float32 estimate, and the share of pixels that did not take the plain mean.

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
        out[rows, cols] = _median_with_lower_shape(stack[:, rows, cols], score[:, rows, cols])
    lone = ~flagged & lone_outlier(score, false_alarm=false_alarm) if false_alarm > 0 else np.zeros_like(flagged)
    rows, cols = np.nonzero(lone)
    if rows.size:
        top = np.argmax(score[:, rows, cols], axis=0)
        out[rows, cols] = (stack[:, rows, cols].sum(axis=0) - stack[top, rows, cols]) / (k - 1)
    return out, float((flagged | lone).mean())


def _median_with_lower_shape(spectra: np.ndarray, score: np.ndarray) -> np.ndarray:
    """(n, C): the band sum of the middle-ranked passes of (K, n, C) ``spectra``, in the
    spectral shape of the mean of the passes ranked at or below the upper median."""
    k = spectra.shape[0]
    order = np.argsort(score, axis=0, kind="stable")  # (K, n)
    columns = np.arange(score.shape[1])[None, :]
    middle = score[order[(k - 1) // 2: k // 2 + 1], columns].mean(axis=0)  # the median pass or the middle two
    shape = spectra[order[: k // 2 + 1], columns].mean(axis=0)  # (n, C)
    total = shape.sum(axis=-1, dtype=np.float64)
    scale = np.divide(middle, total, out=np.zeros_like(total), where=total > 0)
    return (shape * scale[:, None]).astype(np.float32)


def spread_removed_light(mean: np.ndarray, estimate: np.ndarray, *, peak: float = SPREAD_PEAK) -> np.ndarray:
    """Give back the light a robust estimate removed, spread so that no pixel stands out.

    The removed light of a pixel is ``mean − estimate`` (every channel). Its band sum E is spread
    by a normalised Gaussian of the smallest σ in :data:`SPREAD_SCALES_PX` with
    ``E / (2π σ²) ≤ peak · A``, A the light around it (the estimate's band sum, Gaussian-weighted
    over :data:`_AROUND_PX` px): a firefly on a dark floor spreads wide and faint, the rare
    paths of a caustic's field overlap into its glow. Mirrored at the frame's edges, so each
    channel's sum over the frame is the mean's (to float rounding, and but for the few
    negative values clipped to 0 where a channel's removed light was negative).

    Parameters
    ----------
    mean : numpy.ndarray
        (H, W, C) plain mean of the passes.
    estimate : numpy.ndarray
        (H, W, C) robust estimate of the same passes (:func:`adaptive_median_of_means`).
    peak : float
        Largest fraction of the surrounding light one pixel's spread adds at its centre.

    Returns
    -------
    numpy.ndarray
        (H, W, C) float32, non-negative.

    References
    ----------
    .. [1] Zirr, T., Hanika, J., & Dachsbacher, C. (2018). Computer Graphics Forum 37(6), 410–421.

    Examples
    --------
    One pixel's firefly removed from a flat field comes back spread, the total kept:

    >>> import numpy as np
    >>> mean = np.ones((64, 64, 1), np.float32)
    >>> mean[32, 32] = 101.0
    >>> estimate = np.ones_like(mean)
    >>> out = spread_removed_light(mean, estimate)
    >>> round(float(out.sum() / mean.sum()), 4), bool(out.max() < 1.0 + SPREAD_PEAK)
    (1.0, True)
    """
    if not (isinstance(peak, (int, float)) and peak > 0):
        raise ValueError(f"peak = {peak!r}: give the largest added fraction of the surrounding light, > 0")
    import cv2

    estimate = np.asarray(estimate, np.float32)
    removed = np.asarray(mean, np.float32) - estimate
    moved = (removed != 0).any(axis=-1)
    if not moved.any():
        return estimate
    level = estimate.sum(axis=-1, dtype=np.float32)
    around = cv2.GaussianBlur(level, (0, 0), _AROUND_PX, borderType=cv2.BORDER_REFLECT)
    around = np.maximum(around, 1e-3 * max(float(np.percentile(level, 99)), np.finfo(np.float32).tiny))
    width = np.sqrt(np.maximum(removed.sum(axis=-1), 0.0) / (2.0 * np.pi * peak * around))
    which = np.minimum(np.searchsorted(np.asarray(SPREAD_SCALES_PX), width), len(SPREAD_SCALES_PX) - 1)
    out = estimate.copy()
    for index, sigma in enumerate(SPREAD_SCALES_PX):
        sources = moved & (which == index)
        if sources.any():
            _add_spread(out, removed, sources, sigma)
    return np.maximum(out, 0.0, out=out)


def _add_spread(out: np.ndarray, removed: np.ndarray, sources: np.ndarray, sigma: float) -> None:
    """Add the ``sources`` pixels' ``removed`` light blurred by a Gaussian of ``sigma`` px to
    ``out``, over the sources' bounding box widened by OpenCV's kernel radius (4σ: nothing reaches
    past it) and mirrored only at the frame's own edges (BORDER_REFLECT keeps the sum for a
    symmetric kernel)."""
    import cv2

    rows, cols = np.nonzero(sources)
    reach = int(np.ceil(4 * sigma)) + 1
    top, left = max(rows.min() - reach, 0), max(cols.min() - reach, 0)
    bottom, right = min(rows.max() + reach + 1, out.shape[0]), min(cols.max() + reach + 1, out.shape[1])
    inside = sources[top:bottom, left:right, None]
    box = np.where(inside, removed[top:bottom, left:right], np.float32(0.0)).astype(np.float32, copy=False)
    for channel in range(box.shape[-1]):
        out[top:bottom, left:right, channel] += cv2.GaussianBlur(box[..., channel], (0, 0), sigma,
                                                                 borderType=cv2.BORDER_REFLECT)
