"""Adobe's default rendering, as the DNG SDK 1.7 computes it (``dng_render.cpp``): the exposure ramp
(BaselineExposure + the user's offset, a black point at Adobe's default shadows; a negative exposure as
a shoulder folded into the curve), the ACR3 default tone curve applied on linear ProPhoto RGB by Adobe's
hue-preserving RGB tone rule, back to linear sRGB. :func:`spectral_cam.isp.tone.adobe` (the ``"adobe"``
tone curve) adds the sRGB encoding; :func:`adobe_curve` is what its DNGs carry as ProfileToneCurve.

References
----------
.. [1] Adobe DNG SDK 1.7, ``source/dng_render.cpp``, ``source/dng_reference.cpp``.
.. [2] ISO 22028-2:2013 (ROMM RGB, linear ProPhoto).
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

import numpy as np

__all__ = ["ADOBE_DEFAULT_SHADOWS", "adobe_default_curve", "adobe_exposure_ramp", "adobe_exposure_shoulder",
           "rgb_tone", "srgb_prophoto_matrices", "adobe_linear_srgb", "adobe_curve"]

_F32 = np.float32


#: Adobe's default "shadows" setting (dng_render: fShadows = 5): the exposure ramp's black
#: point is 5·0.001 of white.
ADOBE_DEFAULT_SHADOWS = 5.0


@functools.lru_cache(maxsize=1)
def adobe_default_curve() -> tuple[np.ndarray, np.ndarray]:
    """Adobe's default tone curve ("ACR3 default", DNG SDK ``dng_tone_curve_acr3_default``):
    1025 samples (input, output), both linear in [0, 1].

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        float64 inputs k/1024 and outputs (read-only).

    References
    ----------
    .. [1] Adobe DNG SDK 1.7, ``source/dng_render.cpp`` (``dng_tone_curve_acr3_default``);
       provenance and licence in ``spectral_cam/data/tone/README.md``.
    """
    path = Path(__file__).resolve().parent.parent / "data" / "tone" / "adobe_acr3_default.csv"
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    x, y = np.ascontiguousarray(table[:, 0]), np.ascontiguousarray(table[:, 1])
    x.setflags(write=False)
    y.setflags(write=False)
    return x, y


def adobe_exposure_ramp(linear: np.ndarray, *, ev: float = 0.0, shadows: float = ADOBE_DEFAULT_SHADOWS
                        ) -> np.ndarray:
    """Adobe's exposure ramp, applied to each channel (DNG SDK ``dng_function_exposure_ramp``).

    With ``w = 2^−max(ev, 0)`` and black ``b = min(shadows·0.001, 0.99·w)``: ``(x − b)/(w − b)``
    clipped to [0, 1], joined to 0 below ``b`` by a parabola of radius ``r = min(b/2, (w − b)/16)``.
    A negative ``ev`` is not a gain here: the SDK folds it into the tone curve
    (:func:`adobe_exposure_shoulder`), which the hue-preserving rule then applies.

    Parameters
    ----------
    linear : numpy.ndarray
        Linear values (1 = white).
    ev : float
        Exposure in stops (BaselineExposure + the user's offset).
    shadows : float
        Adobe's shadows setting (default 5; 0 = no black point).

    Returns
    -------
    numpy.ndarray
        In [0, 1]: float32 for float32 input (the develop's fast path), else float64.

    References
    ----------
    .. [1] Adobe DNG SDK 1.7, ``source/dng_render.cpp`` (``dng_function_exposure_ramp``,
       ``dng_render_task::Start``).
    """
    x = np.asarray(linear)
    real = _F32 if x.dtype == _F32 else np.float64
    x = x.astype(real, copy=False)
    white = 2.0 ** -max(float(ev), 0.0)
    black = min(shadows * 0.001, 0.99 * white)
    slope = 1.0 / (white - black)
    radius = min(0.5 * black, (1.0 / 16.0) / slope)
    y = x - real(black)
    y *= real(slope)
    np.clip(y, 0.0, 1.0, out=y)
    if radius > 0:  # the parabolic toe joins the ramp to 0 around the black point
        toe = np.clip(x - real(black - radius), 0.0, real(2 * radius))
        toe *= toe
        toe *= real(slope / (4.0 * radius))
        np.copyto(y, toe, where=x < real(black + radius))
    return y


def adobe_exposure_shoulder(values: np.ndarray, *, ev: float) -> np.ndarray:
    """Adobe's negative exposure as a curve (``dng_function_exposure_tone``): ``x·2^ev`` up to
    0.25, then the parabola ``a·x² + b·x + c`` (a = 16/9·(1 − 2^ev)) that keeps white at white;
    the identity for ``ev ≥ 0``. The SDK concatenates it with the tone curve.

    References
    ----------
    .. [1] Adobe DNG SDK 1.7, ``source/dng_render.cpp`` (``dng_function_exposure_tone``).
    """
    x = np.asarray(values, dtype=np.float64)
    if ev >= 0:
        return x
    gain = 2.0 ** float(ev)
    a = 16.0 / 9.0 * (1.0 - gain)
    b = gain - 0.5 * a
    c = 1.0 - a - b
    return np.where(x <= 0.25, x * gain, (a * x + b) * x + c)


def rgb_tone(rgb: np.ndarray, curve) -> np.ndarray:
    """Adobe's hue-preserving RGB tone rule: the curve on each pixel's largest and smallest
    channel, the middle one placed between them in the same proportion as before
    (``out_c = lo' + (hi' − lo')·(x_c − lo)/(hi − lo)``; neutrals get ``curve(x)``).

    Parameters
    ----------
    rgb : numpy.ndarray
        (..., 3) values in [0, 1].
    curve : callable
        Maps values in [0, 1] to [0, 1].

    Returns
    -------
    numpy.ndarray
        float32 (..., 3).

    References
    ----------
    .. [1] Adobe DNG SDK 1.7, ``source/dng_reference.cpp`` (``RefBaselineRGBTone``).
    """
    x = np.asarray(rgb, dtype=_F32)
    r, g, b = x[..., 0], x[..., 1], x[..., 2]
    hi = np.maximum(np.maximum(r, g), b)[..., None]  # elementwise: faster than a reduction over 3
    lo = np.minimum(np.minimum(r, g), b)[..., None]
    hi_t, lo_t = curve(hi), curve(lo)
    # a neutral (hi = lo) gets lo_t = curve(x) from the same formula: x − lo = 0
    hi_t -= lo_t
    hi -= lo
    np.maximum(hi, _F32(1e-12), out=hi)
    hi_t /= hi
    out = x - lo
    out *= hi_t
    out += lo_t
    return out


def _primaries_to_xyz(xy_rgb, xy_white) -> np.ndarray:
    """RGB → XYZ of a colour space from its primaries and white (SMPTE RP 177-1993 §3.3)."""
    xy = np.asarray(xy_rgb, dtype=np.float64)
    primaries = np.stack([xy[:, 0] / xy[:, 1], np.ones(3), (1 - xy[:, 0] - xy[:, 1]) / xy[:, 1]])
    wx, wy = xy_white
    white = np.array([wx / wy, 1.0, (1 - wx - wy) / wy])
    return primaries * np.linalg.solve(primaries, white)


@functools.lru_cache(maxsize=1)
def srgb_prophoto_matrices() -> tuple[np.ndarray, np.ndarray]:
    """Linear sRGB (D65) → linear ProPhoto RGB (ROMM, D50) through XYZ with Bradford
    adaptation, and its inverse.

    References
    ----------
    .. [1] ISO 22028-2:2013 (ROMM RGB primaries and D50 white).
    .. [2] IEC 61966-2-1:1999; Lam (1985) Bradford transform.
    """
    from ..cie import SRGB_TO_XYZ, bradford_adaptation, xy_to_xyz, xyz_d65_white

    d50 = (0.3457, 0.3585)
    romm_to_xyz = _primaries_to_xyz([(0.7347, 0.2653), (0.1596, 0.8404), (0.0366, 0.0001)], d50)
    adapt = bradford_adaptation(xyz_d65_white(), xy_to_xyz(np.array(d50)))
    forward = np.linalg.inv(romm_to_xyz) @ adapt @ SRGB_TO_XYZ
    return forward, np.linalg.inv(forward)


def adobe_linear_srgb(linear: np.ndarray, *, ev: float = 0.0) -> np.ndarray:
    """Adobe's default rendering up to the output colour space: linear sRGB to linear ProPhoto RGB,
    Adobe's exposure ramp (``ev``, default shadows), the ACR3 default curve by Adobe's hue-preserving
    RGB tone rule, back to linear sRGB, clipped to [0, 1] (:func:`spectral_cam.isp.tone.adobe` then
    applies the sRGB encoding). Cache-sized bands of pixels on threads.

    Parameters
    ----------
    linear : numpy.ndarray
        (..., 3) linear sRGB (D65; 1 = reference white), before any exposure gain.
    ev : float
        Exposure in stops (the DNG's BaselineExposure plus the user's ``exposure_ev``).

    Returns
    -------
    numpy.ndarray
        float32 linear sRGB in [0, 1], the shape of ``linear``.

    References
    ----------
    .. [1] Adobe DNG SDK 1.7, ``dng_render.cpp`` (``dng_render_task``: exposure ramp, baseline
       tone curve, final colour space) and ``dng_reference.cpp`` (``RefBaselineRGBTone``).
    """
    import cv2

    x = np.asarray(linear, dtype=_F32)
    to_prophoto, to_srgb = (m.astype(_F32) for m in srgb_prophoto_matrices())
    curve = _curve_table(float(min(ev, 0.0)))
    flat = x.reshape(-1, 3)
    out = np.empty_like(flat)

    def transform(pixels: np.ndarray, matrix: np.ndarray) -> np.ndarray:
        # OpenCV, not `@`: a matrix product on these threads called OpenBLAS, whose own threads
        # on top of ours took a 24 MP tone stage from 1.1 s to 12-14 s on 2 loaded cores
        return cv2.transform(np.ascontiguousarray(pixels).reshape(-1, 1, 3), matrix).reshape(-1, 3)

    def band(start: int) -> None:  # cache-sized row bands on threads (NumPy releases the GIL)
        part = transform(flat[start:start + _BAND_PIXELS], to_prophoto)
        toned = rgb_tone(adobe_exposure_ramp(part, ev=ev), curve)
        back = transform(toned, to_srgb)
        np.clip(back, 0, 1, out=back)
        out[start:start + _BAND_PIXELS] = back

    starts = range(0, len(flat), _BAND_PIXELS)
    if len(starts) > 1:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(max_workers=min(len(starts), os.cpu_count() or 1)) as pool:
            list(pool.map(band, starts))
    else:
        band(0)
    return out.reshape(x.shape)


#: Pixels per band of :func:`adobe_linear_srgb`'s threads (1 MiB of float32 RGB a temporary).
_BAND_PIXELS = 1 << 16


#: Samples of the tone table the develop interpolates (Adobe's own table has 1025).
_TABLE_SIZE = 4096


@functools.lru_cache(maxsize=8)
def _curve_table_values(ev_negative: float) -> np.ndarray:
    """The ACR3 curve after Adobe's negative-exposure shoulder (identity for ev ≥ 0), sampled
    at :data:`_TABLE_SIZE` + 1 points of [0, 1]."""
    grid = np.linspace(0.0, 1.0, _TABLE_SIZE + 1)
    values = np.interp(adobe_exposure_shoulder(grid, ev=ev_negative), *adobe_default_curve()).astype(_F32)
    values.setflags(write=False)
    return values


def _curve_table(ev_negative: float):
    """A fast curve: linear interpolation in :func:`_curve_table_values` (values in [0, 1])."""
    table = _curve_table_values(ev_negative)

    step = np.diff(table).astype(_F32)  # table[i + 1] − table[i]

    def curve(values: np.ndarray) -> np.ndarray:
        # fmax then fmin, not clip: NaN becomes 0 (the curve's black end), never an int32 index of −2³¹
        position = np.fmin(np.fmax(values, _F32(0.0)), _F32(1.0)) * _F32(_TABLE_SIZE)
        index = np.minimum(position.astype(np.int32), _TABLE_SIZE - 1)
        position -= index  # the fraction
        position *= step[index]
        position += table[index]
        return position

    return curve


def adobe_curve(values: np.ndarray) -> np.ndarray:
    """Adobe's ACR3 default curve (:func:`adobe_default_curve`) at ``values`` in [0, 1], linearly
    interpolated between its 1025 samples as the DNG SDK does: ``"adobe"``'s ProfileToneCurve.

    References
    ----------
    .. [1] Adobe DNG SDK 1.7, ``source/dng_render.cpp`` (``dng_tone_curve_acr3_default::Evaluate``).
    """
    return np.interp(values, *adobe_default_curve())
