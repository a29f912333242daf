"""RAW images: the :class:`RawImage` type, DNG writing (tifffile) and reading (rawpy).

:func:`write_dng` writes one uncompressed raw IFD with the tags LibRaw and Adobe readers
need: DNGVersion, PhotometricInterpretation = 32803 (CFA) with CFARepeatPatternDim +
CFAPattern — or 34892 (LinearRaw, one sample) for a monochrome sensor — BlackLevel
(+ BlackLevelRepeatDim), WhiteLevel, ColorMatrix1 with CalibrationIlluminant1 = 21 (D65),
AsShotNeutral, NoiseProfile, UniqueCameraModel and Make/Model.

:func:`read_raw` opens any raw file LibRaw supports (DNG or a camera's own format) through
rawpy. LibRaw does not expose a DNG's ColorMatrix directly: its ``color_matrix`` is the
camera → sRGB matrix it derived from it (``rgb_xyz_matrix`` stays zero for DNGs), so the
XYZ → camera matrix is recovered by inverting LibRaw's derivation.

References
----------
.. [1] Adobe (2023). Digital Negative (DNG) Specification, version 1.7.1.0, ch. 4 (tags),
   ch. 6 (colour).
.. [2] LibRaw 0.21 (libraw_internal ``cam_xyz_coeff``: rgb_cam = (diag(1/pre_mul)·
   cam_xyz·xyz_rgb)⁻¹ with rows of cam_xyz·xyz_rgb normalised to sum 1).
.. [3] rawpy documentation, https://letmaik.github.io/rawpy/api/rawpy.RawPy.html
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import RawFormatError
from .io import atomic_path

__all__ = ["RawImage", "write_dng", "read_raw", "DNG_TAGS"]

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
_CFA_CODES = {"R": 0, "G": 1, "B": 2}
_TIFF_BYTE, _TIFF_ASCII, _TIFF_SHORT, _TIFF_LONG, _TIFF_RATIONAL, _TIFF_SRATIONAL, _TIFF_DOUBLE = 1, 2, 3, 4, 5, 10, 12
_RATIONAL_DENOMINATOR = 1_000_000
#: sRGB (D65) → XYZ as LibRaw hard-codes it (``xyz_rgb``), needed to undo its derivation.
_LIBRAW_XYZ_RGB = np.array([[0.412453, 0.357580, 0.180423],
                            [0.212671, 0.715160, 0.072169],
                            [0.019334, 0.119193, 0.950227]])


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


def _check_raw(raw: RawImage) -> np.ndarray:
    mosaic = np.asarray(raw.mosaic)
    if mosaic.ndim != 2 or mosaic.size == 0:
        raise RawFormatError(f"RawImage.mosaic must be a non-empty (H, W) array; got shape {mosaic.shape}")
    if mosaic.dtype != np.uint16:
        if not np.issubdtype(mosaic.dtype, np.integer) or mosaic.min() < 0 or mosaic.max() > 65535:
            raise RawFormatError(f"RawImage.mosaic must hold whole numbers in 0..65535; got {mosaic.dtype}")
        mosaic = mosaic.astype(np.uint16)
    if raw.cfa != "none" and (len(raw.cfa) != 4 or set(raw.cfa) - set("RGB") or raw.cfa.count("G") != 2):
        raise RawFormatError(f"RawImage.cfa = {raw.cfa!r}; valid: RGGB, BGGR, GRBG, GBRG, none")
    black = np.asarray(raw.black_level, dtype=float)
    if black.ndim not in (0, 2) or (black.ndim == 2 and black.shape != (2, 2)):
        raise RawFormatError(f"black_level must be a number or a 2×2 array per CFA site; got shape {black.shape}")
    if not 0 < int(raw.white_level) <= 65535 or not (0 <= black.min() and black.max() < int(raw.white_level)):
        raise RawFormatError(f"levels black = {raw.black_level!r}, white = {raw.white_level!r}: need "
                             "0 <= black < white <= 65535")
    return np.ascontiguousarray(mosaic)


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
    """
    import tifffile

    mosaic = _check_raw(raw)
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
            (DNG_TAGS["CFAPattern"], _TIFF_BYTE, 4, tuple(_CFA_CODES[c] for c in raw.cfa), True),
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


