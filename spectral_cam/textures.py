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

__all__ = ["fbm", "abundance_maps", "grain_maps", "height_field", "ground_maps", "MOISTURE_SHARE"]


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


#: The moisture share of a ground (the fraction of its area wet) is drawn per layout in this range.
MOISTURE_SHARE = (0.0, 0.35)


#: The finest octave of the clods' relief (texels of the height map; ~3 px at the look point).
CLOD_FINEST_TEXELS = 4.0


@functools.lru_cache(maxsize=4)
def _ground_cached(size: int, covers: tuple, period_px: float, seed: int, litter: tuple, moisture: float,
                   relief_size: int, clod_period_px: float, slope: float, contrast: float):
    abundances = abundance_maps(size, covers, period_px=period_px, seed=seed, contrast=contrast)
    # the hollows: the same scale as the patches, low where the ground holds water
    hollows = fbm(size, period_px=period_px, octaves=4, seed=seed + 15485863, persistence=0.5)
    if moisture > 0:
        level = np.quantile(hollows, moisture)
        t = np.clip((level - hollows) / 0.8 + 0.5, 0.0, 1.0)
        wetness = t * t * (3 - 2 * t)  # smoothstep: wet in the hollows, drying up their sides
        wetness *= moisture / max(float(wetness.mean()), 1e-12)
        wetness = np.clip(wetness, 0.0, 1.0)
    else:
        wetness = np.zeros((size, size))
    litter_share = abundances[list(litter)].sum(axis=0) if litter else np.zeros((size, size))

    def up(field):
        import cv2

        if relief_size == size:
            return np.asarray(field, dtype=np.float64)
        return cv2.resize(np.asarray(field, dtype=np.float32), (relief_size, relief_size),
                          interpolation=cv2.INTER_LINEAR).astype(np.float64)

    # clods: |fBm| (billow noise): rounded aggregates parted by sharp cracks, down to
    # CLOD_FINEST_TEXELS: an octave of 2 texels (1.4 px) lies past the sensor's Nyquist limit and
    # aliased into the demosaic's false colour (vegetation's soil, high-pass chroma 5.5 → 4.9 ΔC*ab
    # at 4 texels, its luminance detail 5.2 → 5.9)
    octaves = max(1, int(np.floor(np.log2(clod_period_px / CLOD_FINEST_TEXELS))) + 1)
    clods = np.abs(fbm(relief_size, period_px=clod_period_px, octaves=octaves, seed=seed + 32452843,
                       persistence=0.6))
    roughness = (1.0 - up(litter_share)) * (1.0 - 0.7 * up(wetness))  # litter lies flat, wet soil slumps
    clods = roughness * clods
    gy, gx = np.gradient(clods)
    clods *= slope / max(float(np.sqrt(np.mean(gx ** 2 + gy ** 2))), 1e-12)  # rms slope of the clods
    scale = relief_size / size  # texels of the height map per texel of the abundances
    height = clods + scale * (0.02 * period_px * up(hollows) + 0.01 * period_px * up(1.0 - litter_share))
    height -= height.min()
    out = (abundances, wetness.astype(np.float32), height.astype(np.float32))
    for a in out:
        a.setflags(write=False)
    return out


def ground_maps(size: int, covers, *, period_px: float, seed: int = 0, litter=(), moisture: float = 0.0,
                relief_size: int | None = None, clod_period_px: float = 12.0, slope: float = 0.6,
                contrast: float = 2.5):
    """The maps of a natural ground, from one set of fractal fields: the abundances of its
    endmembers (:func:`abundance_maps`), where it is wet, and its relief.

    - ``wetness`` (0–1): smooth patches (a smoothstep) over the lowest ``moisture`` share of a
      *hollows* field (fBm of the patches' period), scaled so its mean is ``moisture``;
    - ``height`` (in texels of the height map): clods — |fBm| of period ``clod_period_px``
      texels and octaves down to 2 texels, rounded aggregates parted by sharp cracks, with an rms
      slope ``slope`` on bare dry soil, flattened under litter (the endmembers ``litter``) and
      by wetness (wet soil slumps) — on the hollows (2 % of the patches' period deep) and soil
      patches raised above litter (1 %).

    Parameters
    ----------
    size : int
        Texels on a side of the abundances and the wetness.
    covers, period_px, seed, contrast
        As :func:`abundance_maps`.
    litter : sequence of int
        Indices of the endmembers that lie flat (leaf litter, dry grass).
    moisture : float
        Mean wetness, 0–1.
    relief_size : int, optional
        Texels on a side of the height map (default ``size``; finer for relief at a finer scale
        than the colours).
    clod_period_px, slope
        Size of the clods (texels of the height map) and their rms slope (rise per run).

    Returns
    -------
    (abundances, wetness, height)
        float32 (K, size, size), (size, size) and (relief_size, relief_size); read-only, cached.
    """
    relief_size = int(relief_size or size)
    return _ground_cached(int(size), tuple(float(c) for c in np.ravel(covers)), float(period_px), int(seed),
                          tuple(int(k) for k in litter), float(moisture), relief_size, float(clod_period_px),
                          float(slope), float(contrast))
