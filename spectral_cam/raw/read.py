"""RAW reading: any raw file LibRaw supports (DNG or a camera's own format), through rawpy.

LibRaw does not expose a DNG's ColorMatrix directly: its ``color_matrix`` is the camera →
sRGB matrix it derived from it (``rgb_xyz_matrix`` stays zero for DNGs), so the XYZ →
camera matrix is recovered by inverting LibRaw's derivation.

References
----------
.. [1] Adobe (2023). Digital Negative (DNG) Specification, version 1.7.1.0, ch. 6 (colour).
.. [2] LibRaw 0.21 (libraw_internal ``cam_xyz_coeff``: rgb_cam = (diag(1/pre_mul)·
   cam_xyz·xyz_rgb)⁻¹ with rows of cam_xyz·xyz_rgb normalised to sum 1).
.. [3] rawpy documentation, https://letmaik.github.io/rawpy/api/rawpy.RawPy.html
"""

from __future__ import annotations

import contextlib
import logging
from pathlib import Path
from typing import Iterator, NamedTuple

import numpy as np

from ..cfa import DNG_WHITE_CODE, EXTENDED_PATTERNS, LINEAR, WHITE, channel_count
from ..errors import ConfigError, RawFormatError
from .dng import DNG_TAGS, ILLUMINANT_A
from .hue_sat_map import HueSatMap
from .image import RawImage

#: sRGB (D65) → XYZ as LibRaw hard-codes it (``xyz_rgb``), needed to undo its derivation.
_LIBRAW_XYZ_RGB = np.array([[0.412453, 0.357580, 0.180423],
                            [0.212671, 0.715160, 0.072169],
                            [0.019334, 0.119193, 0.950227]])


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


def _xyz_to_camera_from_table(cam_xyz: np.ndarray) -> np.ndarray | None:
    """LibRaw's own XYZ(D65) → camera matrix for the camera (``rgb_xyz_matrix``: Adobe's
    ColorMatrix for that model, from LibRaw's table), D65 white → max 1; None if absent.
    For a proprietary raw LibRaw derives rgb_cam only while processing, so this is the matrix."""
    cam_xyz = np.asarray(cam_xyz, dtype=float)[:3, :3]
    if not np.all(np.isfinite(cam_xyz)) or abs(np.linalg.det(cam_xyz)) < 1e-12:
        return None
    neutral = cam_xyz @ _LIBRAW_XYZ_RGB.sum(axis=1)
    return cam_xyz / neutral.max() if neutral.max() > 0 else None


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


#: Black levels (DN) at or above which a 0 sample cannot be read noise: ≥ 8 DN below black is
#: several σ of any camera's read noise at that offset.
MIN_BLACK_FOR_ZERO_CHECK = 8


def _check_data_present(path: Path, mosaic: np.ndarray, black_levels, libraw: str) -> None:
    """Refuse a raw whose image data is missing: LibRaw leaves 0 where a truncated or cut-down
    file (exiftool's test raws: a Canon 350D DNG, a Panasonic RW2) has no data, and the ISP would
    develop it to black with exit 0. Every sample 0; or more than half of them 0 although the
    black level is ≥ 8 DN (read noise does not reach 0 from there); or 99 % of them 0."""
    zeros = 1.0 - np.count_nonzero(mosaic) / mosaic.size
    black = float(np.min(black_levels)) if len(black_levels) else 0.0
    if zeros < 0.99 and not (black >= MIN_BLACK_FOR_ZERO_CHECK and zeros > 0.5):
        return
    what = "every sample is 0" if zeros == 1.0 else f"{zeros:.1%} of the samples are 0, black level {black:g} DN"
    raise RawFormatError(f"{path}: the raw image holds no data ({what}): the file is truncated or cut down, or "
                         f"its image data is in a format LibRaw {libraw} does not decode{_size_hint(path)}")


