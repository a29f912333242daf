"""When each row integrates light: global or rolling shutter, and light that flickers.

Row r of a rolling shutter starts its exposure r·t_row after the first (t_row the readout time per
row) and integrates for the exposure time T; a global shutter exposes every row over the same
interval. A light whose power is modulated in time, P(t) = P̄·w(t) with w's mean 1 over a period,
gives row r the electrons of its mean power over its own window,

    W_r = (1/T)·∫ w(t) dt over [t₀ + r·t_row, t₀ + r·t_row + T],

so a rolling shutter shows bands of period 1/(f·t_row) rows, and a short global exposure changes
brightness from frame to frame (t₀ the frame's start, ``exposure.start_s``). W_r = 1 whenever T is
a whole number of flicker periods (the classic remedy).

Waveforms (``illuminant.flicker_waveform``), with depth m ∈ [0, 1] and frequency f (the light's, so
twice the mains frequency for a lamp on the mains):

- ``sine``: w(t) = 1 + m·cos(2π·f·t) (a lamp on rectified mains, fluorescent or a poorly
  smoothed LED driver);
- ``pwm``: an LED dimmed by pulse-width modulation at duty D: w = (1 − m) + m·s(t)/D, s = 1 for
  the first D of each period, else 0.

The scene's whole light is taken to flicker alike (one illuminant).

References
----------
.. [1] IEEE Std 1789-2015, Recommended Practices for Modulating Current in High-Brightness LEDs
   for Mitigating Health Risks to Viewers (percent flicker, modulation depth, PWM).
.. [2] Liang, C.-K., Chang, L.-W., & Chen, H. H. (2008). Analysis and compensation of rolling
   shutter effect. IEEE Trans. Image Processing 17(8), 1323–1330 (row exposure times).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConfigError

__all__ = ["FLICKER_WAVEFORMS", "SHUTTERS", "row_start_times", "mean_power", "instantaneous_power", "flickers",
           "row_exposure_factors", "frame_row_factors"]

#: ``sensor.shutter`` choices.
SHUTTERS = ("global", "rolling")
#: ``illuminant.flicker_waveform`` choices.
FLICKER_WAVEFORMS = ("sine", "pwm")


def row_start_times(height: int, *, shutter: str, row_time_s: float, start_s: float = 0.0) -> np.ndarray:
    """(H,) start of each row's exposure (s): ``start_s`` for a global shutter, ``start_s + r·t_row`` for
    a rolling one."""
    if shutter not in SHUTTERS:
        raise ConfigError(f"sensor.shutter = {shutter!r}; valid: {', '.join(SHUTTERS)}")
    rows = np.arange(int(height), dtype=np.float64)
    return start_s + (rows * row_time_s if shutter == "rolling" else 0.0 * rows)


def _reduced(origin_s: float, frequency_hz: float) -> float:
    """``origin_s`` modulo the flicker period (s), by exact rational arithmetic on the two floats: a
    window's phase at t₀ = 10⁶ s would otherwise come from a difference of two numbers near 10⁶ (a 1 ns
    window was 10.6 % off, issue 39 #31)."""
    from fractions import Fraction

    period = 1 / Fraction(frequency_hz)
    return float(Fraction(float(origin_s)) % period)


def _pwm_integral(t: np.ndarray, *, frequency_hz: float, depth: float, duty: float) -> np.ndarray:
    """∫₀ᵗ w(τ) dτ of the PWM waveform (s); ``t`` within a few periods of 0 (see :func:`_reduced`)."""
    t = np.asarray(t, dtype=np.float64)
    period = 1.0 / frequency_hz
    whole = np.floor(t / period)
    into = t - whole * period
    on_time = whole * duty * period + np.minimum(into, duty * period)  # time spent on, from 0 to t
    return (1.0 - depth) * t + depth * on_time / duty


def _check_waveform(waveform: str) -> None:
    if waveform not in FLICKER_WAVEFORMS:
        raise ConfigError(f"illuminant.flicker_waveform = {waveform!r}; valid: {', '.join(FLICKER_WAVEFORMS)}")


