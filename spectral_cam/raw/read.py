"""A RawImage from any raw file: whatever LibRaw supports (DNG or a camera's own format), read
through rawpy.

LibRaw does not expose a DNG's ColorMatrix directly: its ``color_matrix`` is the camera →
sRGB matrix it derived from it (``rgb_xyz_matrix`` stays zero for DNGs), so the XYZ →
camera matrix is recovered by inverting LibRaw's derivation (:mod:`spectral_cam.raw.colour_tags`, with
the DNG's own colour tags). A file is refused with the reason (:mod:`spectral_cam.raw.file_checks`)
rather than developed from missing data.

References
----------
.. [1] Adobe (2023). Digital Negative (DNG) Specification, version 1.7.1.0, ch. 6 (colour).
.. [2] LibRaw 0.21 (libraw_internal ``cam_xyz_coeff``: rgb_cam = (diag(1/pre_mul)·
   cam_xyz·xyz_rgb)⁻¹ with rows of cam_xyz·xyz_rgb normalised to sum 1).
.. [3] rawpy documentation, https://letmaik.github.io/rawpy/api/rawpy.RawPy.html
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..cfa import EXTENDED_PATTERNS, LINEAR, channel_count
from ..errors import RawFormatError
from .colour_tags import (  # noqa: F401 (colour_tag_problems: its old home)
    _daylight_matrix,
    _profile,
    _rational_matrix,
    _third_calibration,
    _tungsten_matrix,
    _tungsten_slot,
    _xyz_to_camera_from_libraw,
    _xyz_to_camera_from_table,
    colour_tag_problems,
)
from .dng import DNG_TAGS
from .file_checks import (  # noqa: F401 (the public names: their old home)
    LIBRAW_MIN_SIDE_PX,  # noqa: F401
    MIN_BLACK_FOR_ZERO_CHECK,  # noqa: F401
    UNSUPPORTED_COMPRESSION,  # noqa: F401
    _check_data_in_file,
    _check_data_present,
    _check_tiff_cfa,
    _check_white_level,
    _declared_tile,
    _libraw_messages,
    _quiet,
    _size_hint,
    _tiff_ifds,
    unsupported_reason,
)
from .image import RawImage


def _cfa_string(pattern, description: bytes, colors: int) -> str:
    if colors == 1 or pattern is None:
        return "none"
    pattern = np.asarray(pattern)
    letters = description.decode("ascii", "replace")
    if pattern.shape != (2, 2) and colors == 3:  # a larger tile LibRaw knows (X-Trans)
        codes = np.array([{"R": 0, "G": 1, "B": 2}.get(letters[i], -1) for i in pattern.ravel()]).reshape(pattern.shape)
        for name, tile in EXTENDED_PATTERNS.items():
            if np.array_equal(codes, np.array(tile)):
                return name
    if pattern.shape != (2, 2) or colors != 3:
        raise RawFormatError(
            f"unsupported colour filter array ({pattern.shape[0]}×{pattern.shape[1]} tile of "
            f"{letters!r}); spectral_cam reads 2×2 Bayer (RGGB, BGGR, GRBG, GBRG), X-Trans, Quad Bayer and "
            "monochrome raws")
    cfa = "".join(letters[i] for i in pattern.ravel())
    if sorted(cfa) != sorted("RGGB"):
        raise RawFormatError(f"unsupported colour filter array {cfa!r}; need a Bayer tile of R, G, G, B")
    return cfa


def _tiff_extras(path: Path) -> dict:
    """NoiseProfile, UniqueCameraModel and Make/Model from a TIFF-based raw (best effort)."""
    import tifffile

    extras: dict = {}
    try:
        with _quiet(), tifffile.TiffFile(path) as tif:
            for page in tif.pages:
                tags = page.tags
                for name in ("NoiseProfile", "UniqueCameraModel", "Make", "Model", "ColorMatrix1",
                             "ColorMatrix2", "CalibrationIlluminant1", "CalibrationIlluminant2", "WhiteLevel",
                             "DefaultCropOrigin", "DefaultCropSize", "BaselineExposure", "ProfileToneCurve",
                             "ForwardMatrix1", "ForwardMatrix2", "ProfileHueSatMapDims", "ProfileHueSatMapData1",
                             "ProfileHueSatMapData2", "AsShotNeutral", "CalibrationIlluminant3", "ColorMatrix3",
                             "ForwardMatrix3", "IlluminantData3", "ProfileHueSatMapData3"):
                    tag = tags.get(DNG_TAGS[name])
                    if tag is not None and name not in extras:
                        extras[name] = tag.value
    except Exception:  # not a TIFF container (CR3, RAF, ...): rawpy's fields are all there is
        return {}
    return extras


def _tag_numbers(value) -> list[float]:
    """A TIFF SHORT/LONG/RATIONAL tag's values as floats (tifffile gives rationals as pairs)."""
    flat = np.asarray(value, dtype=float).ravel()
    return list(flat) if flat.size == 2 else [flat[i] / flat[i + 1] for i in range(0, flat.size, 2)]


