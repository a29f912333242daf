"""RAW images: the :class:`RawImage` type, DNG writing (tifffile) and reading (rawpy).

References
----------
.. [1] Adobe (2023). Digital Negative (DNG) Specification, version 1.7.1.0.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["RawImage"]


@dataclass
class RawImage:
    """A sensor's raw output plus the metadata an ISP needs.

    Attributes
    ----------
    mosaic
        (H, W) uint16 digital numbers (DN), one CFA colour per pixel.
    cfa
        Bayer tile read row by row from the top-left pixel ("RGGB", "BGGR", "GRBG",
        "GBRG"), or "none" for a monochrome sensor.
    black_level
        DN added by the ADC offset (DNG BlackLevel).
    white_level
        Largest DN the ADC can return (DNG WhiteLevel), 2**bits − 1.
    color_matrix
        (3, 3) XYZ(D65) → camera RGB (DNG ColorMatrix1, CalibrationIlluminant1 = D65), or None.
    as_shot_neutral
        (3,) camera RGB of the scene illuminant's white, normalised to max 1 (DNG
        AsShotNeutral), or None.
    noise_profile
        (S, O) of the DNG NoiseProfile: variance = S·x + O for the signal x normalised to
        [0, 1] by (DN − black) / (white − black), or None.
    camera_model
        DNG UniqueCameraModel.
    meta
        Everything else (gain K in DN/e⁻, exposure, ISO, seeds, ...).
    """

    mosaic: np.ndarray
    cfa: str
    black_level: float
    white_level: int
    color_matrix: np.ndarray | None = None
    as_shot_neutral: np.ndarray | None = None
    noise_profile: tuple[float, float] | None = None
    camera_model: str = ""
    meta: dict = field(default_factory=dict)