def _check_white_level(path: Path, tag, black_levels) -> None:
    """Refuse a DNG WhiteLevel at or below its black level: LibRaw then assumes 65535 and the
    image develops several times too dark (a WhiteLevel of 0 on 12-bit data: 16×)."""
    if tag is None:
        return
    levels = np.atleast_1d(np.asarray(tag, dtype=float))
    black = float(np.max(black_levels)) if len(black_levels) else 0.0
    if levels.size == 0 or levels.min() <= black:
        raise RawFormatError(f"{path}: WhiteLevel {levels.astype(int).tolist()} is not above the black level "
                             f"{black:g}; the file's levels are corrupt (WhiteLevel must exceed BlackLevel)")


#: LibRaw refuses raw images smaller than this on either side.
LIBRAW_MIN_SIDE_PX = 22


class _Ifd(NamedTuple):
    """What the raw checks need of one TIFF image file directory."""

    top_level: bool  # an IFD of the main chain (not a SubIFD)
    photometric: int | None
    has_cfa_tags: bool  # CFARepeatPatternDim (33421) and CFAPattern (33422) both present
    shape: tuple[int, ...]
    compression: int | None
    pixels: int
    data_end: int  # where its last strip or tile ends, bytes
    data_bytes: int
    cfa_pattern: tuple = ()  # CFAPattern's colour codes (0 red, 1 green, 2 blue, …)
    cfa_dims: tuple = ()  # CFARepeatPatternDim (rows, columns)


def _tiff_ifds(path: Path) -> list[_Ifd]:
    """Every IFD of a TIFF-based raw, SubIFDs included (empty for other formats, or when
    tifffile cannot read the structure: LibRaw then gives the verdict)."""
    import tifffile

    found = []
    try:
        with _quiet(), tifffile.TiffFile(path) as tif:
            pages = [(page, True) for page in tif.pages]
            while pages:
                page, top_level = pages.pop(0)
                try:
                    pages.extend((sub, False) for sub in (getattr(page, "pages", None) or []))
                except Exception:  # unreadable SubIFDs: the main chain is still checked
                    pass
                tag = page.tags.get(262)
                compression = page.tags.get(259)
                shape = tuple(int(n) for n in page.shape if isinstance(n, (int, np.integer)))
                offsets, counts = page.dataoffsets or (), page.databytecounts or ()
                found.append(_Ifd(
                    top_level=top_level,
                    photometric=tag.value if tag is not None and isinstance(tag.value, int) else None,
                    has_cfa_tags=all(page.tags.get(code) is not None for code in (33421, 33422)),
                    shape=shape,
                    compression=compression.value if compression is not None else None,
                    pixels=int(np.prod(shape[:2])) if len(shape) >= 2 else 0,
                    data_end=max((int(o) + int(c) for o, c in zip(offsets, counts)), default=0),
                    data_bytes=int(sum(int(c) for c in counts)),
                    cfa_pattern=_pattern_codes(page.tags.get(33422)),
                    cfa_dims=_pattern_codes(page.tags.get(33421))))
    except Exception:  # not a TIFF container, or corrupt: LibRaw gives the verdict
        return []
    return found


def _raw_ifds(path: Path) -> list[_Ifd]:
    """The IFDs of the main chain (what LibRaw's CFA and compression checks look at)."""
    return [ifd for ifd in _tiff_ifds(path) if ifd.top_level]


@contextlib.contextmanager
def _quiet():
    """tifffile logs an error for each TIFF-like raw it cannot parse (a Panasonic RW2: "RAW
    format 0x0055 not supported"); our probes only want its answer, LibRaw reads the file."""
    logger = logging.getLogger("tifffile")
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        logger.setLevel(level)