def _default_crop(path: Path, extras: dict, sizes, shape) -> tuple[int, int, int, int] | None:
    """(top, left, height, width) of the image in the raw mosaic: a DNG's DefaultCropOrigin
    and DefaultCropSize (relative to its ActiveArea, which LibRaw's visible area already is),
    else the camera's own crop as LibRaw reports it (relative to the whole raw, so shifted by
    the visible area's margins, and kept inside it: a camera's crop is advice, e.g. a Canon
    30D's is one row taller than its visible area); None when the whole mosaic is the image."""
    origin, size = extras.get("DefaultCropOrigin"), extras.get("DefaultCropSize")
    if origin is not None and size is not None:
        try:
            (left, top), (width, height) = (_tag_numbers(origin)[:2], _tag_numbers(size)[:2])
            crop = tuple(int(round(v)) for v in (top, left, height, width))
        except (TypeError, ValueError, ZeroDivisionError, OverflowError):
            raise RawFormatError(f"{path}: DefaultCropOrigin {origin!r} / DefaultCropSize {size!r} are not two "
                                 "numbers each; the file's crop tags are corrupt") from None
    elif getattr(sizes, "crop_width", 0) and getattr(sizes, "crop_height", 0):
        top = max(int(sizes.crop_top_margin) - int(sizes.top_margin), 0)
        left = max(int(sizes.crop_left_margin) - int(sizes.left_margin), 0)
        height = min(int(sizes.crop_height), shape[0] - top)
        width = min(int(sizes.crop_width), shape[1] - left)
        if height < 1 or width < 1:
            return None
        crop = (top, left, height, width)
    else:
        return None
    if crop == (0, 0, *shape):
        return None
    top, left, height, width = crop
    if top < 0 or left < 0 or height < 1 or width < 1 or top + height > shape[0] or left + width > shape[1]:
        raise RawFormatError(f"{path}: the default crop (origin {left}, {top}; size {width} × {height}) does not "
                             f"lie inside the {shape[1]} × {shape[0]} raw image; the file's crop tags are corrupt")
    return crop


def _baseline_exposure(value) -> float:
    """BaselineExposure (SRATIONAL, stops) as a number; 0 when absent or unreadable."""
    if value is None:
        return 0.0
    try:
        flat = np.ravel(np.asarray(value, dtype=float))  # tifffile: (numerator, denominator), or the value
    except (TypeError, ValueError):  # a corrupt tag type (e.g. ASCII) is no tag
        return 0.0
    ev = flat[0] / flat[1] if flat.size == 2 and flat[1] != 0 else float(flat[0]) if flat.size == 1 else 0.0
    return ev if np.isfinite(ev) and abs(ev) <= 20 else 0.0


