"""Colour-filter-array geometry: the one place that knows the tiles (2×2 Bayer, X-Trans, Quad Bayer).

The scene validation, the sensor, the DNG writer and reader, the ISP stages and the EMVA
1288 analysis all ask this module, so a bad CFA name gets the same error everywhere.

A CFA is named by its 2×2 tile read row by row from the top-left pixel ("RGGB" has red at
(0, 0), green at (0, 1) and (1, 0), blue at (1, 1)), the DNG CFAPattern convention. Two larger
repeating tiles are named by their kind: ``"XTRANS"`` (Fujifilm's 6×6: 20 green, 8 red, 8 blue, every
row and column holding all three; the tile dcraw and LibRaw use), ``"QUAD_RGGB"`` (Quad Bayer:
each site of an RGGB tile a 2×2 cell of one colour, a 4×4 tile; Sony's IMX586 and phones since 2018)
and ``"RGBW"`` (Kodak's CFA 2.0: a checkerboard of unfiltered white pixels, channel 3, around a
Bayer tile at twice the scale).
OpenCV names a Bayer pattern by the tile that starts at pixel (1, 1) instead, so RGGB is
OpenCV's ``BayerBG``.

References
----------
.. [1] Bayer, B. E. (1976). Color imaging array. US Patent 3,971,065.
.. [2] Adobe (2023). Digital Negative (DNG) Specification 1.7.1.0, tag CFAPattern.
.. [3] OpenCV documentation, "Color conversions: Bayer → RGB" (imgproc, cvtColor).
.. [4] Fujifilm (2012). X-Trans CMOS sensor (the 6×6 aperiodic-looking array); Coffin, D., dcraw.c
   (its ``xtrans`` table, LibRaw's too).
.. [5] Sony Semiconductor Solutions (2018). IMX586 "Quad Bayer coding" (2×2 same-colour cells).
.. [6] Compton, J. T., & Hamilton, J. F. (2007). Image sensor with improved light sensitivity.
   US Patent 8,139,130 (Kodak's panchromatic "CFA 2.0" patterns).
"""

from __future__ import annotations

import numpy as np

from .errors import ConfigError

__all__ = [
    "BAYER_PATTERNS",
    "CFA_PATTERNS",
    "MONOCHROME",
    "LINEAR",
    "check_cfa",
    "tile_layout",
    "channel_index",
    "channel_masks",
    "tile_gain_map",
    "opencv_bayer_name",
    "opencv_bayer_code",
    "plane_offsets",
    "EXTENDED_PATTERNS",
    "cfa_pattern",
    "is_bayer",
    "cfa_period",
    "channel_count",
    "WHITE",
    "DNG_WHITE_CODE",
]

#: The 2×2 Bayer tiles, read row by row from the top-left pixel.
BAYER_PATTERNS = ("RGGB", "BGGR", "GRBG", "GBRG")
#: Larger tiles: channel codes (0 = R, 1 = G, 2 = B) row by row.
EXTENDED_PATTERNS = {
    "XTRANS": ((1, 1, 0, 1, 1, 2),
               (1, 1, 2, 1, 1, 0),
               (2, 0, 1, 0, 2, 1),
               (1, 1, 2, 1, 1, 0),
               (1, 1, 0, 1, 1, 2),
               (0, 2, 1, 2, 0, 1)),
    "QUAD_RGGB": ((0, 0, 1, 1),
                  (0, 0, 1, 1),
                  (1, 1, 2, 2),
                  (1, 1, 2, 2)),
    # Kodak's "CFA 2.0" (Compton & Hamilton 2007): half the pixels panchromatic (W, code 3) on a
    # checkerboard, the other half a Bayer tile at twice the scale
    "RGBW": ((3, 1, 3, 0),
             (1, 3, 0, 3),
             (3, 2, 3, 1),
             (2, 3, 1, 3)),
}
#: The white (panchromatic, unfiltered) channel's index in an RGBW tile; DNG's CFA colour code for white.
WHITE, DNG_WHITE_CODE = 3, 6
#: A sensor without a colour filter array (one channel, flat QE).
MONOCHROME = "none"
#: Every CFA a sensor, RAW or analysis accepts.
CFA_PATTERNS = (*BAYER_PATTERNS, *EXTENDED_PATTERNS, MONOCHROME)
#: A RAW already holding three colours per pixel (DNG LinearRaw, PhotometricInterpretation
#: 34892 with three samples: phones' ProRAW, converted raws): (H, W, 3), no mosaic.
LINEAR = "linear"
#: Colour index of each letter: 0 = R, 1 = G, 2 = B (also the DNG CFAPattern codes).
CHANNEL_CODES = {"R": 0, "G": 1, "B": 2}
_CHANNEL = CHANNEL_CODES


