"""White balance on the linear Bayer mosaic: gain estimation and application.

Gains are normalised so the smallest is 1: every channel then reaches at least the
saturation level where the sensor clipped, which is what the highlight stage relies on
(dcraw / LibRaw use the same convention).

References
----------
.. [1] Buchsbaum, G. (1980). A spatial processor model for object colour perception.
   J. Franklin Inst. 310(1), 1–26 (grey world).
.. [2] Land, E. H., & McCann, J. J. (1971). Lightness and retinex theory. JOSA 61(1),
   1–11 (white patch / max-RGB).
.. [3] Adobe (2023). DNG Specification 1.7.1.0, AsShotNeutral.
"""

from __future__ import annotations

import numpy as np

from ..cfa import channel_index, is_bayer, tile_gain_map, tile_layout
from ..errors import ConfigError
from ..registry import Registry
from .highlights import clipped_mask

__all__ = ["WHITE_BALANCE", "MAX_GAIN_RATIO", "gains_problem", "white_balance_gains", "apply_white_balance"]


#: Largest ratio of the largest white-balance gain to the smallest: 2¹⁴, a 14-bit raw's whole range. A
#: larger one lifts less than one code of the weakest channel to white (low-pressure sodium, the most
#: extreme bundled light, asks 139 of the canon_eos_5d); 1e300 overflowed float32 to inf and NaN (issue 39 #23).
MAX_GAIN_RATIO = float(2 ** 14)