# ----------------------------------------------------------------------------- reading
def _xyz_to_camera_from_libraw(rgb_cam: np.ndarray, daylight: np.ndarray) -> np.ndarray | None:
    """Undo LibRaw's cam_xyz → rgb_cam derivation; normalise D65 white → max 1."""
    rgb_cam = np.asarray(rgb_cam, dtype=float)[:3, :3]
    pre_mul = np.asarray(daylight, dtype=float)[:3]
    if not (np.all(np.isfinite(rgb_cam)) and np.all(pre_mul > 0)) or abs(np.linalg.det(rgb_cam)) < 1e-12:
        return None
    cam_xyz = np.diag(1.0 / pre_mul) @ np.linalg.inv(rgb_cam) @ np.linalg.inv(_LIBRAW_XYZ_RGB)
    neutral = cam_xyz @ _LIBRAW_XYZ_RGB.sum(axis=1)
    if not neutral.max() > 0:
        return None
    return cam_xyz / neutral.max()


def _cfa_string(pattern, description: bytes, colors: int) -> str:
    if colors == 1 or pattern is None:
        return "none"
    pattern = np.asarray(pattern)
    letters = description.decode("ascii", "replace")
    if pattern.shape != (2, 2) or colors != 3:
        raise RawFormatError(
            f"unsupported colour filter array ({pattern.shape[0]}×{pattern.shape[1]} tile of "
            f"{letters!r}); spectral_cam reads 2×2 Bayer (RGGB, BGGR, GRBG, GBRG) and monochrome raws")
    cfa = "".join(letters[i] for i in pattern.ravel())
    if sorted(cfa) != sorted("RGGB"):
        raise RawFormatError(f"unsupported colour filter array {cfa!r}; need a Bayer tile of R, G, G, B")
    return cfa


def _tiff_extras(path: Path) -> dict:
    """NoiseProfile, UniqueCameraModel and Make/Model from a TIFF-based raw (best effort)."""
    import tifffile

    extras: dict = {}
    try:
        with tifffile.TiffFile(path) as tif:
            for page in tif.pages:
                tags = page.tags
                for name in ("NoiseProfile", "UniqueCameraModel", "Make", "Model", "ColorMatrix1",
                             "ColorMatrix2", "CalibrationIlluminant1", "CalibrationIlluminant2"):
                    tag = tags.get(DNG_TAGS[name])
                    if tag is not None and name not in extras:
                        extras[name] = tag.value
    except Exception:  # not a TIFF container (CR3, RAF, ...): rawpy's fields are all there is
        return {}
    return extras


#: LibRaw refuses raw images smaller than this on either side.
LIBRAW_MIN_SIDE_PX = 22


def _raw_ifds(path: Path):
    """The TIFF pages of a TIFF-based raw holding a CFA image (empty for other formats)."""
    import tifffile

    found = []
    try:
        with tifffile.TiffFile(path) as tif:
            for page in tif.pages:
                tag = page.tags.get(262)
                photometric = tag.value if tag is not None and isinstance(tag.value, int) else None
                shape = tuple(int(n) for n in page.shape if isinstance(n, (int, np.integer)))
                found.append((photometric, {code: page.tags.get(code) is not None for code in (33421, 33422)},
                              shape))
    except Exception:  # not a TIFF container, or corrupt: LibRaw gives the verdict
        return []
    return found


def _check_tiff_cfa(path: Path) -> None:
    """Refuse a CFA image (PhotometricInterpretation 32803) without CFARepeatPatternDim or
    CFAPattern: LibRaw would decode it with a stale pattern left from the previous file."""
    for photometric, has, _ in _raw_ifds(path):
        if photometric == 32803 and not all(has.values()):
            raise RawFormatError(f"{path}: a CFA raw image needs the CFARepeatPatternDim (33421) and "
                                 "CFAPattern (33422) tags; this one lacks them")


def _size_hint(path: Path) -> str:
    for photometric, _, shape in _raw_ifds(path):
        if photometric in (32803, 34892) and len(shape) >= 2 and min(shape[:2]) < LIBRAW_MIN_SIDE_PX:
            return (f" (its raw image is {shape[1]}×{shape[0]} px; LibRaw reads no side under "
                    f"{LIBRAW_MIN_SIDE_PX} px)")
    return ""


#: EXIF LightSource codes treated as Standard Illuminant A (≈ 2856 K) for interpolation.
_TUNGSTEN_CODES = (ILLUMINANT_A, 3)


def _rational_matrix(value) -> np.ndarray | None:
    """A 3×3 matrix from a TIFF (S)RATIONAL tag as tifffile returns it (values or num/den pairs)."""
    flat = np.asarray(value, dtype=float).reshape(-1)
    if flat.size == 18:
        den = flat[1::2]
        if np.any(den == 0):
            return None
        flat = flat[0::2] / den
    return flat.reshape(3, 3) if flat.size == 9 and np.all(np.isfinite(flat)) else None