def _check_data_in_file(path: Path, ifds: list[_Ifd]) -> None:
    """Refuse a TIFF-based raw whose image data is not in the file: a large image whose strips
    or tiles end past the end of the file (truncated), or a raw image (CFA or LinearRaw) with less
    than one bit of data per pixel (cut down: a real lossless-JPEG raw needs several). LibRaw
    decodes such files without an error and fills the missing data with zeros or stale memory."""
    size = path.stat().st_size
    for ifd in ifds:
        if ifd.pixels < 1_000_000:
            continue  # thumbnails and small previews
        if ifd.data_end > size:
            raise RawFormatError(f"{path}: the file is truncated: a {ifd.pixels / 1e6:.1f} MP image's data ends at "
                                 f"byte {ifd.data_end}, but the file has {size} bytes")
        if ifd.photometric in (32803, 34892) and ifd.data_bytes * 8 < ifd.pixels:
            raise RawFormatError(f"{path}: the raw image holds no data ({ifd.data_bytes} bytes for "
                                 f"{ifd.pixels / 1e6:.1f} MP, under a bit per pixel): the file is cut down or truncated")


def _pattern_codes(tag) -> tuple:
    if tag is None:
        return ()
    try:
        value = tag.value
        return tuple(int(v) for v in (value if isinstance(value, (tuple, list, bytes, np.ndarray)) else [value]))
    except (TypeError, ValueError):
        return ()


def _declared_tile(ifds: list[_Ifd]) -> str | None:
    """A larger tile (:data:`~spectral_cam.cfa.EXTENDED_PATTERNS`) the raw IFD's CFARepeatPatternDim and
    CFAPattern declare, or None. LibRaw describes a CFA by dcraw's ``filters``, 8 rows × 2 columns at
    most: it reads a 4 × 4 Quad Bayer DNG as a wrong 2 × 2 tile, so the file's own tags decide."""
    for ifd in ifds:
        if ifd.top_level and ifd.photometric == 32803 and len(ifd.cfa_dims) == 2 and ifd.cfa_dims != (2, 2):
            for name, tile in EXTENDED_PATTERNS.items():
                codes = np.where(np.array(tile) == WHITE, DNG_WHITE_CODE, np.array(tile))
                if tuple(ifd.cfa_dims) == codes.shape and tuple(ifd.cfa_pattern) == tuple(codes.ravel()):
                    return name
    return None


def _check_tiff_cfa(path: Path, ifds: list[_Ifd]) -> None:
    """Refuse a CFA image (PhotometricInterpretation 32803) without CFARepeatPatternDim or
    CFAPattern (LibRaw would decode it with a stale pattern left from the previous file), or
    whose CFAPattern lacks one of red, green and blue (0 0 0 0 read as a monochrome, grey image;
    Adobe's SDK rejects it; issue 25 #7)."""
    for ifd in ifds:
        if ifd.top_level and ifd.photometric == 32803 and not ifd.has_cfa_tags:
            raise RawFormatError(f"{path}: a CFA raw image needs the CFARepeatPatternDim (33421) and "
                                 "CFAPattern (33422) tags; this one lacks them")
        if ifd.photometric == 32803 and ifd.cfa_pattern and not {0, 1, 2} <= set(ifd.cfa_pattern):
            raise RawFormatError(f"{path}: CFAPattern {list(ifd.cfa_pattern)} lacks one of red (0), green (1) "
                                 "and blue (2); a Bayer pattern such as RGGB is [0, 1, 1, 2]: the file is corrupt")


#: TIFF Compression codes of raw images LibRaw does not decode (DNG 1.7.1.0 §6, JPEG XL).
UNSUPPORTED_COMPRESSION = {52546: "JPEG XL (DNG 1.7)"}


def unsupported_reason(path: Path) -> str | None:
    """Why LibRaw cannot decode a valid TIFF-based raw (its compression), or None.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, Compression = 52546 (JPEG XL).
    """
    import rawpy

    for ifd in _raw_ifds(path):
        if ifd.photometric in (32803, 34892) and ifd.compression in UNSUPPORTED_COMPRESSION:
            compression = ifd.compression
            return (f"its raw image is {UNSUPPORTED_COMPRESSION[compression]} compressed (Compression "
                    f"{compression}), which LibRaw {'.'.join(map(str, rawpy.libraw_version))} does not decode; "
                    "convert it to an uncompressed or lossless-JPEG DNG (e.g. with Adobe DNG Converter)")
    return None


