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
what it takes off.

The rendered image is known only as pixel values, so a displacement is applied to them: a whole-
pixel one is exact (it commutes with sampling); a fractional one, d = k + φ, moves each pixel's light
— taken as spread evenly over the pixel — by d and shares it by overlap area between the pixels k
and k + 1 away, (1 − φ) and φ. The filter's spots are non-negative copies of the light, so the
output is non-negative by construction, and the sum is kept; a band-limited (Fourier) shift would
treat the pixel-sampled image's aliased detail as band-limited and ring below zero at every edge.
Among the non-negative kernels whose centroid lies at d, this two-tap one adds the least blur (the
least variance, φ(1 − φ)), so its transfer function, |½(1 + (1 − φ)·e^(−2πifk) + φ·e^(−2πif(k+1)))|,
is the closest to |cos(π·f·d)| that pixel data allows; exact would need the render supersampled.

The light of a frame pixel comes from up to ⌈d⌉ pixels above and left of it: the render's crop
margin (``sensor.crop_margin_px``) must hold them, or the filter would repeat the edge's pixels in
their place (a render job's scene refuses a separation beyond its margin; :func:`apply_olpf` on a
bare image repeats its edge).

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

__all__ = ["CAMERA_OLPF", "olpf_separation_px", "apply_olpf", "olpf_mtf", "olpf_kernel_mtf", "olpf_margin_px",
           "check_olpf_margin", "OLPF_CHOICES"]

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
    """|H| of the ideal filter along one axis: |cos(π·f·d)| (f in cycles per pixel, d in pixels)."""
    return np.abs(np.cos(np.pi * np.asarray(frequency_cycles_per_px, dtype=float) * separation_px))


def olpf_kernel_mtf(frequency_cycles_per_px, separation_px: float) -> np.ndarray:
    """|H| along one axis of the filter as applied to pixels (:func:`apply_olpf`).

    Parameters
    ----------
    frequency_cycles_per_px : array_like
        Spatial frequency f (cycles per pixel).
    separation_px : float
        Spot separation d = k + φ (pixels).

    Returns
    -------
    numpy.ndarray
        |½(1 + (1 − φ)·e^(−2πifk) + φ·e^(−2πif(k+1)))|: |cos(π·f·d)| for a whole-pixel d, below it
        by the area-weighted share's blur for a fractional one.
    """
    f = np.asarray(frequency_cycles_per_px, dtype=float)
    whole, frac = _whole_and_fraction(separation_px)
    shifted = (1.0 - frac) * np.exp(-2j * np.pi * f * whole) + frac * np.exp(-2j * np.pi * f * (whole + 1))
    return np.abs(0.5 * (1.0 + shifted))


def olpf_margin_px(separation_px: float) -> int:
    """Pixels of rendered margin above and left of the frame the filter reads: ⌈d⌉."""
    return int(np.ceil(separation_px - 1e-9))


def check_olpf_margin(olpf, *, model: str, pixel_pitch_um: float, crop_margin_px: int, cfa: str = "RGGB") -> None:
    """Refuse a spot separation that reaches beyond the rendered crop margin.

    Raises
    ------
    ConfigError
        When ⌈d⌉ > ``crop_margin_px``, naming the margin (or the separation) that would fit.
    """
    if cfa == "none" and parse_olpf(olpf) == "camera":
        return  # a monochrome sensor's "camera" filter is none (radiometry._olpf)
    separation, _ = olpf_separation_px(olpf, model=model, pixel_pitch_um=pixel_pitch_um)
    need = olpf_margin_px(separation)
    if need <= crop_margin_px:
        return
    fits = need + need % 2  # the margin is even (it keeps the CFA phase at the crop)
    widen = f"sensor.crop_margin_px = {fits}, or " if fits <= 256 else ""
    raise ConfigError(
        f"sensor.olpf = {olpf!r} is a {separation:.4g}-pixel spot separation at {pixel_pitch_um:g} µm pitch: the "
        f"filter moves light {need} px into the frame from outside it, but sensor.crop_margin_px = {crop_margin_px} "
        f"renders only {crop_margin_px} px there. Set {widen}a separation of at most {crop_margin_px} px "
        f"({crop_margin_px * pixel_pitch_um:g} µm at this pitch)")


def _whole_and_fraction(separation_px: float) -> tuple[int, float]:
    whole = int(np.floor(separation_px))
    return whole, float(separation_px) - whole


def _shifted(plane: np.ndarray, pixels: int, axis: int) -> np.ndarray:
    """``plane`` moved ``pixels`` towards higher indices along ``axis``, its first pixels repeated."""
    index = np.clip(np.arange(plane.shape[axis]) - pixels, 0, None)
    return np.take(plane, index, axis=axis)


def _split(plane: np.ndarray, separation_px: float, axis: int) -> np.ndarray:
    """½(E + E displaced by d along ``axis``): one plate's two spots, the displaced one shared by
    overlap area between the two pixels it straddles (non-negative weights summing to 1)."""
    if separation_px == 0:
        return plane
    if not np.issubdtype(plane.dtype, np.floating):
        plane = plane.astype(np.float64)
    whole, frac = _whole_and_fraction(separation_px)
    out = _shifted(plane, whole, axis) * plane.dtype.type(0.5 * (1.0 - frac))
    if frac > 0:
        out += _shifted(plane, whole + 1, axis) * plane.dtype.type(0.5 * frac)
    out += plane * plane.dtype.type(0.5)
    return out


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
        The filtered planes, same shape and (floating) dtype, non-negative where the input is; the
        sum is kept away from the edges (light moved past the bottom and right edges leaves, and the
        ⌈d⌉ pixels nearest the top and left edges take the edge's pixels for the light that would
        come from beyond it: a render job renders its crop margin there).

    References
    ----------
    .. [1] Greivenkamp (1990), Appl. Opt. 29(5), 676–684.
    """
    if isinstance(separation_px, bool) or not isinstance(separation_px, (int, float, np.floating, np.integer)) \
            or not (np.isfinite(separation_px) and separation_px >= 0):
        raise ConfigError(f"OLPF spot separation {separation_px!r} px: give a number >= 0")
    return _split(_split(planes, separation_px, axis=1), separation_px, axis=0)