def gains_problem(gains) -> str | None:
    """Why ``gains`` cannot be white-balance gains, or None: three (R, G, B) or four (R, G, B, W)
    finite numbers > 0 whose largest is at most :data:`MAX_GAIN_RATIO` times the smallest."""
    try:
        gains = np.asarray(gains, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        return "they are not numbers"
    if gains.size not in (3, 4) or not np.all(np.isfinite(gains)) or np.any(gains <= 0):
        return "give three (R, G, B) or four (R, G, B, W) finite numbers > 0"
    ratio = float(gains.max() / gains.min())
    if not ratio <= MAX_GAIN_RATIO:  # not <=: an overflow to inf is refused too
        return (f"the largest is {ratio:.3g} times the smallest; valid: at most {MAX_GAIN_RATIO:g} "
                "(a 14-bit raw's whole range)")
    return None


def _normalised(gains) -> np.ndarray:
    """Gains (three, or four for RGBW) over their smallest."""
    problem = gains_problem(gains)
    if problem:
        raise ConfigError(f"white-balance gains {np.ravel(np.asarray(gains, dtype=object)).tolist()}: {problem}")
    gains = np.asarray(gains, dtype=np.float64).ravel()
    return gains / gains.min()


def _channels(cfa) -> int:
    from ..cfa import channel_count

    return 3 if str(cfa).lower() in ("none", "linear") else channel_count(cfa)


def _usable(mosaic: np.ndarray, cfa: str, saturation: float):
    """CFA channel index per pixel and the samples an estimator may use: the unclipped ones.
    A sensor clips at full well before read noise, so a blown pixel reads just under the
    white level about half the time: the highlight stage's 0.995 threshold catches it."""
    index = channel_index(mosaic.shape, cfa)
    ok = ~clipped_mask(mosaic, saturation=saturation, radius_px=0)
    return index, ok


def _as_shot(mosaic, cfa, *, as_shot_neutral=None, saturation=1.0, **_):
    if as_shot_neutral is None:
        raise ConfigError("white_balance = 'as_shot' needs the RAW's AsShotNeutral; this RAW has none "
                          "(use 'grey_world', 'white_patch' or 'manual')")
    return _normalised(1.0 / np.asarray(as_shot_neutral, dtype=np.float64))


def _grey_world(mosaic, cfa, *, saturation=1.0, **_):
    index, ok = _usable(mosaic, cfa, saturation)
    means = np.array([mosaic[(index == c) & ok].mean() if np.any((index == c) & ok) else np.nan
                      for c in range(_channels(cfa))])
    if not np.all(means > 0):
        raise ConfigError("grey-world white balance needs unclipped signal in all three channels")
    return _normalised(means[1] / means)


def _white_patch(mosaic, cfa, *, saturation=1.0, percentile=99.0, **_):
    index, ok = _usable(mosaic, cfa, saturation)
    tops = np.array([np.percentile(mosaic[(index == c) & ok], percentile) if np.any((index == c) & ok)
                     else np.nan for c in range(_channels(cfa))])
    if not np.all(tops > 0):
        raise ConfigError("white-patch white balance needs unclipped signal in all three channels")
    return _normalised(tops[1] / tops)


def _manual(mosaic, cfa, *, gains=None, **_):
    if gains is None or len(gains) != 3:
        raise ConfigError("white_balance = 'manual' needs isp.wb_gains = [R, G, B]")
    if _channels(cfa) == 4:  # RGBW: white as the three's sum would be balanced, over green's gain
        raise ConfigError("white_balance = 'manual' takes R, G, B gains; an RGBW RAW needs 'as_shot', 'grey_world' "
                          "or 'white_patch' (its white pixels need their own gain)")
    return _normalised(gains)


#: White-balance gain estimators by name.
WHITE_BALANCE = Registry("white balance method")
WHITE_BALANCE.add("as_shot", _as_shot, options=("as_shot_neutral",), description="the RAW's AsShotNeutral")
WHITE_BALANCE.add("grey_world", _grey_world, description="mean of each channel (Buchsbaum 1980)")
WHITE_BALANCE.add("white_patch", _white_patch, options=("percentile",), description="a bright percentile per channel")
WHITE_BALANCE.add("manual", _manual, options=("gains",), description="isp.wb_gains")


def white_balance_gains(
    mosaic: np.ndarray,
    cfa: str,
    *,
    method: str = "as_shot",
    as_shot_neutral=None,
    gains=None,
    saturation: float = 1.0,
    percentile: float = 99.0,
) -> np.ndarray:
    """Estimate R, G, B white-balance gains (smallest = 1).

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic, black at 0 and white level at 1.
    cfa
        Bayer tile name.
    method
        ``"as_shot"``: gains = 1 / AsShotNeutral; ``"grey_world"``: the channel means are
        made equal (Buchsbaum 1980); ``"white_patch"``: the channels' ``percentile``-th
        values are made equal (max-RGB, Land & McCann 1971); ``"manual"``: ``gains``.
        Clipped samples (≥ ``saturation``) are ignored by the estimators.
    as_shot_neutral
        (3,) camera RGB of the scene's white (DNG AsShotNeutral).
    gains
        (3,) manual gains.
    saturation
        Normalised level at which the sensor clips (1 = white level).
    percentile
        Percentile of each channel taken as its white for ``"white_patch"``, %.

    Returns
    -------
    numpy.ndarray
        (3,) float64 gains, normalised so the smallest is 1.

    Raises
    ------
    ConfigError
        For an unknown method (listing the valid ones) or missing inputs.

    References
    ----------
    .. [1] Buchsbaum, G. (1980). J. Franklin Inst. 310(1), 1–26.
    .. [2] Land, E. H., & McCann, J. J. (1971). JOSA 61(1), 1–11.
    .. [3] Adobe (2023). DNG Specification 1.7.1.0, AsShotNeutral.
    """
    return WHITE_BALANCE[method](np.asarray(mosaic, dtype=np.float32), cfa, as_shot_neutral=as_shot_neutral,
                                 gains=gains, saturation=saturation, percentile=percentile)


def apply_white_balance(mosaic: np.ndarray, cfa: str, *, gains) -> np.ndarray:
    """Multiply each CFA sample by its colour's gain.

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic.
    cfa
        Bayer tile name.
    gains
        (3,) R, G, B gains (dimensionless).

    Returns
    -------
    numpy.ndarray
        (H, W) float32 white-balanced mosaic.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, AsShotNeutral.
    """
    mosaic = np.asarray(mosaic, dtype=np.float32)
    if mosaic.ndim == 3:  # a linear raw: one gain per colour plane
        return mosaic * np.asarray(gains, dtype=np.float32).reshape(3)
    if not is_bayer(cfa):  # a larger tile: one gain per pixel from its colour
        return mosaic * tile_gain_map(mosaic.shape, cfa, gains)
    layout = tile_layout(cfa)
    # one gain per CFA site, on strided views: no full-frame gain map (2× the memory traffic)
    balanced = mosaic.copy()
    values = np.asarray(gains, dtype=np.float32).reshape(3)
    for row in (0, 1):
        for col in (0, 1):
            balanced[row::2, col::2] *= values[layout[row][col]]
    return balanced