def _tungsten_matrix(extras: dict) -> np.ndarray | None:
    """The DNG colour matrix calibrated under Standard Illuminant A, from either slot."""
    for number in (1, 2):
        code = extras.get(f"CalibrationIlluminant{number}")
        if code is not None and int(np.asarray(code).reshape(-1)[0]) in _TUNGSTEN_CODES:
            value = extras.get(f"ColorMatrix{number}")
            return None if value is None else _rational_matrix(value)
    return None


def read_raw(path) -> RawImage:
    """Read any raw file LibRaw supports (DNG or a camera's format) into a RawImage.

    Parameters
    ----------
    path : str or path-like
        The raw file.

    Returns
    -------
    RawImage
        ``mosaic``: the visible raw area (uint16); ``cfa`` from LibRaw's pattern and colour
        description; ``black_level`` (a number, or a 2×2 array per CFA site when the
        channels' levels differ; LibRaw's list in ``meta["black_level_per_channel"]``); ``white_level``; ``as_shot_neutral`` =
        1 / camera white-balance multipliers (max 1); ``color_matrix`` = XYZ(D65) → camera
        recovered from LibRaw's ``color_matrix`` (camera → sRGB) and daylight multipliers,
        normalised so D65's white maps to a neutral of max 1; ``noise_profile`` and
        ``camera_model`` from the DNG tags when present.

    Raises
    ------
    RawFormatError
        If the file is missing, not a raw file, truncated or corrupt, or has a colour
        filter array other than a 2×2 Bayer tile or none.

    References
    ----------
    .. [1] rawpy API (raw_image_visible, raw_pattern, color_desc, black_level_per_channel,
       white_level, camera_whitebalance, daylight_whitebalance, color_matrix).
    .. [2] Adobe (2023). DNG Specification 1.7.1.0.
    """
    import rawpy

    path = Path(path)
    if not path.is_file():
        raise RawFormatError(f"raw file {str(path)!r} does not exist")
    _check_tiff_cfa(path)
    try:
        with rawpy.imread(str(path)) as handle:
            mosaic = np.array(handle.raw_image_visible, dtype=np.uint16, copy=True)
            colors = int(handle.num_colors)
            cfa = _cfa_string(handle.raw_pattern, bytes(handle.color_desc), colors)
            black_levels = [float(v) for v in handle.black_level_per_channel]
            pattern = np.asarray(handle.raw_pattern)
            white = int(handle.white_level)
            camera_wb = np.asarray(handle.camera_whitebalance, dtype=float)
            daylight = np.asarray(handle.daylight_whitebalance, dtype=float)
            rgb_cam = np.asarray(handle.color_matrix, dtype=float)
            raw_type = str(handle.raw_type)
    except RawFormatError:
        raise
    except (rawpy.LibRawError, OSError, ValueError, NotImplementedError) as exc:
        # rawpy raises NotImplementedError ("filters: N") for CFA layouts it cannot map
        raise RawFormatError(
            f"{path} is not a readable raw file (missing data, truncated or corrupt){_size_hint(path)}: "
            f"{type(exc).__name__}: {exc}") from None
    if mosaic.ndim != 2 or mosaic.size == 0:
        raise RawFormatError(f"{path}: no single-plane raw mosaic (LibRaw raw type {raw_type})")
    neutral = matrix = None
    if cfa != "none":
        wb = camera_wb[:3]
        if np.all(wb > 0):
            neutral = (1.0 / wb) / (1.0 / wb).max()
        matrix = _xyz_to_camera_from_libraw(rgb_cam, daylight)
    extras = _tiff_extras(path)
    noise = extras.get("NoiseProfile")
    noise_profile = (float(noise[0]), float(noise[1])) if noise is not None and len(noise) >= 2 else None
    # LibRaw orders black_level_per_channel by colour index; raw_pattern maps sites to it
    if cfa == "none" or len(set(black_levels[:4])) == 1 or pattern.shape != (2, 2):
        black = float(black_levels[0])
    else:
        black = np.asarray(black_levels, dtype=float)[pattern]
    return RawImage(
        mosaic=mosaic,
        cfa=cfa,
        black_level=black,
        white_level=white,
        color_matrix=matrix,
        color_matrix_2=_tungsten_matrix(extras) if matrix is not None else None,
        as_shot_neutral=neutral,
        noise_profile=noise_profile,
        camera_model=str(extras.get("UniqueCameraModel", "")).strip(),
        meta={
            "source": str(path),
            "black_level_per_channel": black_levels,
            "make": str(extras.get("Make", "")).strip(),
            "model": str(extras.get("Model", "")).strip(),
            "libraw_raw_type": raw_type,
        },
    )
