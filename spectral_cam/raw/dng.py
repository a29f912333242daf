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

from ..cfa import DNG_WHITE_CODE, LINEAR, WHITE, channel_count, cfa_pattern
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
    "ForwardMatrix1": 50964,
    "ForwardMatrix2": 50965,
    "ProfileHueSatMapDims": 50937,
    "ProfileHueSatMapData1": 50938,
    "ProfileHueSatMapData2": 50939,
    "CalibrationIlluminant3": 52529,
    "ColorMatrix3": 52531,
    "ForwardMatrix3": 52532,
    "IlluminantData3": 52535,
    "ProfileHueSatMapData3": 52537,
    "NoiseProfile": 51041,
    "BaselineExposure": 50730,
    "ProfileToneCurve": 50940,
    "ProfileName": 50936,
    "ProfileEmbedPolicy": 50941,
    "DefaultBlackRender": 51110,
    "DefaultCropOrigin": 50719,
    "DefaultCropSize": 50720,
    "ActiveArea": 50829,
    # capture metadata (TIFF/EP ISO 12234-2 places these EXIF tags in IFD 0)
    "DateTime": 306,
    "ExposureTime": 33434,
    "FNumber": 33437,
    "ISOSpeedRatings": 34855,
    "DateTimeOriginal": 36867,
    "FocalLength": 37386,
    "LensModel": 42036,
    "LensInfo": 50736,
    "ExifIFD": 34665,
    "ExifVersion": 36864,
    "FocalPlaneXResolution": 41486,
    "FocalPlaneYResolution": 41487,
    "FocalPlaneResolutionUnit": 41488,
}
#: The EXIF tags that belong in the Exif IFD (not IFD 0), by EXIF 2.32 §4.6.
EXIF_IFD_TAGS = frozenset({33434, 33437, 34855, 36864, 36867, 37386, 42036, 41486, 41487, 41488})


#: PhotometricInterpretation values.
PHOTOMETRIC_CFA = 32803


PHOTOMETRIC_LINEAR_RAW = 34892


#: EXIF LightSource codes of CIE D65 and Standard Illuminant A (DNG CalibrationIlluminant).
ILLUMINANT_D65 = 21


ILLUMINANT_A = 17
#: EXIF LightSource "other light source": a DNG 1.6 calibration whose light IlluminantData describes.
ILLUMINANT_OTHER = 255
_TIFF_BYTE, _TIFF_ASCII, _TIFF_SHORT, _TIFF_LONG, _TIFF_RATIONAL, _TIFF_SRATIONAL, _TIFF_DOUBLE = 1, 2, 3, 4, 5, 10, 12
_TIFF_FLOAT = 11