def _tone_curve(value) -> np.ndarray | None:
    """ProfileToneCurve (FLOAT pairs) as (N, 2); None when absent or malformed."""
    if value is None:
        return None
    try:
        flat = np.asarray(value, dtype=np.float64).ravel()
    except (TypeError, ValueError):  # a corrupt tag type is no curve
        return None
    if flat.size < 4 or flat.size % 2 or not np.all(np.isfinite(flat)):
        return None
    return flat.reshape(-1, 2)


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
        ``camera_model`` from the DNG tags when present. A malformed or singular ColorMatrixN /
        ForwardMatrixN is dropped and named in ``meta["colour_tag_problems"]`` (the develop's
        messages repeat it).

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

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> from spectral_cam.raw import RawImage, read_raw, write_dng
    >>> path = write_dng(RawImage(np.full((32, 32), 100, np.uint16), "RGGB", 64.0, 4095),
    ...                  pathlib.Path(tempfile.mkdtemp()) / "flat.dng")
    >>> raw = read_raw(path)
    >>> raw.mosaic.shape, raw.cfa, float(np.mean(raw.black_level)), raw.white_level
    ((32, 32), 'RGGB', 64.0, 4095)
    """
    path = Path(path)
    if not path.is_file():
        raise RawFormatError(f"raw file {str(path)!r} does not exist")
    if path.stat().st_size == 0:  # LibRaw said "Input/output error" (issue 25 #16)
        raise RawFormatError(f"{path} is empty (0 bytes): not a raw file; give a DNG or a camera raw")
    ifds = _tiff_ifds(path)  # the file's structure, read once for both checks
    _check_tiff_cfa(path, ifds)
    _check_data_in_file(path, ifds)
    read = _read_libraw(path, ifds)
    extras = _tiff_extras(path)
    planes = channel_count(read.cfa) if read.cfa not in ("none", LINEAR) else 3
    colour, problems = _colour(read, extras, planes)
    _check_white_level(path, extras.get("WhiteLevel"), read.black_levels)
    return RawImage(
        mosaic=read.mosaic,
        cfa=read.cfa,
        black_level=_black_level(read),
        white_level=read.white,
        baseline_exposure=_baseline_exposure(extras.get("BaselineExposure")),
        profile_tone_curve=_tone_curve(extras.get("ProfileToneCurve")),
        crop=_default_crop(path, extras, read.sizes, read.mosaic.shape[:2]),
        **colour,
        calibration_3=(_third_calibration(extras, planes, colour) if colour["color_matrix_2"] is not None
                       else None),
        noise_profile=_noise_profile(extras),
        camera_model=str(extras.get("UniqueCameraModel", "")).strip(),
        meta={
            "source": str(path),
            "black_level_per_channel": read.black_levels,
            "make": str(extras.get("Make", "")).strip(),
            "model": str(extras.get("Model", "")).strip(),
            "libraw_raw_type": read.raw_type,
            **({"colour_tag_problems": list(problems.values())} if problems else {}),
        },
    )


class _LibRawRead(NamedTuple):
    """What :func:`read_raw` takes from LibRaw (rawpy's names)."""

    mosaic: np.ndarray  # the visible raw area, uint16 (H, W), or (H, W, 3) for a Linear Raw
    cfa: str
    colors: int
    black_levels: list  # per colour index
    pattern: np.ndarray  # raw_pattern: each CFA site's colour index
    white: int
    camera_wb: np.ndarray
    daylight: np.ndarray
    rgb_cam: np.ndarray  # LibRaw's camera → sRGB matrix
    cam_xyz: np.ndarray  # its table's XYZ → camera matrix
    raw_type: str
    sizes: object


def _read_libraw(path: Path, ifds) -> _LibRawRead:
    """Decode the file with LibRaw; refused (RawFormatError, with the reason) when LibRaw cannot, says
    anything while reading, or leaves no single-plane mosaic, no three-colour linear raw, or no data."""
    import rawpy

    try:
        with _libraw_messages() as said, rawpy.imread(str(path)) as handle:
            mosaic = np.array(handle.raw_image_visible, dtype=np.uint16, copy=True)
            colors = int(handle.num_colors)
            stacked = handle.raw_type == rawpy.RawType.Stack
            if stacked and colors == 3 and mosaic.ndim == 3 and mosaic.shape[2] >= 3:
                # a Linear Raw DNG: LibRaw stacks R, G, B (and a spare fourth plane) per pixel
                mosaic, cfa = np.ascontiguousarray(mosaic[..., :3]), LINEAR
            else:
                cfa = _declared_tile(ifds) or _cfa_string(handle.raw_pattern, bytes(handle.color_desc), colors)
            read = _LibRawRead(
                mosaic, cfa, colors, [float(v) for v in handle.black_level_per_channel],
                np.asarray(handle.raw_pattern), int(handle.white_level),
                np.asarray(handle.camera_whitebalance, dtype=float), np.asarray(handle.daylight_whitebalance, dtype=float),
                np.asarray(handle.color_matrix, dtype=float), np.asarray(handle.rgb_xyz_matrix, dtype=float),
                str(handle.raw_type), handle.sizes)
    except RawFormatError:
        raise
    except (rawpy.LibRawError, OSError, ValueError, NotImplementedError) as exc:
        reason = unsupported_reason(path)
        if reason:  # a valid file LibRaw cannot decode is not "corrupt"
            raise RawFormatError(f"{path}: {reason}") from None
        # rawpy raises NotImplementedError ("filters: N") for CFA layouts it cannot map
        libraw = f" (LibRaw: {'; '.join(said)})" if said else ""
        raise RawFormatError(
            f"{path} is not a readable raw file (missing data, truncated or corrupt){_size_hint(path)}: "
            f"{type(exc).__name__}: {exc}{libraw}") from None
    if said:  # LibRaw's data callback reports a read past the end or corrupt data, then goes on with zeros
        raise RawFormatError(f"{path} is truncated or corrupt: LibRaw read it with errors ({'; '.join(said)})")
    if read.mosaic.size == 0 or (read.mosaic.ndim != 2 and read.cfa != LINEAR):
        raise RawFormatError(f"{path}: no single-plane raw mosaic nor three-colour linear raw (LibRaw raw type "
                             f"{read.raw_type}, {read.colors} colours)")
    _check_data_present(path, read.mosaic, read.black_levels, '.'.join(map(str, rawpy.libraw_version)))
    return read


def _colour(read: _LibRawRead, extras: dict, planes: int) -> tuple[dict, dict]:
    """(RawImage's colour fields but the third calibration, the colour tags' problems by tag name): the
    XYZ → camera matrix from LibRaw (or, for four planes, the DNG's own tags) and the neutral, the
    Standard A matrix and the profile from the DNG's tags; none of them from a tag that has a problem."""
    neutral = matrix = None
    if read.cfa != "none":
        wb = read.camera_wb[:3]
        if np.all(wb > 0):
            neutral = (1.0 / wb) / (1.0 / wb).max()
        matrix = _xyz_to_camera_from_libraw(read.rgb_cam, read.daylight)
        if matrix is None:
            matrix = _xyz_to_camera_from_table(read.cam_xyz)
    if planes == 4:  # RGBW: LibRaw's colours are four others (GMCY); the DNG's own tags say what they are
        matrix = _daylight_matrix(extras, 4)
        tag = extras.get("AsShotNeutral")
        neutral = None if tag is None else _rational_matrix(tag, (1, 4))
        neutral = None if neutral is None or np.any(neutral <= 0) else neutral[0] / neutral[0].max()
    problems = colour_tag_problems(extras, planes) if read.cfa != "none" else {}
    daylight_slot = next((n for n in (1, 2) if n != _tungsten_slot(extras) and f"ColorMatrix{n}" in extras), None)
    if f"ColorMatrix{daylight_slot}" in problems:
        matrix = None  # LibRaw derives nothing usable from it: the develop says which tag, not "none"
    tungsten = _tungsten_matrix(extras, planes) if matrix is not None else None
    profile = _profile(extras, planes) if matrix is not None else {}
    return {"color_matrix": matrix, "color_matrix_2": tungsten, **profile, "as_shot_neutral": neutral}, problems


def _black_level(read: _LibRawRead):
    """One black level (DN), or one per CFA site (2 × 2) or colour (Linear Raw) where they differ."""
    black_levels, cfa, pattern = read.black_levels, read.cfa, read.pattern
    # LibRaw orders black_level_per_channel by colour index; raw_pattern maps sites to it
    if cfa == LINEAR:
        return float(black_levels[0]) if len(set(black_levels[:3])) == 1 else np.asarray(black_levels[:3], float)
    if cfa == "none" or len(set(black_levels[:4])) == 1 or pattern.shape != (2, 2):
        return float(black_levels[0])
    return np.asarray(black_levels, dtype=float)[pattern]


def _noise_profile(extras: dict) -> tuple[float, float] | None:
    """NoiseProfile's (S, O); None when absent, of a corrupt count (one value) or non-finite."""
    noise = extras.get("NoiseProfile")
    noise = np.atleast_1d(np.asarray(noise, dtype=float)) if noise is not None else np.empty(0)
    return (float(noise[0]), float(noise[1])) if noise.size >= 2 and np.all(np.isfinite(noise[:2])) else None