def check_cfa(cfa: str, *, allow_monochrome: bool = False, allow_extended: bool = False) -> str:
    """Return the upper-case Bayer tile name (or ``"none"``, or an extended tile's name), or raise.

    Parameters
    ----------
    cfa
        Bayer tile read row by row from the top-left pixel, e.g. ``"RGGB"``.
    allow_monochrome
        Also accept ``"none"`` (a monochrome sensor).
    allow_extended
        Also accept the larger tiles of :data:`EXTENDED_PATTERNS` (``"XTRANS"``, ``"QUAD_RGGB"``).

    Raises
    ------
    ConfigError
        If ``cfa`` is not one of :data:`BAYER_PATTERNS` (or ``"none"`` when allowed).

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, CFAPattern.

    Examples
    --------
    >>> check_cfa("rggb")
    'RGGB'
    >>> check_cfa("none", allow_monochrome=True)
    'none'
    """
    text = str(cfa)
    if allow_monochrome and text.lower() == MONOCHROME:
        return MONOCHROME
    name = text.upper()
    if allow_extended and name in EXTENDED_PATTERNS:
        return name
    if name not in BAYER_PATTERNS:
        valid = list(BAYER_PATTERNS) + (list(EXTENDED_PATTERNS) if allow_extended else []) \
            + ([MONOCHROME] if allow_monochrome else [])
        extra = "" if allow_extended or name not in EXTENDED_PATTERNS else \
            f" ({name} is a larger tile this step does not handle: it needs a 2×2 Bayer mosaic)"
        raise ConfigError(f"CFA pattern {cfa!r} is not a Bayer tile{extra}; valid: {', '.join(valid)}")
    return name


def is_bayer(cfa: str) -> bool:
    """Whether ``cfa`` names a 2×2 Bayer tile."""
    return str(cfa).upper() in BAYER_PATTERNS


def cfa_pattern(cfa: str) -> np.ndarray:
    """The repeating tile of any named CFA as channel codes (0 = R, 1 = G, 2 = B), (rows, cols) uint8.

    Examples
    --------
    >>> cfa_pattern("GRBG").tolist(), cfa_pattern("XTRANS").shape
    ([[1, 0], [2, 1]], (6, 6))
    """
    name = check_cfa(cfa, allow_extended=True)
    if name in EXTENDED_PATTERNS:
        return np.array(EXTENDED_PATTERNS[name], dtype=np.uint8)
    return np.array([_CHANNEL[c] for c in name], dtype=np.uint8).reshape(2, 2)


def channel_count(cfa: str) -> int:
    """Colour channels a CFA samples: 1 (monochrome), 3 (R, G, B) or 4 (R, G, B, W)."""
    if str(cfa).lower() == MONOCHROME:
        return 1
    return int(cfa_pattern(cfa).max()) + 1


def cfa_period(cfa: str) -> tuple[int, int]:
    """(rows, cols) of the CFA's repeating tile; (1, 1) for a monochrome sensor."""
    if str(cfa).lower() == MONOCHROME:
        return 1, 1
    return tuple(cfa_pattern(cfa).shape)


def tile_layout(cfa: str) -> tuple[tuple[int, int], tuple[int, int]] | None:
    """Channel indices of the 2×2 tile, ``((c00, c01), (c10, c11))`` with 0 = R, 1 = G,
    2 = B, or None for a monochrome sensor (``"none"``).

    Raises
    ------
    ConfigError
        For anything but a Bayer tile or ``"none"``.

    References
    ----------
    .. [1] Bayer, B. E. (1976). Color imaging array. US Patent 3,971,065.

    Examples
    --------
    >>> tile_layout("GRBG")
    ((1, 0), (2, 1))
    """
    name = check_cfa(cfa, allow_monochrome=True)
    if name == MONOCHROME:
        return None
    codes = [CHANNEL_CODES[c] for c in name]
    return (codes[0], codes[1]), (codes[2], codes[3])