@contextlib.contextmanager
def _libraw_messages() -> "Iterator[list[str]]":
    """Hold what LibRaw prints on the process's stderr (file descriptor 2: its default data
    callback writes "<file>: Unexpected end of file" there, issue 25 #16) while it reads, and
    yield a list that receives those lines, so they join our one-line error instead of
    leaking above it. Where descriptor 2 cannot be redirected (no such descriptor), nothing
    is held."""
    import os
    import sys
    import tempfile

    lines: list[str] = []
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):
        yield lines
        return
    with tempfile.TemporaryFile() as held:
        os.dup2(held.fileno(), 2)
        try:
            yield lines
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            held.seek(0)
            lines += [line for line in held.read().decode("utf-8", "replace").splitlines() if line.strip()]


def _size_hint(path: Path) -> str:
    for ifd in _raw_ifds(path):
        shape = ifd.shape
        if ifd.photometric in (32803, 34892) and len(shape) >= 2 and min(shape[:2]) < LIBRAW_MIN_SIDE_PX:
            return (f" (its raw image is {shape[1]}×{shape[0]} px; LibRaw reads no side under "
                    f"{LIBRAW_MIN_SIDE_PX} px)")
    return ""


#: EXIF LightSource codes treated as Standard Illuminant A (≈ 2856 K) for interpolation.
_TUNGSTEN_CODES = (ILLUMINANT_A, 3)


def _rational_matrix(value, shape: tuple[int, int] | None = None) -> np.ndarray | None:
    """A matrix from a TIFF (S)RATIONAL tag as tifffile returns it (values or num/den pairs): 3×3, or
    ``shape`` (a four-plane RGBW DNG's 4×3 ColorMatrix, 3×4 ForwardMatrix)."""
    shape = (3, 3) if shape is None else shape
    count = shape[0] * shape[1]
    try:
        flat = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):  # a corrupt tag type
        return None
    if flat.size == 2 * count:
        den = flat[1::2]
        if np.any(den == 0):
            return None
        flat = flat[0::2] / den
    return flat.reshape(shape) if flat.size == count and np.all(np.isfinite(flat)) else None


def _tungsten_slot(extras: dict) -> int | None:
    """The calibration slot (1 or 2) calibrated under Standard Illuminant A, if any."""
    for number in (1, 2):
        try:
            codes = np.asarray(extras.get(f"CalibrationIlluminant{number}", []), dtype=float).reshape(-1)
        except (TypeError, ValueError):  # a corrupt tag type (e.g. ASCII) is no tag
            continue
        if codes.size and codes[0] in _TUNGSTEN_CODES:  # a tag of count 0 (a corrupt file) is no tag
            return number
    return None


def _tungsten_matrix(extras: dict, planes: int = 3) -> np.ndarray | None:
    """The DNG colour matrix calibrated under Standard Illuminant A, from either slot (None when singular)."""
    slot = _tungsten_slot(extras)
    if slot and f"ColorMatrix{slot}" in colour_tag_problems(extras, planes):
        return None
    value = extras.get(f"ColorMatrix{slot}") if slot else None
    return None if value is None else _rational_matrix(value, (planes, 3))


def _daylight_matrix(extras: dict, planes: int) -> np.ndarray | None:
    """The colour matrix of the slot not calibrated under Standard A (a four-plane DNG's, which LibRaw's
    three-colour conversion cannot give)."""
    tungsten = _tungsten_slot(extras)
    slot = next((n for n in (1, 2) if n != tungsten and f"ColorMatrix{n}" in extras), None)
    return None if slot is None else _rational_matrix(extras[f"ColorMatrix{slot}"], (planes, 3))


