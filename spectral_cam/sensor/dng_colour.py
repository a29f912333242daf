"""The colour metadata a RAW carries: XYZ→camera matrices (DNG ColorMatrix1/2), forward
matrices (white-balanced camera → XYZ D50, DNG ForwardMatrix1/2) and the fitted
camera→XYZ(D65) corrections, cached per camera, illuminant and filters.

References
----------
.. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 (ColorMatrix1/2, ForwardMatrix1/2).
"""

from __future__ import annotations

import functools

import numpy as np

from ..errors import ConfigError


@functools.lru_cache(maxsize=32)
def _colour_matrix(model: str, specs: tuple, illuminant: str = "D65") -> np.ndarray | None:
    from . import colour_calibration

    try:
        return colour_calibration.xyz_to_camera_matrix(model, illuminant, transmission=list(specs))
    except ConfigError:
        return None  # channels without three distinct spectral sensitivities ("ideal")


@functools.lru_cache(maxsize=32)
def _fitted_corrections_cached(model: str, illuminant: str, specs: tuple) -> tuple:
    from . import colour_calibration

    linear = colour_calibration.camera_to_xyz_d65(model, illuminant, transmission=list(specs))
    root = colour_calibration.camera_to_xyz_d65(model, illuminant, method="root_polynomial", transmission=list(specs))
    return np.asarray(linear, dtype=float).tolist(), np.asarray(root.ccm, dtype=float).tolist()


def _fitted_corrections(model: str, illuminant: str, specs: tuple) -> dict:
    """White-balanced camera RGB → XYZ(D65) fitted on the training set
    (:data:`~spectral_cam.sensor.colour_calibration.TRAINING_SET`) under the scene
    illuminant (3×3 and root-polynomial), for the ISP's ``colour_matrix = "fitted"`` /
    ``"root_polynomial"``; the ISP reads them from ``RawImage.meta`` (it never sees spectra)."""
    from .colour_calibration import training_record

    linear, root = _fitted_corrections_cached(model, illuminant, specs)
    return {"camera_to_xyz_d65": linear, "camera_to_xyz_d65_root_polynomial": root,
            "colour_calibration": training_record()}




@functools.lru_cache(maxsize=32)
def _forward_matrix(model: str, specs: tuple, illuminant: str = "D65") -> np.ndarray | None:
    """White-balanced camera RGB → XYZ(D50) under ``illuminant`` (DNG ForwardMatrix): the
    white-preserving fit of :func:`spectral_cam.sensor.colour_calibration.camera_to_xyz_d65`, Bradford-adapted from
    D65 to D50, so camera white (1, 1, 1) maps onto the D50 white as the DNG spec requires."""
    from . import colour_calibration

    try:
        return colour_calibration.forward_matrix_d50(model, illuminant, transmission=list(specs))
    except ConfigError:
        return None


@functools.lru_cache(maxsize=32)
def _hue_sat_map(model: str, specs: tuple, illuminant: str = "D65"):
    """The DNG ProfileHueSatMap beside :func:`_forward_matrix` for ``illuminant``: what the forward
    matrix leaves of the training set's colours
    (:func:`spectral_cam.sensor.colour_calibration.fit_hue_sat_map`); None without a forward matrix."""
    from . import colour_calibration

    forward = _forward_matrix(model, specs, illuminant)
    if forward is None:
        return None
    return colour_calibration.fit_hue_sat_map(model, illuminant, forward_matrix=forward, transmission=list(specs))


#: Lights the D65–A pair spans: CIE daylights and blackbodies (Standard A is one). Any other light
#: (fluorescent, LED, discharge, a measured CSV) gets a third calibration: under FL2 the D65–A blend of
#: a DNG reader scored 1.61 mean ΔE2000 on CIE 2017 where a profile fitted under FL2 scores 0.91, while
#: under D50 the blend scored 0.90 against 0.91 (docs/validate/calibration.csv, both cameras).
def on_d65_a_locus(illuminant: str) -> bool:
    """Whether ``illuminant`` is a CIE daylight (D50, D65, …) or a blackbody (A, ``blackbody:<K>``): a
    light whose spectrum the D65 and Standard A calibrations interpolate."""
    import re

    name = str(illuminant).strip()
    return bool(re.fullmatch(r"(?i)(A|D\d{2}|blackbody:.*|planck.*)", name))


@functools.lru_cache(maxsize=32)
def _third_calibration(model: str, specs: tuple, illuminant: str):
    """The DNG 1.6 third calibration (:class:`spectral_cam.raw.Calibration`) under the scene's light —
    ColorMatrix3, ForwardMatrix3 and ProfileHueSatMapData3 fitted as the D65 and A ones are — when the
    light is off the D65–A locus (:func:`on_d65_a_locus`); None on it, or for a camera without three
    distinct channels."""
    from ..colour_ground_truth import illuminant_white_xyz
    from ..raw.image import Calibration

    if not isinstance(illuminant, str) or on_d65_a_locus(illuminant):
        return None
    matrix, forward = _colour_matrix(model, specs, illuminant), _forward_matrix(model, specs, illuminant)
    if matrix is None or forward is None:
        return None
    white = np.asarray(illuminant_white_xyz(illuminant), dtype=float)
    return Calibration(illuminant=illuminant, white_xy=(float(white[0] / white.sum()), float(white[1] / white.sum())),
                       color_matrix=matrix, forward_matrix=forward, hue_sat_map=_hue_sat_map(model, specs, illuminant))
