"""Black-level subtraction and normalisation of the raw mosaic.

References
----------
.. [1] Adobe (2023). Digital Negative (DNG) Specification 1.7.1.0, "Mapping Raw Values
   to Linear Reference Values" (BlackLevel, WhiteLevel).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["normalise"]


def normalise(mosaic: np.ndarray, *, black_level, white_level: float) -> np.ndarray:
    """Map raw digital numbers to linear values with black at 0 and white at 1.

    ``x = (DN − black) / (white − black)``, kept unclipped so that noise below the black
    level stays unbiased for the denoiser (clip after denoising if needed).

    Parameters
    ----------
    mosaic
        (H, W) raw DN (any integer or float dtype).
    black_level
        Black level in DN: a scalar, or an array tiled over the mosaic (the DNG
        BlackLevel with BlackLevelRepeatDim, e.g. (2, 2) per CFA site).
    white_level
        DNG WhiteLevel, DN (the fully saturated encoding level).

    Returns
    -------
    numpy.ndarray
        (H, W) float32 linear values; 1.0 = white level.

    Raises
    ------
    ConfigError
        If the white level does not exceed the black level.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, "Mapping Raw Values to Linear
       Reference Values".
    """
    mosaic = np.asarray(mosaic)
    if mosaic.ndim != 2 and not (mosaic.ndim == 3 and mosaic.shape[2] == 3):
        raise ConfigError(f"a raw mosaic must be 2-D (H, W), or (H, W, 3) for a linear raw; got shape {mosaic.shape}")
    if not (np.issubdtype(mosaic.dtype, np.integer) or np.issubdtype(mosaic.dtype, np.floating)):
        raise ConfigError(f"a raw mosaic must hold integer or floating-point numbers (DN); got dtype {mosaic.dtype}")
    if mosaic.size == 0:
        raise ConfigError("the raw mosaic is empty; it needs at least 2×2 pixels")
    if np.issubdtype(mosaic.dtype, np.floating) and not np.isfinite(mosaic).all():
        bad = np.argwhere(~np.isfinite(mosaic))
        raise ConfigError(f"the raw mosaic holds {len(bad)} NaN or infinite values (first at row {bad[0][0]}, "
                          f"column {bad[0][1]}); raw values must be finite DN")
    black = np.asarray(black_level, dtype=np.float32)
    if black.ndim == 2 and mosaic.ndim == 2:
        reps = (-(-mosaic.shape[0] // black.shape[0]), -(-mosaic.shape[1] // black.shape[1]))
        black = np.tile(black, reps)[: mosaic.shape[0], : mosaic.shape[1]]
    elif black.ndim == 1 and mosaic.ndim == 3 and black.shape == (3,):
        pass  # one level per colour of a linear raw: broadcast over the last axis
    elif black.ndim != 0:
        raise ConfigError(f"black_level must be a number, a 2-D repeat pattern or one per colour of a linear "
                          f"raw; got shape {black.shape}")
    if not float(white_level) > float(np.max(black)):
        raise ConfigError(f"white_level {white_level!r} must exceed the black level {float(np.max(black))!r}")
    # per site, as the DNG spec maps raw values: (DN − black_site) / (white − black_site)
    out = mosaic.astype(np.float32) - black
    out /= np.float32(white_level) - black
    return out