def colour_tag_problems(extras: dict, planes: int = 3) -> dict[str, str]:
    """What is wrong with each ColorMatrixN / ForwardMatrixN tag present, by tag name: malformed (not
    ``planes``·3 finite numbers) or singular (rank under 3: an all-zero matrix maps every colour to
    black). A reader that drops such a tag says which one it dropped (issue 39 #31).

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 (ColorMatrix is inverted; ForwardMatrix
       maps camera white onto D50).
    """
    problems = {}
    for number in (1, 2):
        code = np.ravel(np.asarray(extras.get(f"CalibrationIlluminant{number}", []), dtype=object))
        light = f"CalibrationIlluminant{number} = {code[0]}" if code.size else f"no CalibrationIlluminant{number}"
        for kind, shape in (("ColorMatrix", (planes, 3)), ("ForwardMatrix", (3, planes))):
            name = f"{kind}{number}"
            if name not in extras:
                continue
            matrix = _rational_matrix(extras[name], shape)
            if matrix is None:
                problems[name] = f"{name} ({light}) is malformed: not {shape[0] * shape[1]} finite numbers"
            elif np.linalg.matrix_rank(matrix) < 3:
                problems[name] = (f"{name} ({light}) is singular (rank {np.linalg.matrix_rank(matrix)}): it maps no "
                                  "camera colour to XYZ")
    return problems


def _profile(extras: dict, planes: int = 3) -> dict:
    """ForwardMatrix and ProfileHueSatMap per calibration: ``forward_matrix``/``hue_sat_map`` of the
    daylight slot (the one that is not Standard A), ``..._2`` of the Standard A slot; None where a
    tag is absent or malformed (a corrupt profile is no profile, as Adobe's reader treats it)."""
    tungsten = _tungsten_slot(extras)
    daylight = next((n for n in (1, 2) if n != tungsten and f"ColorMatrix{n}" in extras), None)
    out = dict.fromkeys(("forward_matrix", "forward_matrix_2", "hue_sat_map", "hue_sat_map_2"))
    for slot, suffix in ((daylight, ""), (tungsten, "_2")):
        if slot is None:
            continue
        value = extras.get(f"ForwardMatrix{slot}")
        if f"ForwardMatrix{slot}" not in colour_tag_problems(extras, planes):  # a singular one is no matrix
            out[f"forward_matrix{suffix}"] = None if value is None else _rational_matrix(value, (3, planes))
        dims, data = extras.get("ProfileHueSatMapDims"), extras.get(f"ProfileHueSatMapData{slot}")
        if dims is not None and data is not None:
            try:
                out[f"hue_sat_map{suffix}"] = HueSatMap.from_dng(np.ravel(dims), data)
            except (ConfigError, TypeError, ValueError):
                pass  # a malformed map (wrong count, non-finite, negative scale) is no map, as for Adobe's reader
    if out["hue_sat_map"] is None or (tungsten and out["hue_sat_map_2"] is None):
        out["hue_sat_map"] = out["hue_sat_map_2"] = None  # half a dual-illuminant profile is none
    if tungsten and daylight and (out["forward_matrix"] is None) != (out["forward_matrix_2"] is None):
        out["forward_matrix"] = out["forward_matrix_2"] = None  # both or neither (DNG ch. 6, ForwardMatrix2)
    return out


#: CIE 1931 xy of the EXIF LightSource codes a third calibration may name (CIE 15:2004 Table T.3; the
#: DNG SDK's dng_illuminant_data uses the same): D50, D55, D65, D75, Standard A.
_LIGHT_XY = {23: (0.34567, 0.35850), 20: (0.33242, 0.34743), 21: (0.31272, 0.32903), 22: (0.29902, 0.31485),
             17: (0.44757, 0.40745)}


