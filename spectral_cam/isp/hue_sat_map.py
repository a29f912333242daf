"""The ISP's application of a DNG hue/saturation/value map (ProfileHueSatMap): the non-linear
colour correction an Adobe-path develop applies after the camera → XYZ matrix.

The map itself — its data model, DNG encoding and decoding, the ProPhoto RGB and hexcone HSV it is
defined in — is part of the DNG camera profile and lives in :mod:`spectral_cam.raw.hue_sat_map`,
below both the sensor (which fits it) and the ISP, so that nothing below the ISP imports the ISP.
Its names are re-exported here, so ``from spectral_cam.isp.hue_sat_map import HueSatMap`` keeps
working; new code below the ISP imports them from ``spectral_cam.raw.hue_sat_map``.

References
----------
.. [1] Adobe (2023). Digital Negative (DNG) Specification 1.7.1.0, ch. 6, "Camera Profiles"
   (ProfileHueSatMap).
.. [2] ISO 22028-2:2013, ROMM RGB (ProPhoto RGB) primaries and white.
"""

from __future__ import annotations

import numpy as np

from ..raw.hue_sat_map import (PROPHOTO_TO_XYZ_D50, XYZ_D50_TO_PROPHOTO, HueSatMap, hsv_to_rgb,
                               interpolation_weights, rgb_to_hsv)

__all__ = ["HueSatMap", "apply_hue_sat_map", "rgb_to_hsv", "hsv_to_rgb", "interpolation_weights",
           "XYZ_D50_TO_PROPHOTO", "PROPHOTO_TO_XYZ_D50"]


def apply_hue_sat_map(prophoto: np.ndarray, hue_sat_map: HueSatMap) -> np.ndarray:
    """Apply a DNG hue/sat map to linear ProPhoto RGB.

    Parameters
    ----------
    prophoto : numpy.ndarray
        (..., 3) linear ProPhoto RGB (white 1), unclipped.
    hue_sat_map : HueSatMap

    Returns
    -------
    numpy.ndarray
        (..., 3) linear ProPhoto RGB: hue shifted, saturation (clipped to 1, as the DNG SDK does)
        and value scaled. Values above 1 are scaled, not pinned: this develop is scene-linear,
        where the SDK's renderer has already clipped them. Negative components (outside ProPhoto)
        pass through unchanged.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6, "Camera Profiles" (ProfileHueSatMap).
    """
    prophoto = np.asarray(prophoto, dtype=np.float64)
    hsv = rgb_to_hsv(prophoto)
    indices, weights = interpolation_weights(hsv, hue_sat_map.dims)
    flat = hue_sat_map.table.reshape(-1, 3)
    shift, sat_scale, val_scale = (np.sum(flat[indices, k] * weights, axis=-1) for k in range(3))
    out = np.stack([hsv[..., 0] + shift * (6.0 / 360.0), np.minimum(hsv[..., 1] * sat_scale, 1.0),
                    hsv[..., 2] * val_scale], axis=-1)
    mapped = hsv_to_rgb(out)
    outside = np.any(prophoto < 0, axis=-1, keepdims=True)
    return np.where(outside, prophoto, mapped)
