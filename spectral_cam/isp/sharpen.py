"""Unsharp-mask sharpening.

References
----------
.. [1] Gonzalez, R. C., & Woods, R. E. (2018). Digital Image Processing, 4th ed., §3.6
   ("Unsharp masking and highboost filtering").
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["unsharp_mask"]


def unsharp_mask(image: np.ndarray, *, amount: float = 0.5, radius_px: float = 1.0) -> np.ndarray:
    """``out = image + amount · (image − G_σ * image)`` with a Gaussian of σ = radius_px.

    Parameters
    ----------
    image
        (H, W) or (H, W, C) float32 image (any units).
    amount
        Gain of the high-pass detail added back (0 = no change).
    radius_px
        Standard deviation of the Gaussian blur, pixels.

    Returns
    -------
    numpy.ndarray
        float32 image of the same shape, unclipped.

    Raises
    ------
    ConfigError
        For a negative amount or a non-positive radius.

    References
    ----------
    .. [1] Gonzalez, R. C., & Woods, R. E. (2018). Digital Image Processing, 4th ed., §3.6.
    """
    import cv2

    if not amount >= 0:
        raise ConfigError(f"unsharp-mask amount {amount!r} must be >= 0")
    if not radius_px > 0:
        raise ConfigError(f"unsharp-mask radius {radius_px!r} must be > 0 pixels")
    image = np.ascontiguousarray(image, dtype=np.float32)
    if amount == 0:
        return image.copy()
    blurred = cv2.GaussianBlur(image, (0, 0), float(radius_px), borderType=cv2.BORDER_REFLECT_101)
    return image + np.float32(amount) * (image - blurred)