def cfa_at(cfa: str, row: int, col: int) -> str:
    """The Bayer tile read from pixel (``row``, ``col``) of a mosaic whose tile at (0, 0) is
    ``cfa``: the pattern of a crop that starts there.

    Examples
    --------
    >>> cfa_at("RGGB", 0, 1), cfa_at("RGGB", 1, 0), cfa_at("RGGB", 2, 2)
    ('GRBG', 'GBRG', 'RGGB')

    A larger tile has no name for its other phases: a crop must start on a whole tile.
    """
    name = check_cfa(cfa, allow_monochrome=True, allow_extended=True)
    if name == MONOCHROME:
        return name
    if name in EXTENDED_PATTERNS:
        rows, cols = cfa_period(name)
        if row % rows or col % cols:
            raise ConfigError(f"a crop of a {name} mosaic must start on a whole {rows}×{cols} tile; it starts at "
                              f"({row}, {col})")
        return name
    return "".join(name[2 * ((row + r) % 2) + (col + c) % 2] for r in (0, 1) for c in (0, 1))


def channel_index(shape: tuple[int, int], cfa: str) -> np.ndarray:
    """Colour index (0 = R, 1 = G, 2 = B) of every pixel of a Bayer mosaic.

    Parameters
    ----------
    shape
        (height, width) of the mosaic, pixels.
    cfa
        Bayer tile name (see :func:`check_cfa`).

    Returns
    -------
    numpy.ndarray
        (H, W) uint8 array.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, CFAPattern.
    """
    if cfa == LINEAR:  # every pixel holds every colour: the index is the last axis
        if len(shape) != 3 or shape[2] != 3:
            raise ConfigError(f"a linear (three-colour) raw is (H, W, 3); got shape {tuple(shape)}")
        return np.broadcast_to(np.arange(3, dtype=np.uint8), tuple(shape))
    tile = cfa_pattern(cfa)
    h, w = int(shape[0]), int(shape[1])
    rows, cols = tile.shape
    return np.tile(tile, (-(-h // rows), -(-w // cols)))[:h, :w]


def channel_masks(shape: tuple[int, int], cfa: str) -> np.ndarray:
    """One float32 0/1 mask per colour: (H, W, 3), 1 where the pixel samples that colour.

    Parameters
    ----------
    shape
        (height, width) of the mosaic, pixels.
    cfa
        Bayer tile name.

    References
    ----------
    .. [1] Bayer, B. E. (1976). US Patent 3,971,065.
    """
    index = channel_index(shape, cfa)
    return np.stack([(index == c) for c in range(3)], axis=-1).astype(np.float32)


def tile_gain_map(shape: tuple[int, int], cfa: str, values) -> np.ndarray:
    """Per-pixel map (float32, (H, W)) holding ``values[c]`` at the pixels of colour c.

    Parameters
    ----------
    shape
        (height, width), pixels.
    cfa
        Bayer tile name.
    values
        One number per channel (R, G, B; and W for RGBW).

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, CFAPattern.
    """
    lut = np.asarray(values, dtype=np.float32).reshape(channel_count(cfa))
    return lut[channel_index(shape, cfa)]


def plane_offsets(cfa: str) -> list[tuple[int, int, int]]:
    """The four sub-sampled CFA planes as (row offset, column offset, colour index).

    ``mosaic[dy::2, dx::2]`` holds one colour only.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, CFAPattern.
    """
    name = check_cfa(cfa)
    return [(i // 2, i % 2, _CHANNEL[name[i]]) for i in range(4)]


def opencv_bayer_name(cfa: str) -> str:
    """OpenCV's two-letter Bayer name for a DNG-style tile name.

    OpenCV names the pattern by the second and third pixels of the second row, i.e. the
    tile that starts at (1, 1): RGGB → ``"BG"``, BGGR → ``"RG"``, GRBG → ``"GB"``,
    GBRG → ``"GR"``.

    References
    ----------
    .. [1] OpenCV documentation, imgproc "Color conversions", Bayer → RGB.
    """
    name = check_cfa(cfa)
    # the tile at (1, 1): row 1 then row 0, each read from column 1
    return name[3] + name[2]


def opencv_bayer_code(cfa: str, method: str = "") -> int:
    """``cv2.COLOR_Bayer??2RGB[_VNG|_EA]`` for a DNG-style tile name.

    Parameters
    ----------
    cfa
        Bayer tile name.
    method
        ``""`` (bilinear), ``"VNG"`` or ``"EA"``.

    References
    ----------
    .. [1] OpenCV documentation, imgproc "Color conversions", Bayer → RGB.
    """
    import cv2

    suffix = f"_{method.upper()}" if method else ""
    return getattr(cv2, f"COLOR_Bayer{opencv_bayer_name(cfa)}2RGB{suffix}")