def _illuminant_data_xy(value) -> tuple[float, float] | None:
    """The white xy an IlluminantData tag holds: type 0 (x, y RATIONALs) or type 1 (a spectrum:
    count, first wavelength, spacing, samples; its CIE 1931 xy by colour-science); None when malformed.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, IlluminantData1/2/3.
    """
    import struct

    data = bytes(value) if isinstance(value, (bytes, bytearray)) else bytes(np.asarray(value, np.uint8))
    try:
        kind = struct.unpack_from("<H", data)[0]
        if kind == 0:
            xn, xd, yn, yd = struct.unpack_from("<4I", data, 2)
            xy = (xn / xd, yn / yd)
        elif kind == 1:
            import colour

            count = struct.unpack_from("<I", data, 2)[0]
            if not 2 <= count <= 1000:
                return None
            fields = np.array(struct.unpack_from(f"<{4 + 2 * count}I", data, 6), dtype=float)
            if np.any(fields[1::2] == 0) or fields[2] == 0:  # a zero denominator or spacing: corrupt
                return None
            start, step = fields[0] / fields[1], fields[2] / fields[3]
            power = fields[4::2] / fields[5::2]
            if not (200 <= start <= 1000 and step <= 100 and power.max() > 0):
                return None
            sd = colour.SpectralDistribution(power, start + step * np.arange(count))
            xy = tuple(colour.XYZ_to_xy(colour.sd_to_XYZ(sd.align(colour.SpectralShape(360, 830, 1)))))
        else:
            return None
    except (struct.error, ZeroDivisionError, ValueError, TypeError):
        return None
    return xy if all(np.isfinite(xy)) and all(0 < v < 1 for v in xy) and sum(xy) < 1 else None


