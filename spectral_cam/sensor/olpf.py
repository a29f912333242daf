"""Optical low-pass (anti-aliasing) filter: the birefringent four-spot filter in front of a sensor.

Two birefringent plates, one splitting light horizontally and one vertically, each into an
ordinary ray (undeviated) and an extraordinary ray displaced by the spot separation d: every
point of the image becomes four spots of a quarter of its power at (0, 0), (d, 0), (0, d) and
(d, d). Its transfer function is H(fx, fy) = ½(1 + e^(−2πi·fx·d)) · ½(1 + e^(−2πi·fy·d)), of
magnitude |cos(π·fx·d)|·|cos(π·fy·d)|: zero at f = 1/(2d), so d = one pixel pitch nulls the
Nyquist frequency, the classic design. The image's centroid moves d/2 right and down, as in a
camera.

It acts on the irradiance before the pixels sample it, so it is applied to each colour channel's
full-resolution electron-rate plane (linear in the band irradiance, so equal to filtering every
band) before the colour filter array picks each pixel's channel: the false colour a Bayer mosaic
makes of detail between its colour Nyquist (1/4 cycle per pixel) and the pixel Nyquist (1/2) is
what it takes off. Shifts by whole pixels are exact (they commute with sampling); a fractional
separation is applied as the band-limited (Fourier) shift of the rendered pixels, exact below
the pixel Nyquist frequency.

The birefringence of quartz or lithium niobate changes by ~1 % across the visible (Ghosh 1999),
so d is taken as the same in every band.

References
----------
.. [1] Greivenkamp, J. E. (1990). Color dependent optical prefilter for the suppression of
   aliasing artifacts. Applied Optics 29(5), 676–684 (the four-spot birefringent filter, its
   MTF |cos(π f d)|).
.. [2] Ghosh, G. (1999). Dispersion-equation coefficients for the refractive index and
   birefringence of calcite and quartz crystals. Optics Communications 163, 95–102.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["CAMERA_OLPF", "olpf_separation_px", "apply_olpf", "olpf_mtf", "OLPF_CHOICES"]

#: ``sensor.olpf`` words: no filter, or the camera's own (:data:`CAMERA_OLPF`).
OLPF_CHOICES = ("off", "camera")

#: Whether each bundled camera has an optical low-pass filter, from its maker's specifications, and its
#: spot separation in pixel pitches. No maker publishes the separation: the cameras with a filter take
#: 1 pitch (nulls at Nyquist, the classic design). None: built without one; "unknown": not published.
CAMERA_OLPF: dict[str, float | None | str] = {
    "nikon_d850": None,        # Nikon: no optical low-pass filter
    "nikon_d810": None,        # Nikon: no optical low-pass filter
    "sony_ilce_7rm3": None,    # Sony α7R III: no optical low-pass filter
    "sony_ilce_7m3": 1.0,
    "sony_ilce_9": 1.0,
    "sony_ilce_6400": 1.0,
    "canon_eos_5ds": 1.0,      # the 5DS (the 5DS R cancels it)
    "canon_eos_5d": 1.0,
    "canon_eos_5d_mkii": 1.0,
    "canon_eos_5d_mkiii": 1.0,
    "canon_eos_5d_mkiv": 1.0,
    "canon_eos_1dx_mkii": 1.0,
    "canon_eos_100d": 1.0,
    "canon_eos_200d": 1.0,
    "canon_eos_200d_mkii": 1.0,
    "canon_eos_m": 1.0,
    "nikon_5100_npl": 1.0,     # the D5100
    "sigma_sdmerill_npl": None,  # Sigma SD1 Merrill (Foveon X3): no low-pass filter
    "hasselblad_l1d_20c": "unknown",
}


def parse_olpf(value) -> float | str:
    """``sensor.olpf`` as a spot separation in pitches (float, 0 = off) or ``"camera"``; "<x> um"
    strings stay strings for :func:`olpf_separation_px` (they need the pitch)."""
    if isinstance(value, bool):
        value = "off" if not value else "camera"
    if isinstance(value, (int, float)):
        if not (np.isfinite(value) and 0 <= value <= 4):
            raise ConfigError(f"sensor.olpf = {value!r}: a spot separation in pixel pitches must lie in 0..4 "
                              "(1: nulls the Nyquist frequency); or 'off', 'camera', or microns as '3.5 um'")
        return float(value)
    text = str(value).strip().lower()
    if text in OLPF_CHOICES:
        return 0.0 if text == "off" else "camera"
    if text.endswith("um") or text.endswith("µm"):
        try:
            microns = float(text.rstrip("uµm").strip())
        except ValueError:
            microns = float("nan")
        if np.isfinite(microns) and 0 <= microns <= 100:
            return text
    raise ConfigError(f"sensor.olpf = {value!r}; valid: 'off', 'camera' (the camera's own, where known), a spot "
                      "separation in pixel pitches (0..4, 1 nulls Nyquist), or microns as '3.5 um'")


def olpf_separation_px(olpf, *, model: str, pixel_pitch_um: float) -> tuple[float, str]:
    """The spot separation in pixels of a sensor's ``olpf`` setting, and where it came from.

    Returns
    -------
    (float, str)
        Separation in pixel pitches (0: no filter) and a note for the record.
    """
    value = parse_olpf(olpf)
    if value == "camera":
        known = CAMERA_OLPF.get(model, "unknown")
        if known is None:
            return 0.0, f"{model} is built without an optical low-pass filter (maker's specification)"
        if known == "unknown":
            return 0.0, f"{model}: whether it has an optical low-pass filter is not published; none modelled"
        return float(known), f"{model} has an optical low-pass filter; its separation is not published: " \
                             f"{known:g} pitch assumed (nulls the Nyquist frequency)"
    if isinstance(value, str):
        microns = float(value.rstrip("uµm").strip())
        return microns / pixel_pitch_um, f"{microns:g} µm spot separation ({microns / pixel_pitch_um:.3g} pitch)"
    return value, ("no optical low-pass filter" if value == 0 else f"{value:g} pitch spot separation")


def olpf_mtf(frequency_cycles_per_px, separation_px: float) -> np.ndarray:
    """|H| of the filter along one axis: |cos(π·f·d)| (f in cycles per pixel, d in pixels)."""
    return np.abs(np.cos(np.pi * np.asarray(frequency_cycles_per_px, dtype=float) * separation_px))


def _split(plane: np.ndarray, separation_px: float, axis: int) -> np.ndarray:
    """½(E + E shifted by d along ``axis``): one plate's two spots."""
    if separation_px == 0:
        return plane
    whole = float(separation_px).is_integer()
    if whole:  # exact: a whole-pixel shift commutes with sampling (edge pixels repeated)
        k = int(separation_px)
        shifted = np.take(plane, np.clip(np.arange(plane.shape[axis]) - k, 0, None), axis=axis)
        return 0.5 * (plane + shifted)
    pad = int(np.ceil(separation_px)) + 16  # reflect padding keeps the circular FFT from wrapping edges
    widths = [(0, 0)] * plane.ndim
    widths[axis] = (pad, pad)
    padded = np.pad(plane, widths, mode="reflect")
    n = padded.shape[axis]
    spectrum = np.fft.rfft(padded, axis=axis)
    shape = [1] * plane.ndim
    shape[axis] = -1
    transfer = 0.5 * (1.0 + np.exp(-2j * np.pi * np.fft.rfftfreq(n) * separation_px)).reshape(shape)
    out = np.fft.irfft(spectrum * transfer, n=n, axis=axis)
    return np.take(out, np.arange(pad, pad + plane.shape[axis]), axis=axis).astype(plane.dtype, copy=False)


def apply_olpf(planes: np.ndarray, separation_px: float) -> np.ndarray:
    """The four-spot filter on (H, W) or (H, W, C) irradiance (or electron-rate) planes.

    Parameters
    ----------
    planes : numpy.ndarray
        Full-resolution planes, one per colour channel.
    separation_px : float
        Spot separation d in pixel pitches (0: unchanged).

    Returns
    -------
    numpy.ndarray
        The filtered planes, same shape and dtype; the total power is kept (edges repeated).

    References
    ----------
    .. [1] Greivenkamp (1990), Appl. Opt. 29(5), 676–684.
    """
    if not (np.isfinite(separation_px) and separation_px >= 0):
        raise ConfigError(f"OLPF spot separation {separation_px!r} px: give a number >= 0")
    return _split(_split(planes, separation_px, axis=1), separation_px, axis=0)
