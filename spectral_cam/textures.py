"""Spectral textures: procedural abundance maps that mix measured reflectance spectra, and a
height field for relief.

A textured surface has, at each point, the reflectance R(λ, x) = Σ_k a_k(x)·S_k(λ) of its
endmembers S_k (measured spectra: soils, dry grass, leaf litter), with abundances a_k(x) ≥ 0 that
sum to 1 — the linear mixing model of remote sensing. The abundances come from fractal noise
(OpenSimplex, summed over octaves: fractional Brownian motion, whose power spectrum falls as a
power of frequency as natural textures' do) pushed through a softmax, each endmember's field with
its own seed and a bias that sets how much of the ground it covers.

References
----------
.. [1] Keshava, N., & Mustard, J. F. (2002). Spectral unmixing. IEEE Signal Processing Magazine
   19(1), 44–57 (the linear mixing model).
.. [2] Perlin, K. (2002). Improving noise. ACM Transactions on Graphics 21(3), 681–682; OpenSimplex
   (PyPI ``opensimplex``: gradient noise without Perlin's axis artefacts).
.. [3] Mandelbrot, B. B., & Van Ness, J. W. (1968). Fractional Brownian motions, fractional
   noises and applications. SIAM Review 10(4), 422–437.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = ["fbm", "abundance_maps", "grain_maps", "height_field"]


@functools.lru_cache(maxsize=32)
def _fbm_cached(size: int, period_px: float, octaves: int, seed: int, persistence: float) -> np.ndarray:
    from opensimplex import OpenSimplex

    noise = OpenSimplex(seed=seed)
    field = np.zeros((size, size), np.float64)
    amplitude, frequency = 1.0, 1.0 / period_px
    grid = np.arange(size, dtype=np.float64)
    for octave in range(octaves):
        offset = 97.31 * (octave + 1)  # octaves from different places of the noise
        field += amplitude * noise.noise2array(grid * frequency + offset, grid * frequency - offset)
        amplitude *= persistence
        frequency *= 2.0
    field = (field - field.mean()) / max(field.std(), 1e-12)
    field.setflags(write=False)
    return field


def fbm(size: int, *, period_px: float, octaves: int = 6, seed: int = 0, persistence: float = 0.55) -> np.ndarray:
    """A ``size`` × ``size`` field of fractional Brownian motion, zero mean and unit variance:
    OpenSimplex noise of period ``period_px`` and ``octaves`` − 1 finer octaves, each half the
    period and ``persistence`` × the amplitude of the last.

    Examples
    --------
    >>> field = fbm(64, period_px=16.0, seed=1)
    >>> field.shape, round(float(field.mean()), 6), round(float(field.std()), 6)
    ((64, 64), 0.0, 1.0)
    """
    return _fbm_cached(int(size), float(period_px), int(octaves), int(seed), float(persistence))


def abundance_maps(size: int, covers, *, period_px: float, seed: int = 0, contrast: float = 2.5) -> np.ndarray:
    """Abundances of K endmembers (:func:`_abundances_cached`, which says how; cached, read-only)."""
    return _abundances_cached(int(size), tuple(float(c) for c in np.ravel(covers)), float(period_px), int(seed),
                              float(contrast))


@functools.lru_cache(maxsize=8)
def _abundances_cached(size: int, covers: tuple, period_px: float, seed: int, contrast: float) -> np.ndarray:
    """Abundances of K endmembers over a ``size`` × ``size`` texture: a softmax of K independent
    fBm fields, ``a_k ∝ exp(contrast·f_k + ln(cover_k))``, so each point is a mixture, patches of
    one endmember dominate where its field is high, and ``covers`` set the endmembers' shares.

    Parameters
    ----------
    size : int
        Texels on a side.
    covers : sequence of float
        Relative shares of the endmembers (> 0).
    period_px : float
        Period of the coarsest octave (texels): the size of the patches.
    seed : int
        Seed of the first field (the others follow).
    contrast : float
        How sharply one endmember dominates (0: every point the same mixture).

    Returns
    -------
    numpy.ndarray
        float32 (K, size, size), each texel's abundances ≥ 0 summing to 1.

    References
    ----------
    .. [1] Keshava, N., & Mustard, J. F. (2002). IEEE Signal Processing Magazine 19(1), 44–57.
    """
    covers = np.asarray(covers, dtype=np.float64)
    if covers.ndim != 1 or covers.size < 1 or not np.all(covers > 0):
        raise ValueError(f"covers must be positive shares, one per endmember; got {covers!r}")
    logits = np.stack([contrast * fbm(size, period_px=period_px, seed=seed + 7919 * k) + np.log(c)
                       for k, c in enumerate(covers)])
    logits -= logits.max(axis=0, keepdims=True)
    weights = np.exp(logits)
    maps = (weights / weights.sum(axis=0, keepdims=True)).astype(np.float32)
    maps.setflags(write=False)
    return maps


def grain_maps(size: int, covers, *, period_px: float, stretch: float, seed: int = 0,
               contrast: float = 2.5) -> np.ndarray:
    """Abundances like :func:`abundance_maps`, stretched ``stretch`` times along the rows: the
    long streaks of wood grain (the fields drawn on size/stretch rows, resampled bilinearly)."""
    import cv2

    short = max(2, int(round(size / stretch)))
    maps = abundance_maps(size, covers, period_px=period_px, seed=seed, contrast=contrast)
    out = np.stack([cv2.resize(np.ascontiguousarray(m[:short]), (size, size), interpolation=cv2.INTER_LINEAR)
                    for m in maps])
    out /= out.sum(axis=0, keepdims=True)
    return out.astype(np.float32)


def height_field(size: int, *, period_px: float, seed: int = 0) -> np.ndarray:
    """A relief height field in [0, 1] (fBm, rescaled), for a bump map."""
    field = fbm(size, period_px=period_px, octaves=5, seed=seed + 104729, persistence=0.6)
    low, high = field.min(), field.max()
    return ((field - low) / max(high - low, 1e-12)).astype(np.float32)