def _third_calibration(extras: dict, planes: int, profile: dict):
    """The DNG 1.6 third calibration (:class:`~spectral_cam.raw.image.Calibration`) when the file has
    one that can be used: CalibrationIlluminant3 (a named light or 255 with IlluminantData3), a
    ColorMatrix3 of rank 3, and ForwardMatrix3 / ProfileHueSatMapData3 exactly where the other two
    calibrations have theirs; else None."""
    from .image import Calibration

    if planes != 3 or "ColorMatrix3" not in extras or "CalibrationIlluminant3" not in extras:
        return None
    code = int(np.ravel(extras["CalibrationIlluminant3"])[0]) if np.size(extras["CalibrationIlluminant3"]) else None
    xy = _illuminant_data_xy(extras.get("IlluminantData3", b"")) if code == 255 else _LIGHT_XY.get(code)
    matrix = _rational_matrix(extras["ColorMatrix3"], (3, 3))
    if xy is None or matrix is None or np.linalg.matrix_rank(matrix) < 3:
        return None
    forward = _rational_matrix(extras["ForwardMatrix3"], (3, 3)) if "ForwardMatrix3" in extras else None
    if forward is not None and np.linalg.matrix_rank(forward) < 3:
        forward = None
    hue_sat = None
    dims, data = extras.get("ProfileHueSatMapDims"), extras.get("ProfileHueSatMapData3")
    if dims is not None and data is not None:
        try:
            hue_sat = HueSatMap.from_dng(np.ravel(dims), data)
        except (ConfigError, TypeError, ValueError):
            hue_sat = None
    if (forward is None) != (profile.get("forward_matrix") is None) or \
            (hue_sat is None) != (profile.get("hue_sat_map") is None):
        return None  # DNG 1.6: forward matrices and maps for all three calibrations or none
    return Calibration(illuminant=f"CalibrationIlluminant3 = {code}", white_xy=(float(xy[0]), float(xy[1])),
                       color_matrix=matrix, forward_matrix=forward, hue_sat_map=hue_sat)


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
    import rawpy

    path = Path(path)
    if not path.is_file():
        raise RawFormatError(f"raw file {str(path)!r} does not exist")
    if path.stat().st_size == 0:  # LibRaw said "Input/output error" (issue 25 #16)
        raise RawFormatError(f"{path} is empty (0 bytes): not a raw file; give a DNG or a camera raw")
    ifds = _tiff_ifds(path)  # the file's structure, read once for both checks
    _check_tiff_cfa(path, ifds)
    _check_data_in_file(path, ifds)
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
            black_levels = [float(v) for v in handle.black_level_per_channel]
            pattern = np.asarray(handle.raw_pattern)
            white = int(handle.white_level)
            camera_wb = np.asarray(handle.camera_whitebalance, dtype=float)
            daylight = np.asarray(handle.daylight_whitebalance, dtype=float)
            rgb_cam = np.asarray(handle.color_matrix, dtype=float)
            cam_xyz = np.asarray(handle.rgb_xyz_matrix, dtype=float)
            raw_type = str(handle.raw_type)
            sizes = handle.sizes
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
    if mosaic.size == 0 or (mosaic.ndim != 2 and cfa != LINEAR):
        raise RawFormatError(f"{path}: no single-plane raw mosaic nor three-colour linear raw (LibRaw raw type "
                             f"{raw_type}, {colors} colours)")
    _check_data_present(path, mosaic, black_levels, '.'.join(map(str, rawpy.libraw_version)))
    neutral = matrix = None
    if cfa != "none":
        wb = camera_wb[:3]
        if np.all(wb > 0):
            neutral = (1.0 / wb) / (1.0 / wb).max()
        matrix = _xyz_to_camera_from_libraw(rgb_cam, daylight)
        if matrix is None:
            matrix = _xyz_to_camera_from_table(cam_xyz)
    extras = _tiff_extras(path)
    planes = channel_count(cfa) if cfa not in ("none", LINEAR) else 3
    if planes == 4:  # RGBW: LibRaw's colours are four others (GMCY); the DNG's own tags say what they are
        matrix = _daylight_matrix(extras, 4)
        tag = extras.get("AsShotNeutral")
        neutral = None if tag is None else _rational_matrix(tag, (1, 4))
        neutral = None if neutral is None or np.any(neutral <= 0) else neutral[0] / neutral[0].max()
    problems = colour_tag_problems(extras, planes) if cfa != "none" else {}
    daylight_slot = next((n for n in (1, 2) if n != _tungsten_slot(extras) and f"ColorMatrix{n}" in extras), None)
    if f"ColorMatrix{daylight_slot}" in problems:
        matrix = None  # LibRaw derives nothing usable from it: the develop says which tag, not "none"
    tungsten = _tungsten_matrix(extras, planes) if matrix is not None else None
    profile = _profile(extras, planes) if matrix is not None else {}
    _check_white_level(path, extras.get("WhiteLevel"), black_levels)
    noise = extras.get("NoiseProfile")
    noise = np.atleast_1d(np.asarray(noise, dtype=float)) if noise is not None else np.empty(0)
    # a corrupt count (one value) or non-finite values: no profile rather than an error
    noise_profile = (float(noise[0]), float(noise[1])) if noise.size >= 2 and np.all(np.isfinite(noise[:2])) else None
    # LibRaw orders black_level_per_channel by colour index; raw_pattern maps sites to it
    if cfa == LINEAR:
        black = float(black_levels[0]) if len(set(black_levels[:3])) == 1 else np.asarray(black_levels[:3], float)
    elif cfa == "none" or len(set(black_levels[:4])) == 1 or pattern.shape != (2, 2):
        black = float(black_levels[0])
    else:
        black = np.asarray(black_levels, dtype=float)[pattern]
    return RawImage(
        mosaic=mosaic,
        cfa=cfa,
        black_level=black,
        white_level=white,
        baseline_exposure=_baseline_exposure(extras.get("BaselineExposure")),
        profile_tone_curve=_tone_curve(extras.get("ProfileToneCurve")),
        crop=_default_crop(path, extras, sizes, mosaic.shape[:2]),
        color_matrix=matrix,
        color_matrix_2=tungsten,
        **profile,
        calibration_3=_third_calibration(extras, planes, profile) if tungsten is not None else None,
        as_shot_neutral=neutral,
        noise_profile=noise_profile,
        camera_model=str(extras.get("UniqueCameraModel", "")).strip(),
        meta={
            "source": str(path),
            "black_level_per_channel": black_levels,
            "make": str(extras.get("Make", "")).strip(),
            "model": str(extras.get("Model", "")).strip(),
            "libraw_raw_type": raw_type,
            **({"colour_tag_problems": list(problems.values())} if problems else {}),
        },
    )
