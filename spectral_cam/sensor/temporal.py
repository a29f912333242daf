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

__all__ = ["FLICKER_WAVEFORMS", "SHUTTERS", "row_start_times", "mean_power", "row_exposure_factors"]

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


def _integral(t: np.ndarray, *, waveform: str, frequency_hz: float, depth: float, duty: float) -> np.ndarray:
    """∫₀ᵗ w(τ) dτ of the waveform (s)."""
    t = np.asarray(t, dtype=np.float64)
    if waveform == "sine":
        return t + depth * np.sin(2.0 * math.pi * frequency_hz * t) / (2.0 * math.pi * frequency_hz)
    if waveform == "pwm":
        period = 1.0 / frequency_hz
        whole = np.floor(t / period)
        into = t - whole * period
        on_time = whole * duty * period + np.minimum(into, duty * period)  # time spent on, from 0 to t
        return (1.0 - depth) * t + depth * on_time / duty
    raise ConfigError(f"illuminant.flicker_waveform = {waveform!r}; valid: {', '.join(FLICKER_WAVEFORMS)}")


def mean_power(start_s, exposure_s: float, *, waveform: str, frequency_hz: float, depth: float,
               duty: float = 0.5) -> np.ndarray:
    """The waveform's mean over [start, start + T] (1 for a steady light, or T a whole number of periods).

    Parameters
    ----------
    start_s : array_like
        Window starts (s).
    exposure_s : float
        Window length T (s), > 0.
    waveform, frequency_hz, depth, duty
        As in the module docstring; ``frequency_hz = 0`` or ``depth = 0``: steady.

    Returns
    -------
    numpy.ndarray
        W for each start.
    """
    start = np.asarray(start_s, dtype=np.float64)
    if frequency_hz == 0 or depth == 0:
        return np.ones_like(start)
    if not exposure_s > 0:
        raise ConfigError(f"exposure time {exposure_s!r} s: flicker needs a positive exposure")
    kwargs = {"waveform": waveform, "frequency_hz": frequency_hz, "depth": depth, "duty": duty}
    return (_integral(start + exposure_s, **kwargs) - _integral(start, **kwargs)) / exposure_s


def row_exposure_factors(config, height: int, exposure_s: float) -> np.ndarray | None:
    """(H, 1) float32 mean light each row integrates over its exposure, relative to the steady light's;
    None when the light is steady (nothing to do)."""
    light, sensor = config.illuminant, config.sensor
    if light.flicker_hz == 0 or light.flicker_depth == 0:
        return None
    starts = row_start_times(height, shutter=sensor.shutter, row_time_s=sensor.row_time_s,
                             start_s=config.exposure.start_s)
    factors = mean_power(starts, exposure_s, waveform=light.flicker_waveform, frequency_hz=light.flicker_hz,
                         depth=light.flicker_depth, duty=light.flicker_duty)
    return factors.astype(np.float32)[:, None]