# ----------------------------------------------------------------------------- writing
def _rationals(values, *, signed: bool) -> list[int]:
    """(numerator, denominator) pairs: each value's best rational approximation whose terms fit
    the TIFF (S)RATIONAL's 32 bits (a fixed denominator of 10⁶ wrote 1.35·10⁻⁸ s as 0 and refused
    times above 4294.97 s; issue 25 #3)."""
    from fractions import Fraction

    limit = 2 ** 31 - 1 if signed else 2 ** 32 - 1
    out = []
    for value in np.ravel(np.asarray(values, dtype=float)):
        if not np.isfinite(value) or abs(value) > limit or (value < 0 and not signed):
            raise RawFormatError(f"value {value!r} does not fit a TIFF {'S' if signed else ''}RATIONAL "
                                 f"(a finite number within {'±' if signed else '0..'}{limit})")
        fraction = Fraction(float(value)).limit_denominator(limit)
        while abs(fraction.numerator) > limit:  # a large value: coarser denominators until it fits
            fraction = Fraction(float(value)).limit_denominator(max(1, fraction.denominator // 2))
        out += [fraction.numerator, fraction.denominator]
    return out


def _ascii(text: str) -> str:
    return text.encode("ascii", "replace").decode("ascii") or "unknown"


def _matrix_tag(name: str, matrix, planes: int = 3) -> tuple:
    """ColorMatrix (planes × 3) or ForwardMatrix (3 × planes) as SRATIONALs (DNG ch. 6)."""
    matrix = np.asarray(matrix, dtype=float)
    shape = (3, planes) if name.startswith("Forward") else (planes, 3)
    if matrix.shape != shape or not np.all(np.isfinite(matrix)):
        raise RawFormatError(f"{name} must be a finite {shape[0]}×{shape[1]} array for {planes} colour planes; "
                             f"got shape {matrix.shape}")
    rank = int(np.linalg.matrix_rank(matrix))
    if rank < 3:  # a reader inverts a ColorMatrix and maps white through a ForwardMatrix: neither works singular
        raise RawFormatError(f"{name} is singular (rank {rank}): a DNG reader could map no camera colour to XYZ "
                             "through it; give a matrix of rank 3 (an all-zero matrix is no calibration)")
    return (DNG_TAGS[name], _TIFF_SRATIONAL, matrix.size, _rationals(matrix, signed=True), True)


def _colour_tags(raw: RawImage) -> list[tuple]:
    """ColorMatrix/ForwardMatrix/CalibrationIlluminant in Adobe's slot order: with two
    calibrations the lower colour temperature (Standard A, 17) is slot 1 and D65 (21) slot 2,
    as in Adobe's own DNGs (dcraw keeps the slot it reads last, so this order gives it D65);
    with one, D65 is slot 1."""
    if raw.color_matrix is None:
        return []
    calibrations = [(ILLUMINANT_D65, raw.color_matrix, raw.forward_matrix, raw.hue_sat_map)]
    if raw.color_matrix_2 is not None:
        calibrations.insert(0, (ILLUMINANT_A, raw.color_matrix_2, raw.forward_matrix_2, raw.hue_sat_map_2))
    tags = []
    maps = [hsm for *_, hsm in calibrations]
    if any(hsm is not None for hsm in maps) and (any(hsm is None for hsm in maps)
                                                   or len({hsm.dims for hsm in maps}) > 1):
        raise RawFormatError("hue/sat maps: give one per calibration (hue_sat_map, and hue_sat_map_2 with "
                             "color_matrix_2), all of the same divisions (DNG ProfileHueSatMapDims is shared)")
    planes = channel_count(raw.cfa) if raw.cfa != LINEAR else 3
    for number, (illuminant, matrix, forward, hue_sat) in enumerate(calibrations, start=1):
        tags += [_matrix_tag(f"ColorMatrix{number}", matrix, planes),
                 (DNG_TAGS[f"CalibrationIlluminant{number}"], _TIFF_SHORT, 1, (illuminant,), True)]
        if forward is not None:
            tags.append(_matrix_tag(f"ForwardMatrix{number}", forward, planes))
        if hue_sat is not None:
            data = hue_sat.dng_data()
            tags.append((DNG_TAGS[f"ProfileHueSatMapData{number}"], _TIFF_FLOAT, data.size,
                         tuple(float(v) for v in data), True))
    if maps[0] is not None:
        tags.append((DNG_TAGS["ProfileHueSatMapDims"], _TIFF_LONG, 3, maps[0].dims, True))
    return tags + _third_calibration_tags(raw, planes, forward_present=raw.forward_matrix is not None, maps=maps)


def _illuminant_data_xy(xy) -> bytes:
    """IlluminantData of type 0 (the light's white as CIE 1931 x, y: two RATIONALs after a SHORT 0),
    in the file's little-endian order (DNG 1.7.1.0, IlluminantData1/2/3)."""
    import struct

    x, y = (float(v) for v in xy)
    if not (0 < x < 1 and 0 < y < 1 and x + y < 1):
        raise RawFormatError(f"a calibration light's white xy {xy!r} lies outside the chromaticity diagram")
    return struct.pack("<H4I", 0, *_rationals([x, y], signed=False))


def _third_calibration_tags(raw: RawImage, planes: int, *, forward_present: bool, maps: list) -> list[tuple]:
    """CalibrationIlluminant3 = 255 with IlluminantData3, ColorMatrix3 and, as the first two have them,
    ForwardMatrix3 and ProfileHueSatMapData3 (DNG 1.6: all three calibrations or none of each)."""
    third = getattr(raw, "calibration_3", None)
    if third is None:
        return []
    if raw.color_matrix_2 is None or planes != 3:
        raise RawFormatError("a third calibration (calibration_3) needs the D65 and Standard A ones (color_matrix, "
                             "color_matrix_2) and three colour planes")
    if (third.forward_matrix is None) == forward_present or (third.hue_sat_map is None) != (maps[0] is None):
        raise RawFormatError("calibration_3 must carry a forward matrix and a hue/sat map exactly when the first two "
                             "calibrations do (DNG 1.6: ForwardMatrix and ProfileHueSatMapData for all three or none)")
    data = _illuminant_data_xy(third.white_xy)
    tags = [(DNG_TAGS["CalibrationIlluminant3"], _TIFF_SHORT, 1, (ILLUMINANT_OTHER,), True),
            (DNG_TAGS["IlluminantData3"], 7, len(data), data, True),
            _matrix_tag("ColorMatrix3", third.color_matrix, planes)]
    if third.forward_matrix is not None:
        tags.append(_matrix_tag("ForwardMatrix3", third.forward_matrix, planes))
    if third.hue_sat_map is not None:
        if third.hue_sat_map.dims != maps[0].dims:
            raise RawFormatError("calibration_3's hue/sat map must share the others' divisions (ProfileHueSatMapDims)")
        values = third.hue_sat_map.dng_data()
        tags.append((DNG_TAGS["ProfileHueSatMapData3"], _TIFF_FLOAT, values.size, tuple(float(v) for v in values), True))
    return tags


def _rendering_tags(raw: RawImage) -> list[tuple]:
    """BaselineExposure, and the tone curve as ProfileToneCurve with DefaultBlackRender: how
    the default rendering should look, so Adobe-path readers show what our develop shows. A
    curve with a black point of its own ("adobe") lets the reader apply its default shadows
    (Auto, 0); the others ask for none (1)."""
    ev = float(getattr(raw, "baseline_exposure", 0.0) or 0.0)
    if not np.isfinite(ev) or abs(ev) > 20:
        raise RawFormatError(f"baseline_exposure = {ev!r}: give a finite number of stops within ±20")
    tags = [(DNG_TAGS["BaselineExposure"], _TIFF_SRATIONAL, 1, _rationals([ev], signed=True), True)]
    curve = getattr(raw, "profile_tone_curve", None)
    if curve is not None:
        pairs = np.asarray(curve, dtype=np.float32)
        if pairs.ndim != 2 or pairs.shape[1] != 2 or len(pairs) < 2 or not np.all(np.diff(pairs[:, 0]) > 0) \
                or pairs.min() < 0 or pairs.max() > 1:
            raise RawFormatError("profile_tone_curve must be (N >= 2, 2) pairs in [0, 1] with rising inputs")
        own_black = bool((raw.meta or {}).get("tone_black_render", False))
        tags += [(DNG_TAGS["ProfileToneCurve"], _TIFF_FLOAT, pairs.size, tuple(float(v) for v in pairs.ravel()), True),
                 (DNG_TAGS["DefaultBlackRender"], _TIFF_LONG, 1, (0 if own_black else 1,), True)]
    return tags


def capture_time(meta: dict) -> str:
    """The EXIF DateTime of a capture: ``meta["capture_time"]`` if given, else
    ``SOURCE_DATE_EPOCH`` (reproducible builds), else 2000-01-01 00:00:00 — never the
    clock, so the same seed gives the same bytes.

    References
    ----------
    .. [1] reproducible-builds.org, SOURCE_DATE_EPOCH specification.
    """
    import datetime
    import os

    if meta.get("capture_time"):
        return str(meta["capture_time"])
    epoch = os.environ.get("SOURCE_DATE_EPOCH", "").strip()
    seconds = int(epoch) if epoch.isdigit() else 946684800
    return datetime.datetime.fromtimestamp(seconds, datetime.timezone.utc).strftime("%Y:%m:%d %H:%M:%S")


def _capture_tags(meta: dict) -> list[tuple]:
    """EXIF capture tags from a RawImage's meta: what the simulation knows (the Exif IFD's
    ones are split off by :func:`_write_exif_ifd`)."""
    stamp = capture_time(meta)
    tags = [(DNG_TAGS["DateTime"], _TIFF_ASCII, 0, stamp, True),
            (DNG_TAGS["DateTimeOriginal"], _TIFF_ASCII, 0, stamp, True),
            (DNG_TAGS["ExifVersion"], 7, 4, b"0232", True)]
    if meta.get("exposure_s"):
        tags.append((DNG_TAGS["ExposureTime"], _TIFF_RATIONAL, 1, _rationals([meta["exposure_s"]], signed=False), True))
    if meta.get("iso"):
        tags.append((DNG_TAGS["ISOSpeedRatings"], _TIFF_SHORT, 1, (int(min(round(meta["iso"]), 65535)),), True))
    f_number, focal = meta.get("f_number"), meta.get("focal_length_mm")
    if f_number:
        tags.append((DNG_TAGS["FNumber"], _TIFF_RATIONAL, 1, _rationals([f_number], signed=False), True))
    if focal:
        tags.append((DNG_TAGS["FocalLength"], _TIFF_RATIONAL, 1, _rationals([focal], signed=False), True))
    if meta.get("pixel_area_m2"):  # pixels per centimetre: readers derive the sensor size (35 mm equivalent)
        per_cm = 0.01 / float(np.sqrt(meta["pixel_area_m2"]))
        tags += [(DNG_TAGS["FocalPlaneXResolution"], _TIFF_RATIONAL, 1, _rationals([per_cm], signed=False), True),
                 (DNG_TAGS["FocalPlaneYResolution"], _TIFF_RATIONAL, 1, _rationals([per_cm], signed=False), True),
                 (DNG_TAGS["FocalPlaneResolutionUnit"], _TIFF_SHORT, 1, (3,), True)]
    if f_number and focal:
        lens = f"spectral_cam thin lens {focal:g} mm f/{f_number:g}"
        tags += [(DNG_TAGS["LensModel"], _TIFF_ASCII, 0, _ascii(lens), True),
                 (DNG_TAGS["LensInfo"], _TIFF_RATIONAL, 4,
                  _rationals([focal, focal, f_number, f_number], signed=False), True)]
    return tags


def _ifd_bytes(entries: list[tuple], offset: int) -> bytes:
    """A little-endian TIFF IFD placed at ``offset``: entries (tag, type, count, value) sorted
    by tag, values over 4 bytes in a data area after it, next-IFD offset 0 (TIFF 6.0 §2)."""
    import struct

    sizes = {1: 1, 2: 1, 3: 2, 4: 4, 5: 8, 7: 1, 10: 8, 12: 8}
    formats = {1: "B", 3: "H", 4: "I", 5: "I", 10: "i", 12: "d"}
    entries = sorted(entries)
    data_at = offset + 2 + 12 * len(entries) + 4
    head, data = [struct.pack("<H", len(entries))], b""
    for tag, kind, count, value in entries:
        if kind == 2:
            raw = value.encode("ascii") + b"\0"
            count = len(raw)
        elif kind == 7:
            raw = bytes(value)
        else:
            raw = struct.pack("<" + formats[kind] * len(value), *value)
        if count * sizes[kind] <= 4:
            head.append(struct.pack("<HHI", tag, kind, count) + raw.ljust(4, b"\0"))
        else:
            head.append(struct.pack("<HHII", tag, kind, count, data_at + len(data)))
            data += raw + (b"\0" if len(raw) % 2 else b"")
    return b"".join(head) + struct.pack("<I", 0) + data


#: A placeholder IFD 0 entry tifffile writes (it refuses tag 34665 itself); it sorts where the
#: ExifIFD tag does, and :func:`_write_exif_ifd` turns it into one.
_EXIF_PLACEHOLDER = 34666


def _write_exif_ifd(path: Path, tags: list[tuple]) -> None:
    """Append an Exif IFD holding ``tags`` to a little-endian TIFF file and turn IFD 0's
    placeholder entry into the ExifIFD pointer (tag 34665, LONG) to it (TIFF/EP, EXIF 2.32 §4.6)."""
    import struct

    with open(path, "r+b") as handle:
        handle.seek(0, 2)
        offset = handle.tell() + (handle.tell() % 2)
        handle.write(b"\0" * (offset - handle.tell()))
        handle.write(_ifd_bytes([(tag, kind, count, value) for tag, kind, count, value, _ in tags], offset))
        handle.seek(4)
        ifd0 = struct.unpack("<I", handle.read(4))[0]
        handle.seek(ifd0)
        count = struct.unpack("<H", handle.read(2))[0]
        for index in range(count):
            handle.seek(ifd0 + 2 + 12 * index)
            if struct.unpack("<H", handle.read(2))[0] == _EXIF_PLACEHOLDER:
                handle.seek(ifd0 + 2 + 12 * index)
                handle.write(struct.pack("<HHII", DNG_TAGS["ExifIFD"], _TIFF_LONG, 1, offset))
                return
    raise RawFormatError(f"{path}: the ExifIFD placeholder is missing")


def _crop_tags(crop, shape) -> list[tuple]:
    """ActiveArea (the whole mosaic: every pixel is real data), DefaultCropOrigin (H, V) and
    DefaultCropSize (width, height) of the image inside it (DNG 1.7.1.0 ch. 4). Adobe's reader
    wants at least ~2 pixels of CFA around the crop on every side to interpolate its edges."""
    if crop is None:
        return []
    top, left, height, width = crop
    return [
        (DNG_TAGS["ActiveArea"], _TIFF_LONG, 4, (0, 0, int(shape[0]), int(shape[1])), True),
        (DNG_TAGS["DefaultCropOrigin"], _TIFF_LONG, 2, (int(left), int(top)), True),
        (DNG_TAGS["DefaultCropSize"], _TIFF_LONG, 2, (int(width), int(height)), True),
    ]


def write_dng(raw: RawImage, path, *, make: str = "spectral_cam", software: str = "spectral_cam") -> Path:
    """Write a RawImage as an uncompressed DNG (atomically).

    Parameters
    ----------
    raw : RawImage
        Mosaic (uint16), CFA, levels and optional colour metadata. ``color_matrix``
        (XYZ(D65) → camera) and ``color_matrix_2`` (Standard A) become ColorMatrix2/1 with
        CalibrationIlluminant2 = 21 and 1 = 17 (Adobe's order: the lower temperature first;
        a lone D65 matrix is ColorMatrix1), the forward matrices ForwardMatrix1/2 beside them;
        ``as_shot_neutral`` AsShotNeutral; ``noise_profile`` NoiseProfile; from ``meta``
        the capture: ExposureTime (``exposure_s``), ISO (``iso``), FNumber (``f_number``),
        FocalLength, LensModel and LensInfo (``focal_length_mm``), DateTime/DateTimeOriginal
        (:func:`capture_time`).
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
        If the RawImage cannot be stored (wrong mosaic shape or type, bad levels or CFA, a singular
        colour or forward matrix).

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
    if raw.cfa == LINEAR:  # one level per sample: BlackLevel holds RepeatRows·RepeatCols·SamplesPerPixel values
        black_dim, black_values = (1, 1), [float(v) for v in np.broadcast_to(black, (3,))]
    elif black.ndim == 0 or np.all(black == black.flat[0]):
        black_dim, black_values = (1, 1), [float(black.flat[0])]
    else:
        black_dim, black_values = (2, 2), [float(v) for v in black.reshape(-1)]
    integral = all(v.is_integer() for v in black_values)
    # a third calibration is DNG 1.6; readers before it keep reading slots 1 and 2 (the D65–A pair)
    version = (1, 6, 0, 0) if getattr(raw, "calibration_3", None) is not None else (1, 4, 0, 0)
    tags = [
        (DNG_TAGS["DNGVersion"], _TIFF_BYTE, 4, version, True),
        (DNG_TAGS["DNGBackwardVersion"], _TIFF_BYTE, 4, (1, 1, 0, 0), True),
        (DNG_TAGS["UniqueCameraModel"], _TIFF_ASCII, 0, model, True),
        (DNG_TAGS["Make"], _TIFF_ASCII, 0, _ascii(make), True),
        (DNG_TAGS["Model"], _TIFF_ASCII, 0, model, True),
        (DNG_TAGS["Orientation"], _TIFF_SHORT, 1, (1,), True),
        (DNG_TAGS["BlackLevelRepeatDim"], _TIFF_SHORT, 2, black_dim, True),
        ((DNG_TAGS["BlackLevel"], _TIFF_LONG, len(black_values), tuple(int(v) for v in black_values), True)
         if integral else
         (DNG_TAGS["BlackLevel"], _TIFF_RATIONAL, len(black_values), _rationals(black_values, signed=False), True)),
    ]
    monochrome, linear = raw.cfa == "none", raw.cfa == LINEAR
    # one WhiteLevel per sample (DNG 1.7.1.0 ch. 4): a Linear Raw DNG has three (issue 25 #17)
    samples = 3 if linear else 1
    tags.append((DNG_TAGS["WhiteLevel"], _TIFF_LONG, samples, (int(raw.white_level),) * samples, True))
    if not monochrome:
        if not linear:
            pattern = cfa_pattern(raw.cfa)  # 2×2 Bayer, 6×6 X-Trans, 4×4 Quad Bayer or RGBW
            codes = np.where(pattern == WHITE, DNG_WHITE_CODE, pattern)  # TIFF/EP colour codes: white is 6
            plane_colours = (0, 1, 2, DNG_WHITE_CODE) if channel_count(raw.cfa) == 4 else (0, 1, 2)
            tags += [
                (DNG_TAGS["CFARepeatPatternDim"], _TIFF_SHORT, 2, tuple(int(n) for n in pattern.shape), True),
                (DNG_TAGS["CFAPattern"], _TIFF_BYTE, pattern.size, tuple(int(c) for c in codes.ravel()), True),
                (DNG_TAGS["CFAPlaneColor"], _TIFF_BYTE, len(plane_colours), plane_colours, True),
                (DNG_TAGS["CFALayout"], _TIFF_SHORT, 1, (1,), True),
            ]
        tags += _colour_tags(raw)
        if raw.as_shot_neutral is not None:
            neutral = np.asarray(raw.as_shot_neutral, dtype=float)
            planes = channel_count(raw.cfa) if raw.cfa != LINEAR else 3
            if neutral.shape != (planes,) or not np.all(neutral > 0):
                raise RawFormatError(f"as_shot_neutral must be {planes} positive numbers (one per colour plane); "
                                     f"got {neutral}")
            tags.append((DNG_TAGS["AsShotNeutral"], _TIFF_RATIONAL, planes, _rationals(neutral, signed=False), True))
    tags += _rendering_tags(raw)
    calibration = (raw.meta or {}).get("colour_calibration")
    if calibration and raw.color_matrix is not None:  # which reflectances the matrices were fitted on
        tags.append((DNG_TAGS["ProfileName"], _TIFF_ASCII, 0,
                     _ascii(f"spectral_cam: matrices fitted on {calibration['training_set']} "
                            f"({calibration['training_count']} reflectances)"), True))
    if raw.noise_profile is not None:
        scale, offset = (float(v) for v in raw.noise_profile)
        tags.append((DNG_TAGS["NoiseProfile"], _TIFF_DOUBLE, 2, (scale, offset), True))
    tags += _crop_tags(raw.crop, mosaic.shape[:2])
    capture = _capture_tags(raw.meta or {})
    exif = [t for t in capture if t[0] in EXIF_IFD_TAGS]
    tags += [t for t in capture if t[0] not in EXIF_IFD_TAGS] + [(_EXIF_PLACEHOLDER, _TIFF_LONG, 1, (0,), True)]
    with atomic_path(path) as tmp:
        photometric = "minisblack" if monochrome else "rgb" if linear else "cfa"
        tifffile.imwrite(tmp, mosaic, photometric=photometric, planarconfig="contig" if linear else None,
                         subfiletype=0, software=_ascii(software), extratags=tags, metadata=None)
        if monochrome or linear:  # tifffile does not write LinearRaw itself; set the tag in place
            with tifffile.TiffFile(tmp, mode="r+b") as tif:
                tif.pages[0].tags["PhotometricInterpretation"].overwrite(PHOTOMETRIC_LINEAR_RAW)
        _write_exif_ifd(tmp, exif)
    return path


#: The byte-order mark and magic of a DNG camera profile file (DCP): TIFF's layout, "IIRC" for "II*\0".
DCP_MAGIC = b"IIRC"


def write_dcp(raw: RawImage, path, *, name: str | None = None) -> Path:
    """Write a RAW's camera profile as a DNG Camera Profile file (``.dcp``, atomically).

    What the DNG carries of its colour — ColorMatrix1/2, CalibrationIlluminant1/2, ForwardMatrix1/2
    and ProfileHueSatMap — in the standalone form RawTherapee (``InputProfile=file:<path>``),
    Lightroom and Camera Raw load as an input profile. A TIFF structure whose magic is "IIRC".

    Parameters
    ----------
    raw : RawImage
        A RAW with ``color_matrix`` (and optionally the rest of the profile).
    path : str or path-like
        Output file (``.dcp``).
    name : str, optional
        ProfileName; default the DNG's ("spectral_cam: matrices fitted on ...").

    Returns
    -------
    pathlib.Path

    Raises
    ------
    RawFormatError
        If the RAW has no colour matrix, or a colour or forward matrix is singular (issue 39 #31).

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 "Camera Profiles" (the DCP file:
       "IIRC" header, UniqueCameraModel, ProfileName, ProfileEmbedPolicy and the colour tags).
    """
    import tifffile

    if raw.color_matrix is None:
        raise RawFormatError("a camera profile needs the RAW's color_matrix (ColorMatrix1); this RAW has none")
    path = Path(path)
    calibration = (raw.meta or {}).get("colour_calibration")
    if name is None:
        name = (f"spectral_cam: matrices fitted on {calibration['training_set']}" if calibration
                else f"spectral_cam {raw.camera_model}")
    tags = [(DNG_TAGS["UniqueCameraModel"], _TIFF_ASCII, 0, _ascii(raw.camera_model or "spectral_cam"), True),
            (DNG_TAGS["ProfileName"], _TIFF_ASCII, 0, _ascii(name), True),
            (DNG_TAGS["ProfileEmbedPolicy"], _TIFF_LONG, 1, (3,), True)] + _colour_tags(raw)
    with atomic_path(path) as tmp:
        tifffile.imwrite(tmp, np.zeros((1, 1), np.uint8), extratags=tags, metadata=None)
        with open(tmp, "r+b") as handle:
            handle.write(DCP_MAGIC)
    return path
