"""Issue 29 #4: rolling shutter and flicker. Under a light flickering at f, a rolling shutter's rows
band with a period of 1/(f·t_row) rows (within 1 %); each row's level against the analytic mean of
the modulation over its exposure window (within 2 %); no banding at T = k/f; a short global
exposure changes from frame to frame with the light's phase; bad settings are refused."""

from __future__ import annotations

import math

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.errors import ConfigError
from spectral_cam.radiance_targets import lambertian_radiance, uniform_image
from spectral_cam.sensor.temporal import mean_power

pytestmark = pytest.mark.timeout(120)

QUIET = {"shot_noise": False, "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0,
         "bit_depth": 16, "vignetting": False, "cfa": "none", "model": "ideal", "crop_margin_px": 0}


def _rows(height=400, width=8, *, exposure_s, shutter="rolling", row_time_s=20e-6, start_s=0.0, **light):
    """Mean level of each row of a noise-free monochrome flat field (40 lx: unclipped at 20 ms and
    under a PWM peak of 2.9 times the mean) under a flickering light."""
    scene = sc.scene_from_dict({"sensor": {"width_px": width, "height_px": height, "shutter": shutter,
                                           "row_time_s": row_time_s, **QUIET},
                                "illuminant": {"spd": "D65", **light},
                                "exposure": {"time_s": exposure_s, "start_s": start_s}})
    radiance = uniform_image(lambertian_radiance("D65", [0.5], illuminance_lux=40.0)[0], (height, width))
    raw = sc.expose(radiance, scene)
    return (raw.mosaic.astype(float) - raw.black_level).mean(axis=1)


def _integral_by_quadrature(start, exposure_s, waveform):
    """The mean of w over [start, start + T] by the trapezoid rule on 20 001 points (independent of the
    closed form)."""
    t = np.linspace(start, start + exposure_s, 20001)
    return np.trapezoid(waveform(t), t) / exposure_s


@pytest.mark.parametrize(("waveform", "duty"), [("sine", 0.5), ("pwm", 0.3)])
def test_rolling_shutter_bands_have_the_flicker_period_and_the_analytic_amplitude(waveform, duty):
    """100 Hz flicker (50 Hz mains), 20 µs per row, 2 ms exposure: the bands' period is
    1/(100·20e-6) = 500 rows; each row equals the modulation's mean over its own window, computed by
    quadrature of w(t) (within 2 % of the steady level)."""
    f, depth, exposure = 100.0, 0.8, 2e-3
    levels = _rows(height=1200, exposure_s=exposure, flicker_hz=f, flicker_depth=depth, flicker_waveform=waveform,
                   flicker_duty=duty)
    steady = _rows(height=1200, exposure_s=exposure)
    ratio = levels / steady
    if waveform == "sine":
        def w(t):
            return 1 + depth * np.cos(2 * math.pi * f * t)
    else:
        def w(t):
            return (1 - depth) + depth * ((np.mod(t * f, 1.0) < duty) / duty)
    for row in (0, 137, 250, 499, 777, 1100):
        expected = _integral_by_quadrature(row * 20e-6, exposure, w)
        assert ratio[row] == pytest.approx(expected, abs=0.02), (row, ratio[row], expected)
    # the period: rows r and r + 500 see the same phase (a period of 495 or 505 rows would leave them
    # 0.03 apart at this amplitude)
    np.testing.assert_allclose(ratio[:700], ratio[500:1200], atol=1e-3)
    assert not np.allclose(ratio[:200], ratio[250:450], atol=0.02)  # half a period later is not alike


def test_an_exposure_of_whole_flicker_periods_shows_no_bands():
    """T = 10 ms = one period of 100 Hz (and 20 ms = two): every row gets the steady level (within 0.2 %)."""
    steady = _rows(exposure_s=10e-3)
    for exposure in (10e-3, 20e-3):
        levels = _rows(exposure_s=exposure, flicker_hz=100.0, flicker_depth=1.0)
        np.testing.assert_allclose(levels / _rows(exposure_s=exposure), 1.0, atol=2e-3)
    assert steady.std() / steady.mean() < 1e-3


def test_a_short_global_exposure_changes_from_frame_to_frame():
    """Global shutter, 1 ms under 100 Hz: all rows alike in a frame; frames started 0, 2.5 and 5 ms apart
    get the analytic means (cos phase: bright, middle, dark) within 2 %."""
    steady = _rows(exposure_s=1e-3, shutter="global").mean()
    for start in (0.0, 2.5e-3, 5e-3):
        levels = _rows(exposure_s=1e-3, shutter="global", start_s=start, flicker_hz=100.0, flicker_depth=1.0)
        assert levels.std() / levels.mean() < 1e-3
        expected = mean_power(start, 1e-3, waveform="sine", frequency_hz=100.0, depth=1.0)
        quadrature = _integral_by_quadrature(start, 1e-3, lambda t: 1 + np.cos(2 * math.pi * 100 * t))
        assert float(expected) == pytest.approx(quadrature, abs=1e-6)
        assert levels.mean() / steady == pytest.approx(quadrature, abs=0.02)


@pytest.mark.parametrize(("section", "key", "bad"), [("illuminant", "flicker_hz", -1),
                                                     ("illuminant", "flicker_depth", 1.5),
                                                     ("illuminant", "flicker_waveform", "square"),
                                                     ("illuminant", "flicker_duty", 0),
                                                     ("sensor", "shutter", "electronic"),
                                                     ("sensor", "row_time_s", 0),
                                                     ("exposure", "start_s", "now")])
def test_bad_timing_settings_are_refused_with_what_would_be_valid(section, key, bad):
    with pytest.raises(ConfigError, match=key):
        sc.scene_from_dict({section: {key: bad}})


@pytest.mark.parametrize("waveform", ["sine", "pwm"])
def test_the_flicker_phase_keeps_its_precision_a_million_seconds_in(waveform):
    """Issue 39 #31: at exposure.start_s = 1e6 s a 1 ns window under 100 Hz flicker was 10.6 % off (the
    window's integral a difference of two numbers near 1e6). The truth: the window's phase by exact
    rational arithmetic (Fraction of the start's float times f, modulo 1), the waveform at the
    window's middle (1 ns is 1e-7 of a period); within 1e-6."""
    from fractions import Fraction

    f, depth, duty, exposure = 100.0, 1.0, 0.3, 1e-9
    for start in (1e6, 1e6 + 0.0025, 999_999.0037, 123_456.789):
        phase = float((Fraction(start) * Fraction(f) + Fraction(exposure) * Fraction(f) / 2) % 1)
        if waveform == "sine":
            truth = 1 + depth * math.cos(2 * math.pi * phase)
        else:
            truth = (1 - depth) + depth * (phase < duty) / duty
        got = float(mean_power(start, exposure, waveform=waveform, frequency_hz=f, depth=depth, duty=duty))
        assert got == pytest.approx(truth, abs=1e-6), (start, got, truth)
