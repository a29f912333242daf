"""Issue 39 #27, #28: single-photon (QIS/SPAD) and event sensors under a flickering light and a rolling
shutter, and the single-photon meter against the count's saturation.

A QIS/SPAD flat field under 100 Hz flicker with a rolling shutter bands as the light's mean over each
row's jot-frame windows says (the test's own cosine, at the windows' middles); an event pixel under a
light swinging 0.1–1.9× fires the number of threshold crossings of ln(1 + 0.9·cos) that the held-level
rule gives from the waveform's extrema alone; a metered single-photon capture puts its reference at the
mode's share of the count's saturation min(2^b − 1, ⌈t_f/τ⌉)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.image import SpectralImage
from spectral_cam.sensor.events import simulate_events
from spectral_cam.sensor.photon_counting import expose_photon_counting

pytestmark = pytest.mark.timeout(120)

F_HZ, DEPTH, ROW_S = 100.0, 0.8, 20e-6


def _scene(shape, *, exposure, sensor=None, light=None):
    return sc.scene_from_dict({"sensor": {"width_px": shape[1], "height_px": shape[0], "model": "ideal", "cfa": "none",
                                          "vignetting": False, "pixel_pitch_um": 1.1, "dark_current_e_per_s": 0.0,
                                          "crop_margin_px": 0, **(sensor or {})},
                               "lens": {"f_number": 2.0, "focal_length_mm": 50.0, "focus_distance_m": 1e6},
                               "illuminant": light or {}, "exposure": exposure})


def _flat(value, shape):
    return SpectralImage(np.full((*shape, 1), value, np.float32), (550.0,), (545.0, 555.0))


@pytest.mark.parametrize("sensor", [{"kind": "qis"}, {"kind": "spad", "jot_bits": 4, "dead_time_s": 1e-7}])
def test_a_single_photon_flat_field_bands_under_flicker_with_a_rolling_shutter(sensor):
    """400 rows × 32, 20 µs a row, 2 ms over 64 jot frames, 100 Hz at depth 0.8: the rows' mean count
    correlates with the analytic one (each frame's expected count at the light of its window's middle,
    1 + m·cos(2πf·t), averaged over the frames) at r ≥ 0.9 (was 0.08: no bands); the steady light's rows
    do not band (their spread is the Poisson noise's)."""
    shape, frames, exposure = (400, 32), 64, 2e-3
    flicker = {"flicker_hz": F_HZ, "flicker_depth": DEPTH}
    rolling = {**sensor, "jot_frames": frames, "shutter": "rolling", "row_time_s": ROW_S}
    scene = _scene(shape, exposure={"time_s": exposure}, sensor=rolling, light=flicker)
    capture = expose_photon_counting(_flat(0.05, shape), scene)
    h = capture.meta["mean_detections_per_frame"]  # the steady light's, from the camera equation
    assert 0.05 < h < 1.0
    frame_s = exposure / frames
    middles = np.arange(400)[None, :] * ROW_S + (np.arange(frames)[:, None] + 0.5) * frame_s  # (F, rows)
    light = h * (1 + DEPTH * np.cos(2 * math.pi * F_HZ * middles))
    if sensor["kind"] == "qis":
        analytic = (1 - np.exp(-light)).mean(axis=0)
    else:  # mostly one count a frame at this light: the dead time (a tenth of a µs) hardly matters
        analytic = light.mean(axis=0)
    profile = capture.counts.mean(axis=(0, 2))
    r = np.corrcoef(profile, analytic)[0, 1]
    print(f"{sensor['kind']}: row profile vs analytic r = {r:.3f}")
    assert r >= 0.9
    steady = expose_photon_counting(_flat(0.05, shape), _scene(shape, exposure={"time_s": exposure}, sensor=rolling))
    rows = steady.counts.mean(axis=(0, 2))
    assert rows.std() < 3 * math.sqrt(rows.mean() / (frames * shape[1]))


def _extrema_crossings(levels, threshold):
    """Events of the held-level rule from a waveform's successive extrema alone: from the held level, a
    rise to e fires floor((e − held)/C) ON events and the held level moves up by that many C (likewise
    down)."""
    held, count = levels[0], 0
    for e in levels[1:]:
        k = math.floor(abs(e - held) / threshold)
        count += k
        held += math.copysign(k * threshold, e - held)
    return count


@pytest.mark.parametrize("start_s", [0.0011, 0.0037])  # not at a peak: no tie of the held level with it
def test_an_event_pixel_fires_the_crossings_of_the_flickering_log_intensity(start_s):
    """A static scene (two equal frames 0.1 s apart) under 100 Hz at depth 0.9 (0.1–1.9×): each pixel fires
    the analytic number of crossings of ln(1 + 0.9·cos 2πf(t₀ + t)) by C = 0.2 (from the extrema: 10
    periods, ≈ 29 events a period), within 2 %; it fired 0 before."""
    shape, span, c = (4, 6), 0.1, 0.2
    scene = _scene(shape, exposure={"time_s": span, "start_s": start_s},
                   sensor={"kind": "event", "event_threshold": c, "event_threshold_sigma": 0.0,
                           "event_refractory_s": 0.0, "event_leak_hz": 0.0, "event_shot_noise_hz": 0.0},
                   light={"flicker_hz": F_HZ, "flicker_depth": 0.9})
    level = np.full(shape, math.log(1e5))
    stream = simulate_events([level, level], [0.0, span], scene)
    # the waveform's extrema over [t0, t0 + span]: its ends and every peak and trough between
    t = np.sort(np.concatenate([[start_s, start_s + span],
                                np.arange(0, 40) / (2 * F_HZ)]))
    t = t[(t >= start_s) & (t <= start_s + span)]
    levels = np.log(1 + 0.9 * np.cos(2 * math.pi * F_HZ * t))
    expected = _extrema_crossings(levels, c)
    per_pixel = np.bincount(stream.y.astype(int) * shape[1] + stream.x, minlength=shape[0] * shape[1])
    print(f"events a pixel {per_pixel.min()}..{per_pixel.max()}, analytic {expected}")
    assert expected > 250
    assert per_pixel.min() >= 0.98 * expected and per_pixel.max() <= 1.02 * expected
    on = (stream.p > 0).sum() / per_pixel.sum()
    assert on == pytest.approx(0.5, abs=0.02)  # as many up as down over whole periods


METERED = [({"kind": "qis"}, 1), ({"kind": "qis", "jot_bits": 4}, 15),
           ({"kind": "spad", "jot_bits": 4, "dead_time_s": 1.0}, 1)]  # τ far beyond any frame: 1 count at most


@pytest.mark.parametrize(("sensor", "saturation"), METERED)
@pytest.mark.parametrize("metering", ["average", "etr"])
def test_the_single_photon_meter_puts_its_reference_below_the_counts_saturation(sensor, saturation, metering):
    """A metered flat field's mean count is the meter's share of the analytic saturation count
    (min(2^b − 1, ⌈t_f/τ⌉): 1 for one bit, 15 for four, 1 for a 4-bit SPAD whose dead time exceeds the
    frame): ISO 12232's 10/78 for ``average``, ``auto_fraction`` 0.8 for ``etr``, within 3 % (it was
    metered for 0.8·15 = 12 and 1.6 detections: every frame of the white read its saturation)."""
    from spectral_cam.metering import GREY_RAW

    shape = (32, 32)
    scene = _scene(shape, exposure={"time_s": "auto", "metering": metering}, sensor={**sensor, "jot_frames": 256})
    capture = expose_photon_counting(_flat(0.05, shape), scene)
    assert capture.meta["saturation_count"] == saturation
    share = 0.8 if metering == "etr" else GREY_RAW
    assert capture.counts.mean() == pytest.approx(share * saturation, rel=0.03)
    assert capture.counts.max() <= saturation
    # the reconstruction's white: the estimate of a count half a frame short of saturating every frame;
    # for n_sat = 1 that is 1 − e^(−H) = 1 − 0.5/F, H = ln(2F)
    if saturation == 1:
        top = capture.to_raw().meta["detections_per_frame_at_white"]
        assert top == pytest.approx(math.log(2 * capture.frames), rel=1e-3)


@pytest.mark.parametrize(("sensor", "saturation"), METERED)
def test_a_white_patch_does_not_saturate_a_metered_single_photon_sensor(sensor, saturation):
    """A frame of 18 % grey with a white patch (0.9) on a tenth of it, metered ``average``: no white jot
    reads its saturation count in every frame (69–83 % did), and the white's mean count stays below
    0.8 of the saturation."""
    shape = (40, 40)
    data = np.full((*shape, 1), 0.18 * 0.2, np.float32)
    data[:, :4] = 0.9 * 0.2
    scene = _scene(shape, exposure={"time_s": "auto"}, sensor={**sensor, "jot_frames": 256})
    capture = expose_photon_counting(SpectralImage(data, (550.0,), (545.0, 555.0)), scene)
    white = capture.counts[:, :, :4]
    assert not np.any(np.all(white == saturation, axis=0))
    assert white.mean() < 0.8 * saturation
