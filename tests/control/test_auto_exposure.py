"""Issue 17 #2: auto exposure as a damped loop with a dead band, against its hand-computed step
response, and its metering modes and program limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spectral_cam.control import AutoExposure, ExposureState, meter
from spectral_cam.metering import GREY_RAW
from spectral_cam.errors import ConfigError


def _scene(seed=0):
    texture = np.random.default_rng(seed).uniform(0.5, 1.5, (48, 64))  # reflectance-like texture
    return texture / texture.mean()  # mean exactly 1: average metering reads brightness × exposure


def _run(ae, brightness, frames, state):
    """Frames of a scene whose luminance per unit exposure is ``brightness(k)``: each frame taken
    with the loop's current exposure, metered, and stepped."""
    texture, history = _scene(), []
    for k in range(frames):
        gain = state.time_s * state.iso / ae.base_iso
        luminance = np.clip(texture * brightness(k) * gain, 0.0, 1.0)
        state = ae.step(state, luminance)
        history.append(state)
    return history


def test_a_brightness_step_settles_in_the_frames_the_damping_implies_without_overshoot():
    """Damping 0.5, dead band 1/6 EV, the scene 3 EV darker at once: the residual halves each
    frame, 3·0.5ⁿ ≤ 1/6 first at n = 5 (by hand: 3, 1.5, 0.75, 0.375, 0.1875, 0.094): five
    corrections, then the loop rests; every error has the same sign and shrinks (no
    oscillation)."""
    ae = AutoExposure(damping=0.5, dead_band_ev=1 / 6, max_shutter_s=1.0, max_iso=100.0)
    # the exposure that meters mid grey (ISO 12232: 10/78 of saturation) at brightness 100
    start = ExposureState(time_s=GREY_RAW * 1e-2, iso=100.0)
    history = _run(ae, lambda k: 100.0 / 8.0, 12, start)
    errors = [s.error_ev for s in history]
    assert errors[0] == pytest.approx(3.0, abs=1e-9)
    assert [s.adjusted for s in history] == [True] * 5 + [False] * 7
    assert ae.frames_to_settle(3.0) == 5
    assert all(e > 0 for e in errors) and all(b < a for a, b in zip(errors[:6], errors[1:6]))
    assert abs(errors[5]) <= 1 / 6 and errors[5] == pytest.approx(3.0 * 0.5 ** 5, rel=1e-9)


def test_damping_one_corrects_at_once_and_locked_never_moves():
    ae = AutoExposure(damping=1.0, dead_band_ev=0.1, max_shutter_s=1.0)
    start = ExposureState(time_s=GREY_RAW * 1e-2, iso=100.0)
    history = _run(ae, lambda k: 100.0 / 4.0, 3, start)
    assert [s.adjusted for s in history] == [True, False, False] and abs(history[1].error_ev) < 1e-9
    locked = _run(AutoExposure(mode="locked"), lambda k: 100.0 / 4.0, 3, start)
    assert {(s.time_s, s.iso) for s in locked} == {(GREY_RAW * 1e-2, 100.0)} and locked[-1].error_ev == pytest.approx(2.0)


def test_the_program_keeps_its_limits():
    """Shutter priority holds the time at max_shutter_s and raises ISO only then, up to max_iso;
    ISO priority holds the base ISO; the compensation moves the target by 2^EV."""
    ae = AutoExposure(program="shutter_priority", max_shutter_s=1 / 30, max_iso=3200.0)
    assert ae.split(math.log2(1 / 60)) == (pytest.approx(1 / 60), 100.0)
    time_s, iso = ae.split(math.log2(1 / 30 * 8))
    assert time_s == pytest.approx(1 / 30) and iso == pytest.approx(800.0)
    assert ae.split(math.log2(1 / 30 * 1000))[1] == 3200.0
    assert AutoExposure(program="iso_priority").split(math.log2(1.0)) == (pytest.approx(1 / 30), 100.0)
    assert AutoExposure().target == pytest.approx(10 / 78)  # ISO 12232: H = 10/S, S_sat = 78/H_sat
    assert AutoExposure(compensation_ev=1.0).target == pytest.approx(20 / 78)


def test_metering_modes_weigh_the_frame_as_their_names_say():
    frame = np.full((100, 100), 0.1)
    frame[35:65, 35:65] = 0.9  # a bright centre, 9 % of the area (the spot is the central 5 %)
    assert meter(frame, "average") == pytest.approx(0.1 + 0.8 * 0.09)
    assert meter(frame, "spot") == pytest.approx(0.9)
    assert meter(frame, "average") < meter(frame, "centre_weighted") < meter(frame, "spot")
    # highlight-protecting: the average while the brightest 1 % stays below the fraction ...
    assert meter(frame, "highlight", highlight_target=0.9) == pytest.approx(meter(frame, "average"))
    # ... and the 99th percentile placed at it (0.9 of saturation) once it would clip
    frame[35:65, 35:65] = 3.0
    assert meter(frame, "highlight", highlight_target=0.9) == pytest.approx(3.0 * GREY_RAW / 0.9)
    assert meter(frame, "highlight", highlight_target=0.9) > meter(frame, "average")
    assert meter(frame, "etr", highlight_target=0.8) == pytest.approx(3.0 * GREY_RAW / 0.8)
    with pytest.raises(ConfigError, match="unknown metering mode 'matrix'; valid: average"):
        meter(frame, "matrix")
    with pytest.raises(ConfigError, match="overshoot"):
        AutoExposure(damping=1.5)


@pytest.mark.parametrize("key, value", [("compensation_ev", 1e9), ("compensation_ev", -1e9),
                                        ("compensation_ev", float("nan")), ("highlight_target", 0.0),
                                        ("highlight_target", -1.0), ("damping", "0.5"), ("max_iso", float("inf"))])
def test_controller_settings_are_refused_with_their_range_before_anything_renders(key, value):
    """Issue 25 #9–#10: each was a traceback or a wrong result after every frame had rendered."""
    with pytest.raises(ConfigError, match=rf"\[camera\] {key} = .*give a number in"):
        AutoExposure(**{key: value})


def test_white_balance_and_sequence_hours_are_refused_with_what_is_valid():
    from spectral_cam.apps.sequence.spec import sequence_from_dict
    from spectral_cam.control import AutoWhiteBalance

    with pytest.raises(ConfigError, match=r"wb_white = \[0, 1, 1\]: give the white's camera R, G, B"):
        AutoWhiteBalance(mode="manual", manual_white=(0, 1, 1))
    with pytest.raises(ConfigError, match=r"start_hour = 'abc': give a local clock time in hours, 0..24"):
        sequence_from_dict({"scene": {"preset": "vegetation"}, "sequence": {"frames": 2, "start_hour": "abc"}})
    with pytest.raises(ConfigError, match=r"end_hour = inf"):
        sequence_from_dict({"scene": {"preset": "vegetation"}, "sequence": {"frames": 2, "end_hour": float("inf")}})
