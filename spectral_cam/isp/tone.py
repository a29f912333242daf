"""Tone: exposure and the curve from scene-referred linear sRGB to display values in [0, 1].

``"adobe"`` (the default) is Adobe's default rendering as the DNG SDK does it: exposure ramp
(BaselineExposure + the user's offset, a black point at Adobe's default shadows), the ACR3
default tone curve on linear ProPhoto RGB by Adobe's hue-preserving rule, then the sRGB
encoding: a camera's look, with a highlight roll-off and the mid-tone lift that puts a
metered grey at 118/255 from 9.9 % of white. ``"srgb"`` applies the sRGB OETF only
(IEC 61966-2-1): a colorimetric rendition with a hard clip at white (colour accuracy is
measured on the linear image). ``"filmic"`` first compresses highlights with Narkowicz's fit
of the ACES reference rendering transform. ``"linear"`` shows the linear values. Every
method returns values in [0, 1]. Each :data:`TONE` entry also declares the DNG ProfileToneCurve its
RAWs carry (:class:`ToneEntry`), so an Adobe-path reader renders a neutral as the develop does.
Adobe's rendering up to the output encoding is :mod:`spectral_cam.isp.adobe_rendering`.

References
----------
.. [1] IEC 61966-2-1:1999, Multimedia systems and equipment — Colour measurement and
   management — Default RGB colour space — sRGB, eq. (5) (encoding, "gamma").
.. [2] Narkowicz, K. (2016). ACES Filmic Tone Mapping Curve.
   https://knarkowicz.wordpress.com/2016/01/06/aces-filmic-tone-mapping-curve/
.. [3] Academy of Motion Picture Arts and Sciences. ACES, Reference Rendering Transform.
.. [4] Adobe DNG SDK 1.7, ``source/dng_render.cpp``, ``source/dng_reference.cpp``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, fields
from typing import Callable

import numpy as np

from ..registry import Entry, Registry
from .adobe_rendering import (  # noqa: F401 (their old home: tone.py re-exports Adobe's pieces)
    ADOBE_DEFAULT_SHADOWS,
    adobe_curve,
    adobe_default_curve,
    adobe_exposure_ramp,
    adobe_exposure_shoulder,
    adobe_linear_srgb,
    rgb_tone,
    srgb_prophoto_matrices,
)

__all__ = ["TONE", "ToneEntry", "ToneRegistry", "adobe_curve", "srgb_oetf", "srgb_eotf", "filmic", "adobe",
           "apply_exposure", "tone_map", "grey_input", "profile_tone_curve", "adobe_default_curve",
           "adobe_exposure_ramp", "adobe_exposure_shoulder", "rgb_tone", "SOS_GREY_DISPLAY", "finite_linear"]

_F32 = np.float32


def srgb_oetf(linear: np.ndarray) -> np.ndarray:
    """sRGB encoding: ``12.92·L`` for L ≤ 0.0031308, else ``1.055·L^(1/2.4) − 0.055``.

    Unclipped: negative values stay on the linear segment (as colour-science's
    ``cctf_encoding(..., function="sRGB")``), values above 1 follow the power law.

    Parameters
    ----------
    linear
        Linear sRGB values (1 = reference white).

    Returns
    -------
    numpy.ndarray
        float32 non-linear sRGB values.

    References
    ----------
    .. [1] IEC 61966-2-1:1999, eq. (5).
    """
    import cv2

    x = np.asarray(linear, dtype=_F32)
    flat = np.ascontiguousarray(x).reshape(-1)
    knee = _F32(0.0031308)
    # cv2.pow is a vectorised, multithreaded x**p (several times faster than np.power)
    # one output buffer, worked in place (each fresh 24 MP RGB temporary is ~0.1 s of page faults)
    out = np.maximum(flat, knee)
    cv2.pow(out, 1.0 / 2.4, dst=out)
    out *= _F32(1.055)
    out -= _F32(0.055)
    np.multiply(flat, _F32(12.92), out=out, where=flat <= knee)
    return out.reshape(x.shape)


def srgb_eotf(encoded: np.ndarray) -> np.ndarray:
    """Inverse of :func:`srgb_oetf` (sRGB decoding to linear).

    Parameters
    ----------
    encoded
        Non-linear sRGB values.

    Returns
    -------
    numpy.ndarray
        float32 linear values.

    References
    ----------
    .. [1] IEC 61966-2-1:1999, eq. (4)–(5).
    """
    v = np.asarray(encoded, dtype=_F32)
    power = np.power((np.maximum(v, _F32(0.04045)) + _F32(0.055)) / _F32(1.055), _F32(2.4))
    return np.where(v <= _F32(0.04045), v / _F32(12.92), power).astype(_F32, copy=False)


def filmic(linear: np.ndarray) -> np.ndarray:
    """Filmic highlight roll-off followed by the sRGB OETF.

    ``f(x) = x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)`` on x = max(L, 0), clipped to
    [0, 1] (Narkowicz's fit of the ACES RRT + sRGB ODT luminance response), then
    :func:`srgb_oetf`.

    Parameters
    ----------
    linear
        Linear sRGB values.

    Returns
    -------
    numpy.ndarray
        float32 display values in [0, 1].

    References
    ----------
    .. [1] Narkowicz, K. (2016). ACES Filmic Tone Mapping Curve.
    """
    return srgb_oetf(np.clip(_narkowicz(np.asarray(linear, dtype=_F32)), 0, 1))


def _narkowicz(x):
    # the fit passes 1 (white, after the clip) near x = 8: capped at 1e4 it cannot overflow float32
    x = np.minimum(np.maximum(x, 0), 1e4)
    return (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)


def adobe(linear: np.ndarray, *, ev: float = 0.0) -> np.ndarray:
    """Adobe's default rendering of scene-referred linear sRGB: linear ProPhoto RGB, Adobe's
    exposure ramp (``ev``, default shadows), the ACR3 default curve by Adobe's hue-preserving
    RGB tone rule, back to linear sRGB, clipped (:func:`~spectral_cam.isp.adobe_rendering.
    adobe_linear_srgb`), then the sRGB encoding.

    Parameters
    ----------
    linear : numpy.ndarray
        (..., 3) linear sRGB (D65; 1 = reference white), before any exposure gain.
    ev : float
        Exposure in stops (the DNG's BaselineExposure plus the user's ``exposure_ev``).

    Returns
    -------
    numpy.ndarray
        float32 display sRGB in [0, 1].

    References
    ----------
    .. [1] Adobe DNG SDK 1.7, ``dng_render.cpp`` (``dng_render_task``: exposure ramp, baseline
       tone curve, final colour space) and ``dng_reference.cpp`` (``RefBaselineRGBTone``).
    .. [2] Adobe (2023). DNG Specification 1.7.1.0, BaselineExposure, ProfileToneCurve.
    """
    return srgb_oetf(adobe_linear_srgb(linear, ev=ev))


def _gain(ev: float):
    return _F32(2.0 ** float(ev))


def _identity(values: np.ndarray) -> np.ndarray:
    return np.array(values, dtype=np.float64)


#: Marks a :meth:`ToneRegistry.add` call that did not say what the DNG should carry.
_UNDECLARED = object()


@dataclass(frozen=True)
class ToneEntry(Entry):
    """A tone curve: its rendering and the DNG ProfileToneCurve that gives an Adobe-path reader
    the same rendering of a neutral.

    Attributes
    ----------
    dng_curve : callable or None
        Linear input in [0, 1] (after the reader's exposure) → linear output in [0, 1], before
        the reader's output encoding (sRGB): what :func:`profile_tone_curve` samples into the DNG.
        None: the curve has no DNG form of its own, and the DNG carries the identity, so a reader
        shows its output encoding alone — never its own default curve, which an absent tag asks for.
    sets_black : bool
        The rendering places black itself (Adobe's: a reader's Auto black render is part of it),
        so its DNGs say DefaultBlackRender = Auto (0); the others ask readers for none (1).
    """

    dng_curve: Callable[[np.ndarray], np.ndarray] | None = None
    sets_black: bool = False


class ToneRegistry(Registry):
    """The :data:`TONE` registry: as :class:`~spectral_cam.registry.Registry`, but every entry
    declares its DNG ProfileToneCurve (``dng_curve=``, a function or None), so a new curve cannot
    silently write another curve's (or the identity) into the RAWs rendered with it.
    """

    def register(self, name: str, *, dng_curve=_UNDECLARED, sets_black: bool = False,
                 options: tuple[str, ...] = (), description: str = ""):
        """Decorator: register the decorated rendering under ``name`` with its ``dng_curve``."""

        def decorate(function: Callable) -> Callable:
            self.add(name, function, dng_curve=dng_curve, sets_black=sets_black, options=options,
                     description=description)
            return function

        return decorate

    def add(self, name: str, function: Callable, *, dng_curve=_UNDECLARED, sets_black: bool = False,
            options: tuple[str, ...] = (), description: str = "") -> ToneEntry:
        """Register ``function(linear, *, ev)`` under ``name`` with its DNG curve.

        Raises
        ------
        ValueError
            When ``dng_curve`` is not given, or is neither callable nor None.
        """
        if dng_curve is _UNDECLARED or not (dng_curve is None or callable(dng_curve)):
            raise ValueError(f"tone curve {name!r}: declare what its DNGs carry as ProfileToneCurve: "
                             "dng_curve=<function of linear values in [0, 1], returning values in [0, 1], applied "
                             "before the reader's sRGB encoding>, or dng_curve=None for a curve with no DNG form "
                             f"(the DNG then carries the identity); got {dng_curve!r}")
        entry = super().add(name, function, options=options, description=description)  # refuses a name twice
        # the base entry's fields by name: Entry may grow fields, which positional arguments would fill
        base = {f.name: getattr(entry, f.name) for f in fields(entry)}
        entry = ToneEntry(**base, dng_curve=dng_curve, sets_black=bool(sets_black))
        self._entries[name] = entry
        return entry


#: Tone curves by name: each maps linear sRGB and an exposure (stops) to display values in [0, 1], and
#: declares the ProfileToneCurve its DNGs carry.
TONE = ToneRegistry("tone curve")
TONE.add("adobe", adobe, dng_curve=adobe_curve, sets_black=True,
         description="Adobe's default rendering (DNG SDK: exposure ramp, ACR3 curve on "
                     "ProPhoto, hue-preserving), then sRGB encoding: a camera's look")
# the reader's own sRGB encoding is the whole of this rendering: the identity is its curve, not a stand-in
TONE.add("srgb", lambda linear, *, ev=0.0: np.clip(srgb_oetf(np.asarray(linear, _F32) * _gain(ev)), 0, 1),
         dng_curve=_identity, description="the sRGB OETF only (colorimetric), hard clip at white")
TONE.add("filmic", lambda linear, *, ev=0.0: filmic(np.asarray(linear, _F32) * _gain(ev)), dng_curve=_narkowicz,
         description="ACES-like filmic curve (Narkowicz), then the sRGB OETF")
# no DNG form: every Adobe-path reader encodes its output, so "display = linear" cannot be asked of it
TONE.add("linear", lambda linear, *, ev=0.0: np.clip(np.asarray(linear, _F32) * _gain(ev), 0, 1),
         dng_curve=None, description="no curve (display = linear, clipped); its DNGs carry the identity curve")

#: The display value ISO 12232's standard output sensitivity puts mid grey at: 118 of 255 in sRGB.
SOS_GREY_DISPLAY = 118.0 / 255.0


def profile_tone_curve(method: str, *, samples: int = 129) -> np.ndarray:
    """The DNG ``ProfileToneCurve`` of the tone curve ``method``: its :data:`TONE` entry's
    ``dng_curve`` sampled at ``samples`` points of [0, 1], as (input, output) pairs of linear
    values, which an Adobe-path reader applies before its output encoding (the ACR3 curve for
    ``"adobe"``, Narkowicz's curve for ``"filmic"``, the identity for ``"srgb"``, whose only
    encoding is the sRGB one, and for ``"linear"``, which has no DNG form). 129 samples: a cubic
    spline through them (as Adobe's reader fits) is within 2.3·10⁻⁴ of the 1025-sample ACR3
    table, and exiftool decodes the tag without a "large array" warning (257 samples draw one).

    Parameters
    ----------
    method : str
        A :data:`TONE` name.
    samples : int
        Points on [0, 1] (at least 2).

    Returns
    -------
    numpy.ndarray
        float64 (samples, 2).

    Raises
    ------
    ConfigError
        For an unknown method, or an entry whose ``dng_curve`` leaves [0, 1] or returns no finite
        value per input.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ProfileToneCurve (tag 50940).
    """
    entry = TONE[TONE.check(method, key="isp.tone")]
    x = np.linspace(0.0, 1.0, max(int(samples), 2))
    y = x.copy() if entry.dng_curve is None else np.asarray(entry.dng_curve(x), dtype=np.float64)
    if y.shape != x.shape or not np.all(np.isfinite(y)) or y.min() < 0 or y.max() > 1:
        from ..errors import ConfigError

        raise ConfigError(f"tone curve {method!r}: its dng_curve must map each linear value in [0, 1] to one in "
                          f"[0, 1]; got shape {y.shape}, range [{np.nanmin(y):.4g}, {np.nanmax(y):.4g}]")
    return np.stack([x, y], axis=-1)


@functools.lru_cache(maxsize=16)
def grey_input(method: str, display: float = SOS_GREY_DISPLAY) -> float:
    """The linear value (at exposure 0) that the tone curve ``method`` renders as ``display``
    on a neutral (bisection on the curve): mid grey's place for the standard output
    sensitivity.

    Measured: ``adobe`` 0.0991 (0.0946 on the curve alone, before the black point of the
    exposure ramp; Adobe's curve lifts mid-tones: 18 % grey would render at 167), ``srgb`` 0.18,
    ``linear`` 0.4627, ``filmic`` 0.131.

    References
    ----------
    .. [1] ISO 12232:2019, §6 (standard output sensitivity: H_SOS = 10/S gives 118 of 255 in sRGB).
    """
    lo, hi = 1e-6, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        shown = float(TONE[method](np.full((1, 1, 3), mid, _F32))[0, 0, 1])
        lo, hi = (mid, hi) if shown < display else (lo, mid)
    return 0.5 * (lo + hi)


def apply_exposure(linear: np.ndarray, *, ev: float = 0.0) -> np.ndarray:
    """Digital exposure gain: multiply by 2^ev.

    Parameters
    ----------
    linear
        Linear values.
    ev
        Gain in stops (exposure values).

    Returns
    -------
    numpy.ndarray
        float32.

    References
    ----------
    .. [1] ISO 2720:1974, exposure value (EV): one stop doubles the exposure.
    """
    return (np.asarray(linear, dtype=_F32) * _F32(2.0 ** float(ev))).astype(_F32, copy=False)


#: Bound (linear, 1 = white) that values reach the tone curves within: far beyond white and below black, so
#: the curves' ends, yet small enough that a colour matrix and a 2²⁰ exposure gain stay finite in float32.
_LINEAR_BOUND = 1e30


def finite_linear(linear: np.ndarray) -> np.ndarray:
    """``linear`` as float32 with every value finite and within ±1e30: the curves' ends.

    A non-finite value (an earlier stage overflowed: an impossible gain, a corrupt matrix or shading
    table) has no place on a tone curve; +inf is shown as white, −inf and NaN as black, with a
    :class:`~spectral_cam.errors.SceneWarning` that counts them (issue 39 #23: a NaN cast to int32
    indexed the curve's table at −2³¹).

    Parameters
    ----------
    linear : numpy.ndarray
        (..., 3) linear values (1 = white).

    Returns
    -------
    numpy.ndarray
        float32: ``linear`` itself when it is all within the bound, else a clipped copy.
    """
    x = np.asarray(linear, dtype=_F32)
    if x.size == 0:
        return x
    low, high = float(x.min()), float(x.max())  # NaN propagates: one check for both
    if -_LINEAR_BOUND <= low and high <= _LINEAR_BOUND:
        return x
    bad = ~np.isfinite(x)
    if bad.any():
        import warnings

        from ..errors import SceneWarning

        pixels = int(bad.reshape(-1, x.shape[-1]).any(axis=-1).sum()) if x.ndim > 1 else int(bad.sum())
        warnings.warn(f"{pixels} pixel(s) reached the tone stage non-finite (NaN or ±inf: an earlier stage "
                      "overflowed); shown at the curve's ends: +inf as white, −inf and NaN as black",
                      SceneWarning, stacklevel=3)
    out = np.nan_to_num(x, nan=0.0, posinf=_LINEAR_BOUND, neginf=-_LINEAR_BOUND)
    return np.clip(out, -_LINEAR_BOUND, _LINEAR_BOUND, out=out)


def tone_map(linear: np.ndarray, *, method: str = "adobe", ev: float = 0.0) -> np.ndarray:
    """Apply the named tone curve at an exposure.

    Parameters
    ----------
    linear
        (H, W, 3) linear sRGB, before the exposure.
    method
        A :data:`TONE` name: ``"adobe"`` (default), ``"srgb"``, ``"filmic"`` or ``"linear"``.
    ev
        Exposure in stops: the RAW's BaselineExposure plus the user's ``exposure_ev``.

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 display values in [0, 1].

    Raises
    ------
    ConfigError
        For an unknown method (listing the valid ones).

    Warns
    -----
    SceneWarning
        When ``linear`` holds non-finite values (:func:`finite_linear` puts them at the curve's ends).

    References
    ----------
    .. [1] IEC 61966-2-1:1999.
    .. [2] Adobe DNG SDK 1.7, ``dng_render.cpp``.
    .. [3] Narkowicz, K. (2016). ACES Filmic Tone Mapping Curve.
    """
    return TONE[method](finite_linear(linear), ev=ev)
