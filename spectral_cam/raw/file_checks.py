"""Why a raw file is refused, with the reason: what its TIFF structure says before LibRaw reads it
(a CFA image without its pattern tags or with a pattern lacking a colour, image data past the end of
the file or under a bit per pixel, a JPEG XL raw LibRaw does not decode, an image under LibRaw's
smallest side), what LibRaw printed while reading (held, not leaked to stderr), and what the decoded
data show (all or mostly zeros, a white level not above black). LibRaw itself decodes such files
without an error and fills the missing data with zeros or stale memory.

References
----------
.. [1] Adobe (2023). DNG Specification 1.7.1.0 (CFARepeatPatternDim, CFAPattern; Compression 52546).
.. [2] TIFF 6.0 (strips and tiles: offsets and byte counts).
"""

from __future__ import annotations

import contextlib
import logging
from pathlib import Path
from typing import Iterator, NamedTuple

import numpy as np

from ..cfa import DNG_WHITE_CODE, EXTENDED_PATTERNS, WHITE
from ..errors import RawFormatError

__all__ = ["MIN_BLACK_FOR_ZERO_CHECK", "LIBRAW_MIN_SIDE_PX", "UNSUPPORTED_COMPRESSION", "unsupported_reason"]


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
