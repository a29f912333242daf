"""The RAW image: a sensor's mosaic plus the metadata an ISP needs (levels, CFA, colour, noise).

References
----------
.. [1] Adobe (2023). Digital Negative (DNG) Specification, version 1.7.1.0, ch. 4 (tags),
   ch. 6 (colour).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..cfa import LINEAR, check_cfa
from ..errors import RawFormatError


@dataclass(frozen=True)
class Calibration:
    """A DNG 1.6 third calibration (CalibrationIlluminant3, ColorMatrix3, ForwardMatrix3,
    ProfileHueSatMapData3): the camera profile fitted under a light off the D65–A locus, which a
    DNG 1.6 reader blends with the D65 and Standard A ones by the scene white's distance from each
    light in (1/temperature, tint) (DNG ch. 6, "three calibrations").

    Attributes
    ----------
    illuminant : str
        The light's name (the record; the file holds it as CalibrationIlluminant3 = 255, "other").
    white_xy : tuple of float
        CIE 1931 xy of the light's white (IlluminantData3).
    color_matrix : numpy.ndarray
        (3, 3) XYZ → camera RGB under that light (ColorMatrix3).
    forward_matrix : numpy.ndarray or None
        (3, 3) white-balanced camera RGB → XYZ(D50) under it (ForwardMatrix3).
    hue_sat_map : HueSatMap or None
        Its ProfileHueSatMapData3.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 (CalibrationIlluminant3, IlluminantData3).
    """

    illuminant: str
    white_xy: tuple[float, float]
    color_matrix: np.ndarray
    forward_matrix: np.ndarray | None = None
    hue_sat_map: object | None = None


@dataclass
class RawImage:
    """A sensor's raw output plus the metadata an ISP needs.

    Attributes
    ----------
    mosaic
        (H, W) uint16 digital numbers (DN), one CFA colour per pixel.
    cfa
        Bayer tile read row by row from the top-left pixel ("RGGB", "BGGR", "GRBG",
        "GBRG"), "none" for a monochrome sensor, or "linear" for a three-colour (H, W, 3)
        raw (DNG LinearRaw).
    black_level
        DN added by the ADC offset (DNG BlackLevel): a number, or a (2, 2) array per CFA site
        (BlackLevelRepeatDim 2×2) when a camera's channels differ.
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
    color_matrix_2
        (3, 3) XYZ → camera RGB calibrated under Standard Illuminant A (DNG ColorMatrix2,
        CalibrationIlluminant2 = 17), or None. With both matrices an ISP interpolates
        between them by the scene white's correlated colour temperature (DNG ch. 6).
    forward_matrix, forward_matrix_2
        (3, 3) white-balanced camera RGB → XYZ(D50), calibrated under D65 and under
        Standard A (DNG ForwardMatrix), or None.
    crop
        (top, left, height, width) of the image in the mosaic (DNG DefaultCropOrigin and
        DefaultCropSize): the pixels outside it are a margin of real data that lets a
        demosaicer interpolate the image's edges; an ISP develops the mosaic and keeps the
        crop. None: the whole mosaic is the image.
    baseline_exposure
        Stops by which a developer brightens the image (DNG BaselineExposure): the offset that
        puts a metered mid grey at 118/255 in the default rendering (ISO 12232 standard output
        sensitivity); 0 for a camera raw without the tag.
    profile_tone_curve
        (N, 2) linear input → output pairs of the tone curve the default rendering applies (DNG
        ProfileToneCurve), or None.
    hue_sat_map, hue_sat_map_2
        :class:`spectral_cam.raw.hue_sat_map.HueSatMap` of the D65 and the Standard A calibration
        (DNG ProfileHueSatMapData, beside the forward matrices), or None.
    calibration_3
        A DNG 1.6 third calibration (:class:`Calibration`) under the scene's light when it lies
        off the D65–A locus, or None.
    """

    mosaic: np.ndarray
    cfa: str
    black_level: float | np.ndarray
    white_level: int
    color_matrix: np.ndarray | None = None
    as_shot_neutral: np.ndarray | None = None
    noise_profile: tuple[float, float] | None = None
    camera_model: str = ""
    meta: dict = field(default_factory=dict)
    color_matrix_2: np.ndarray | None = None
    forward_matrix: np.ndarray | None = None
    forward_matrix_2: np.ndarray | None = None
    crop: tuple[int, int, int, int] | None = None
    baseline_exposure: float = 0.0
    profile_tone_curve: np.ndarray | None = None
    hue_sat_map: object | None = None
    hue_sat_map_2: object | None = None
    calibration_3: Calibration | None = None


def check_raw(raw: RawImage) -> np.ndarray:
    mosaic = np.asarray(raw.mosaic)
    linear = raw.cfa == LINEAR
    if mosaic.size == 0 or (mosaic.ndim != 2 if not linear else (mosaic.ndim != 3 or mosaic.shape[2] != 3)):
        shape = "(H, W, 3)" if linear else "(H, W)"
        raise RawFormatError(f"RawImage.mosaic must be a non-empty {shape} array; got shape {mosaic.shape}")
    if mosaic.dtype != np.uint16:
        if not np.issubdtype(mosaic.dtype, np.integer) or mosaic.min() < 0 or mosaic.max() > 65535:
            raise RawFormatError(f"RawImage.mosaic must hold whole numbers in 0..65535; got {mosaic.dtype}")
        mosaic = mosaic.astype(np.uint16)
    if not linear:
        check_cfa(raw.cfa, allow_monochrome=True, allow_extended=True)
    black = np.asarray(raw.black_level, dtype=float)
    if black.shape not in ((), (2, 2)) and not (linear and black.shape == (3,)):
        raise RawFormatError(f"black_level must be a number, a 2×2 array per CFA site or (linear raws) one per "
                             f"colour; got shape {black.shape}")
    if not 0 < int(raw.white_level) <= 65535 or not (0 <= black.min() and black.max() < int(raw.white_level)):
        raise RawFormatError(f"levels black = {raw.black_level!r}, white = {raw.white_level!r}: need "
                             "0 <= black < white <= 65535")
    check_crop(raw.crop, mosaic.shape[:2])
    return np.ascontiguousarray(mosaic)


def check_crop(crop, shape) -> tuple[int, int, int, int] | None:
    """A (top, left, height, width) crop that lies inside a mosaic of ``shape`` (H, W)."""
    if crop is None:
        return None
    values = tuple(crop)
    if len(values) != 4 or not all(isinstance(v, (int, np.integer)) for v in values):
        raise RawFormatError(f"RawImage.crop must be four whole numbers (top, left, height, width); got {crop!r}")
    top, left, height, width = (int(v) for v in values)
    if top < 0 or left < 0 or height < 1 or width < 1 or top + height > shape[0] or left + width > shape[1]:
        raise RawFormatError(f"RawImage.crop {values} does not lie inside the {shape[1]}×{shape[0]} mosaic "
                             "(need top, left >= 0, height, width >= 1, top + height <= H, left + width <= W)")
    return top, left, height, width
