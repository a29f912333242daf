"""DNG writing: one uncompressed raw IFD with the tags LibRaw and Adobe readers need.

DNGVersion, PhotometricInterpretation = 32803 (CFA) with CFARepeatPatternDim + CFAPattern —
or 34892 (LinearRaw, one sample) for a monochrome sensor — BlackLevel (+ BlackLevelRepeatDim),
WhiteLevel, ColorMatrix1 with CalibrationIlluminant1 = 21 (D65), ColorMatrix2 (Standard A),
AsShotNeutral, NoiseProfile, UniqueCameraModel and Make/Model.

References
----------
.. [1] Adobe (2023). Digital Negative (DNG) Specification, version 1.7.1.0, ch. 4 (tags),
   ch. 6 (colour).
.. [2] ISO 12234-2 (TIFF/EP): CFARepeatPatternDim (33421), CFAPattern (33422).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..cfa import CHANNEL_CODES
from ..errors import RawFormatError
from ..io import atomic_path
from .image import RawImage, check_raw

#: TIFF/DNG tag numbers written by :func:`write_dng` (DNG 1.7.1.0 ch. 4; TIFF 6.0; TIFF/EP).
DNG_TAGS = {
    "NewSubFileType": 254,
    "PhotometricInterpretation": 262,
    "Make": 271,
    "Model": 272,
    "Orientation": 274,
    "Software": 305,
    "CFARepeatPatternDim": 33421,
    "CFAPattern": 33422,
    "DNGVersion": 50706,
    "DNGBackwardVersion": 50707,
    "UniqueCameraModel": 50708,
    "CFAPlaneColor": 50710,
    "CFALayout": 50711,
    "BlackLevelRepeatDim": 50713,
    "BlackLevel": 50714,
    "WhiteLevel": 50717,
    "ColorMatrix1": 50721,
    "ColorMatrix2": 50722,
    "AsShotNeutral": 50728,
    "CalibrationIlluminant1": 50778,
    "CalibrationIlluminant2": 50779,
    "NoiseProfile": 51041,
}


#: PhotometricInterpretation values.
PHOTOMETRIC_CFA = 32803


PHOTOMETRIC_LINEAR_RAW = 34892


#: EXIF LightSource codes of CIE D65 and Standard Illuminant A (DNG CalibrationIlluminant).
ILLUMINANT_D65 = 21


ILLUMINANT_A = 17
_TIFF_BYTE, _TIFF_ASCII, _TIFF_SHORT, _TIFF_LONG, _TIFF_RATIONAL, _TIFF_SRATIONAL, _TIFF_DOUBLE = 1, 2, 3, 4, 5, 10, 12


_RATIONAL_DENOMINATOR = 1_000_000


# ----------------------------------------------------------------------------- writing
def _rationals(values, *, signed: bool) -> list[int]:
    out = []
    for value in np.ravel(np.asarray(values, dtype=float)):
        numerator = int(round(value * _RATIONAL_DENOMINATOR))
        limit = 2 ** 31 - 1 if signed else 2 ** 32 - 1
        if not (-limit if signed else 0) <= numerator <= limit:
            raise RawFormatError(f"value {value!r} does not fit a TIFF {'S' if signed else ''}RATIONAL")
        out += [numerator, _RATIONAL_DENOMINATOR]
    return out


def _ascii(text: str) -> str:
    return text.encode("ascii", "replace").decode("ascii") or "unknown"


def write_dng(raw: RawImage, path, *, make: str = "spectral_cam", software: str = "spectral_cam") -> Path:
    """Write a RawImage as an uncompressed DNG (atomically).

    Parameters
    ----------
    raw : RawImage
        Mosaic (uint16), CFA, levels and optional colour metadata. ``color_matrix``
        (XYZ(D65) → camera) becomes ColorMatrix1 with CalibrationIlluminant1 = 21;
        ``as_shot_neutral`` AsShotNeutral; ``noise_profile`` NoiseProfile.
    path : str or path-like
        Output file (``.dng``); written through a temporary file and renamed.
    make : str
        Make (tag 271); Model (272) is the camera model.
    software : str
        Software (tag 305).

    Returns
    -------
    pathlib.Path
        The written path.

    Raises
    ------
    RawFormatError
        If the RawImage cannot be stored (wrong mosaic shape or type, bad levels or CFA).

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 4 (tags 50706–51041).
    .. [2] ISO 12234-2 (TIFF/EP): CFARepeatPatternDim (33421), CFAPattern (33422).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> from spectral_cam.raw import RawImage, read_raw, write_dng
    >>> mosaic = np.arange(32 * 32, dtype=np.uint16).reshape(32, 32)
    >>> path = write_dng(RawImage(mosaic, "GRBG", 64.0, 4095), pathlib.Path(tempfile.mkdtemp()) / "ramp.dng")
    >>> raw = read_raw(path)                   # LibRaw reads it back bit for bit
    >>> bool((raw.mosaic == mosaic).all()), raw.cfa, raw.white_level
    (True, 'GRBG', 4095)
    """
    import tifffile

    mosaic = check_raw(raw)
    path = Path(path)
    model = _ascii(raw.camera_model or "spectral_cam")
    black = np.asarray(raw.black_level, dtype=float)
    if black.ndim == 0 or np.all(black == black.flat[0]):
        black_dim, black_values = (1, 1), [float(black.flat[0])]
    else:
        black_dim, black_values = (2, 2), [float(v) for v in black.reshape(-1)]
    integral = all(v.is_integer() for v in black_values)
    tags = [
        (DNG_TAGS["DNGVersion"], _TIFF_BYTE, 4, (1, 4, 0, 0), True),
        (DNG_TAGS["DNGBackwardVersion"], _TIFF_BYTE, 4, (1, 1, 0, 0), True),
        (DNG_TAGS["UniqueCameraModel"], _TIFF_ASCII, 0, model, True),
        (DNG_TAGS["Make"], _TIFF_ASCII, 0, _ascii(make), True),
        (DNG_TAGS["Model"], _TIFF_ASCII, 0, model, True),
        (DNG_TAGS["Orientation"], _TIFF_SHORT, 1, (1,), True),
        (DNG_TAGS["BlackLevelRepeatDim"], _TIFF_SHORT, 2, black_dim, True),
        ((DNG_TAGS["BlackLevel"], _TIFF_LONG, len(black_values), tuple(int(v) for v in black_values), True)
         if integral else
         (DNG_TAGS["BlackLevel"], _TIFF_RATIONAL, len(black_values), _rationals(black_values, signed=False), True)),
        (DNG_TAGS["WhiteLevel"], _TIFF_LONG, 1, (int(raw.white_level),), True),
    ]
    monochrome = raw.cfa == "none"
    if not monochrome:
        tags += [
            (DNG_TAGS["CFARepeatPatternDim"], _TIFF_SHORT, 2, (2, 2), True),
            (DNG_TAGS["CFAPattern"], _TIFF_BYTE, 4, tuple(CHANNEL_CODES[c] for c in raw.cfa), True),
            (DNG_TAGS["CFAPlaneColor"], _TIFF_BYTE, 3, (0, 1, 2), True),
            (DNG_TAGS["CFALayout"], _TIFF_SHORT, 1, (1,), True),
        ]
        for number, matrix, illuminant in ((1, raw.color_matrix, ILLUMINANT_D65),
                                           (2, raw.color_matrix_2, ILLUMINANT_A)):
            if matrix is None or (number == 2 and raw.color_matrix is None):
                continue
            matrix = np.asarray(matrix, dtype=float)
            if matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
                raise RawFormatError(f"color matrix {number} must be a finite 3×3 array; got {matrix.shape}")
            tags += [
                (DNG_TAGS[f"ColorMatrix{number}"], _TIFF_SRATIONAL, 9, _rationals(matrix, signed=True), True),
                (DNG_TAGS[f"CalibrationIlluminant{number}"], _TIFF_SHORT, 1, (illuminant,), True),
            ]
        if raw.as_shot_neutral is not None:
            neutral = np.asarray(raw.as_shot_neutral, dtype=float)
            if neutral.shape != (3,) or not np.all(neutral > 0):
                raise RawFormatError(f"as_shot_neutral must be three positive numbers; got {neutral}")
            tags.append((DNG_TAGS["AsShotNeutral"], _TIFF_RATIONAL, 3, _rationals(neutral, signed=False), True))
    if raw.noise_profile is not None:
        scale, offset = (float(v) for v in raw.noise_profile)
        tags.append((DNG_TAGS["NoiseProfile"], _TIFF_DOUBLE, 2, (scale, offset), True))
    with atomic_path(path) as tmp:
        tifffile.imwrite(tmp, mosaic, photometric="cfa" if not monochrome else "minisblack",
                         subfiletype=0, software=_ascii(software), extratags=tags, metadata=None)
        if monochrome:  # tifffile refuses LinearRaw with one sample; set the tag in place
            with tifffile.TiffFile(tmp, mode="r+b") as tif:
                tif.pages[0].tags["PhotometricInterpretation"].overwrite(PHOTOMETRIC_LINEAR_RAW)
    return path