def mean_power(start_s, exposure_s: float, *, waveform: str, frequency_hz: float, depth: float,
               duty: float = 0.5, origin_s: float = 0.0) -> np.ndarray:
    """The waveform's mean over [t₀ + start, t₀ + start + T] (1 for a steady light, or T a whole number
    of periods).

    The sine's mean is the closed form 1 + m·cos(2πf·(s + T/2))·sinc(fT) (no difference of two
    integrals); t₀ (``origin_s``, and a scalar ``start_s``) is reduced modulo the period exactly first,
    so the phase keeps its precision however late the window (1 ns at 10⁶ s: within 1e-9).

    Parameters
    ----------
    start_s : array_like
        Window starts (s) after ``origin_s``.
    exposure_s : float
        Window length T (s), > 0.
    waveform, frequency_hz, depth, duty
        As in the module docstring; ``frequency_hz = 0`` or ``depth = 0``: steady.
    origin_s : float
        t₀ (s), e.g. ``exposure.start_s``: kept apart from the (small) offsets ``start_s`` so that its
        reduction modulo the period is exact.

    Returns
    -------
    numpy.ndarray
        W for each start.

    References
    ----------
    .. [1] IEEE Std 1789-2015 (modulation depth, PWM).
    """
    start = np.asarray(start_s, dtype=np.float64)
    if frequency_hz == 0 or depth == 0:
        return np.ones_like(start)
    if not exposure_s > 0:
        raise ConfigError(f"exposure time {exposure_s!r} s: flicker needs a positive exposure")
    _check_waveform(waveform)
    if start.ndim == 0:  # one window, perhaps late: reduced exactly too
        start = np.asarray(_reduced(float(start), frequency_hz))
    period = 1.0 / frequency_hz
    start = np.fmod(start + _reduced(origin_s, frequency_hz), period)  # fmod is exact: no precision lost
    if waveform == "sine":
        phase = 2.0 * math.pi * frequency_hz * (start + 0.5 * exposure_s)
        return 1.0 + depth * np.cos(phase) * np.sinc(frequency_hz * exposure_s)
    kwargs = {"frequency_hz": frequency_hz, "depth": depth, "duty": duty}
    return (_pwm_integral(start + exposure_s, **kwargs) - _pwm_integral(start, **kwargs)) / exposure_s


def instantaneous_power(t_s, *, waveform: str, frequency_hz: float, depth: float, duty: float = 0.5,
                        origin_s: float = 0.0) -> np.ndarray:
    """w(t₀ + t), the light's power relative to its mean at times ``t_s`` after ``origin_s`` (what an event
    pixel's photocurrent follows); t₀ reduced modulo the period exactly, as in :func:`mean_power`."""
    t = np.asarray(t_s, dtype=np.float64)
    if frequency_hz == 0 or depth == 0:
        return np.ones_like(t)
    _check_waveform(waveform)
    cycles = np.mod((t + _reduced(origin_s, frequency_hz)) * frequency_hz, 1.0)
    if waveform == "sine":
        return 1.0 + depth * np.cos(2.0 * math.pi * cycles)
    return (1.0 - depth) + depth * (cycles < duty) / duty


def flickers(config) -> bool:
    """Whether the scene's light is modulated in time (``illuminant.flicker_hz`` and ``flicker_depth``)."""
    return bool(config.illuminant.flicker_hz) and bool(config.illuminant.flicker_depth)


def _light(config) -> dict:
    light = config.illuminant
    return {"waveform": light.flicker_waveform, "frequency_hz": light.flicker_hz, "depth": light.flicker_depth,
            "duty": light.flicker_duty}


def row_exposure_factors(config, height: int, exposure_s: float) -> np.ndarray | None:
    """(H, 1) float32 mean light each row integrates over its exposure, relative to the steady light's;
    None when the light is steady (nothing to do)."""
    if not flickers(config):
        return None
    offsets = row_start_times(height, shutter=config.sensor.shutter, row_time_s=config.sensor.row_time_s)
    factors = mean_power(offsets, exposure_s, origin_s=config.exposure.start_s, **_light(config))
    return factors.astype(np.float32)[:, None]


def frame_row_factors(config, height: int, frame_s: float, frames: int) -> np.ndarray | None:
    """(F, H) float64 mean light of each row in each of ``frames`` back-to-back frames of ``frame_s``
    (a single-photon sensor's jot frames: frame f of row r covers t₀ + r·t_row + f·t_f onwards, the same
    windows :func:`row_exposure_factors` integrates for one frame); None for a steady light."""
    if not flickers(config):
        return None
    rows = row_start_times(height, shutter=config.sensor.shutter, row_time_s=config.sensor.row_time_s)
    starts = np.arange(int(frames), dtype=np.float64)[:, None] * frame_s + rows[None, :]
    return mean_power(starts, frame_s, origin_s=config.exposure.start_s, **_light(config))
