"""The colour metadata a RAW carries: XYZ→camera matrices (DNG ColorMatrix1/2) and the
fitted camera→XYZ(D65) corrections, cached per camera, illuminant and filters.

References
----------
.. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 (ColorMatrix1/2).
"""

from __future__ import annotations

import functools

import numpy as np

from ..errors import ConfigError


@functools.lru_cache(maxsize=32)
def _colour_matrix(model: str, specs: tuple, illuminant: str = "D65") -> np.ndarray | None:
    from . import calibration

    try:
        return calibration.xyz_to_camera_matrix(model, illuminant, transmission=list(specs))
    except ConfigError:
        return None  # channels without three distinct spectral sensitivities ("ideal")


@functools.lru_cache(maxsize=32)
def _fitted_corrections_cached(model: str, illuminant: str, specs: tuple) -> tuple:
    from . import calibration

    linear = calibration.camera_to_xyz_d65(model, illuminant, transmission=list(specs))
    root = calibration.camera_to_xyz_d65(model, illuminant, method="root_polynomial", transmission=list(specs))
    return np.asarray(linear, dtype=float).tolist(), np.asarray(root.ccm, dtype=float).tolist()


def _fitted_corrections(model: str, illuminant: str, specs: tuple) -> dict:
    """White-balanced camera RGB → XYZ(D65) fitted on the ColorChecker under the scene
    illuminant (3×3 and root-polynomial), for the ISP's ``colour_matrix = "fitted"`` /
    ``"root_polynomial"``; the ISP reads them from ``RawImage.meta`` (it never sees spectra)."""
    linear, root = _fitted_corrections_cached(model, illuminant, specs)
    return {"camera_to_xyz_d65": linear, "camera_to_xyz_d65_root_polynomial": root}
