"""Issue 39 #25: a single-photon sensor's count frames and an event sensor's events are in the memory
estimate, and a capture whose outputs would not fit is refused before anything renders, with the size
that fits (63 GiB of QIS frames and 572 GiB of events were asked while the dry run said 0.77/0.18 GB)."""

from __future__ import annotations

import math
import tracemalloc

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.errors import ConfigError
from spectral_cam.render import memory

pytestmark = pytest.mark.timeout(120)


def _no_render(monkeypatch):
    """Any depth probe or radiance render fails the test: the refusal must come first."""
    import importlib

    def rendered(*args, **kwargs):
        raise AssertionError("rendered before the memory refusal")

    monkeypatch.setattr(importlib.import_module("spectral_cam.render.depth"), "render_depth", rendered)
    package = importlib.import_module("spectral_cam.render")
    monkeypatch.setattr(package, "trace", rendered)  # execute() traces through this name


def test_the_estimate_holds_a_qis_captures_count_frames_byte_for_byte():
    """65 536 one-bit frames at 1 MP: the frames alone are F·P bytes (uint8) plus F·P/8 packed for the NPZ
    = 73.7 GB; the estimate counts them and the per-pixel rest within 1 % of that analytic count (it
    said 0.77 GB)."""
    config = sc.scene_from_dict({"sensor": {"kind": "qis", "jot_frames": 65536, "width_px": 1000, "height_px": 1000}})
    frames_bytes = 65536 * 1e6 * (1 + 1 / 8)
    estimate = memory.estimate_render_bytes(1000, 1000, 31, sensor_bytes=memory.sensor_bytes_per_pixel(config))
    assert frames_bytes < estimate < 1.01 * frames_bytes + memory.estimate_render_bytes(1000, 1000, 31)
    four = config.replace(**{"sensor.jot_bits": 4})
    assert memory.sensor_bytes_per_pixel(four) == pytest.approx(65536 + memory.PHOTON_COUNTING_BYTES_PER_PIXEL)


@pytest.mark.parametrize("sensor", [{"kind": "qis"}, {"kind": "spad", "jot_bits": 4, "dead_time_s": 1e-7}])
def test_a_small_captures_traced_peak_stays_under_its_estimate(sensor):
    """Measured by tracemalloc (NumPy's allocations) over expose, reconstruction and NPZ: 96 × 96 jots × 256
    frames stay under the sensor's share of the estimate and above the frames' own F·P bytes."""
    import tempfile
    from pathlib import Path

    from spectral_cam.image import SpectralImage
    from spectral_cam.sensor.photon_counting import expose_photon_counting

    shape, frames = (96, 96), 256
    config = sc.scene_from_dict({"sensor": {"width_px": 96, "height_px": 96, "model": "ideal", "cfa": "none",
                                            "crop_margin_px": 0, "jot_frames": frames, **sensor},
                                 "exposure": {"time_s": 1e-3}})
    radiance = SpectralImage(np.full((*shape, 1), 0.05, np.float32), (550.0,), (545.0, 555.0))
    import scipy.special  # noqa: F401  (imported first: its own import is not the capture's)

    tracemalloc.start()
    try:
        capture = expose_photon_counting(radiance, config)
        capture.to_raw()
        with tempfile.TemporaryDirectory() as folder:
            capture.save(Path(folder) / "counts.npz")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    pixels = shape[0] * shape[1]
    print(f"{sensor['kind']}: peak {peak / pixels:.0f} B a jot, estimate {memory.sensor_bytes_per_pixel(config):.0f}")
    assert frames * pixels < peak < memory.sensor_bytes_per_pixel(config) * pixels + memory.NPZ_CHUNK_BYTES


def test_the_event_estimate_is_rate_times_time_times_pixels():
    """10⁴ s with 10⁴ Hz shot noise and a 10 Hz leak: the expected events a pixel are (shot + leak)·T
    (analytic), the upper bound 5 σ above; a 100 Hz flicker at depth 0.9 adds 2⌈ln(1.9/0.1)/C⌉ = 30 a
    period; the refractory period caps the leak and flicker at T/t_ref + 1."""
    config = sc.scene_from_dict({"sensor": {"kind": "event", "event_shot_noise_hz": 1e4, "event_leak_hz": 10.0,
                                            "event_threshold_sigma": 0.0},
                                 "exposure": {"time_s": 1e4}})
    mean = (1e4 + 10.0) * 1e4
    assert memory.expected_events_per_pixel(config, upper=False) == pytest.approx(mean)
    assert memory.expected_events_per_pixel(config) == pytest.approx(mean + 5 * math.sqrt(mean))
    flicker = config.replace(**{"illuminant.flicker_hz": 100.0, "illuminant.flicker_depth": 0.9,
                                "sensor.event_shot_noise_hz": 0.0, "sensor.event_leak_hz": 0.0,
                                "sensor.event_refractory_s": 0.0})
    assert memory.expected_events_per_pixel(flicker, 1.0, upper=False) == pytest.approx(
        2 * math.ceil(math.log(1.9 / 0.1) / 0.2) * 100)
    capped = config.replace(**{"sensor.event_leak_hz": 1e4, "sensor.event_shot_noise_hz": 0.0,
                               "sensor.event_refractory_s": 1e-3})
    assert memory.expected_events_per_pixel(capped, upper=False) == pytest.approx(1e4 / 1e-3 + 1)
    per_pixel = memory.sensor_bytes_per_pixel(config)
    assert per_pixel > mean * memory.BYTES_PER_EVENT


def test_a_measured_event_stream_stays_under_its_estimate():
    """2·10⁶ shot-noise events over 50 × 40 pixels: NumPy's traced peak while they are made stays under
    the estimate (expected events × BYTES_PER_EVENT) and above 13 B an event (the stream's own arrays)."""
    from spectral_cam.sensor.events import expected_event_count, simulate_events

    config = sc.scene_from_dict({"sensor": {"kind": "event", "event_shot_noise_hz": 100.0, "event_leak_hz": 0.0,
                                            "width_px": 50, "height_px": 40}, "exposure": {"time_s": 10.0}})
    level = np.zeros((40, 50))
    tracemalloc.start()
    try:
        stream = simulate_events([level, level], [0.0, 10.0], config)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    estimate = expected_event_count([level, level], [0.0, 10.0], config) * memory.BYTES_PER_EVENT
    assert 13 * len(stream) < peak < estimate


def test_a_qis_capture_beyond_memory_is_refused_before_anything_renders(monkeypatch):
    """sensor.kind = qis, 65 536 frames at 1 MP on a 16 GB machine: refused by the plan before the depth
    probe or any radiance, naming the count frames and the jot_frames that fits (which then passes)."""
    from spectral_cam.render.plan import make_plan

    monkeypatch.setattr(memory, "available_bytes", lambda: 16e9)
    _no_render(monkeypatch)
    config = sc.scene_from_dict({"sensor": {"kind": "qis", "jot_frames": 65536, "width_px": 1000, "height_px": 1000}})
    with pytest.raises(ConfigError, match=r"count frames.*sensor\.jot_frames = (\d+) fits") as refused:
        make_plan(config, with_depth=False)
    import re

    frames = int(re.search(r"jot_frames = (\d+) fits", str(refused.value)).group(1))
    assert 1000 < frames < 65536
    capture = (1000 + 2 * config.sensor.crop_margin_px, 1000 + 2 * config.sensor.crop_margin_px)
    memory.check_render_memory(*capture, config=config.replace(**{"sensor.jot_frames": frames}))
    with pytest.raises(ConfigError):
        memory.check_render_memory(*capture, config=config.replace(**{"sensor.jot_frames": int(frames * 1.05)}))


def test_an_event_capture_beyond_memory_is_refused_before_anything_renders(monkeypatch):
    """exposure.time_s = 10⁴ s with 10⁴ Hz shot noise on 64 × 48 pixels: 3·10¹² events, refused before the
    first frame renders, with the span that fits; the same with a 10⁴ Hz leak (it grew until the machine
    ran out)."""
    from spectral_cam.job import simulate

    monkeypatch.setattr(memory, "available_bytes", lambda: 16e9)
    _no_render(monkeypatch)
    for noise in ({"event_shot_noise_hz": 1e4}, {"event_leak_hz": 1e4}):
        config = sc.scene_from_dict({"sensor": {"kind": "event", "width_px": 64, "height_px": 48, **noise},
                                     "exposure": {"time_s": 1e4}})
        with pytest.raises(ConfigError, match=r"events.*exposure\.time_s = [\d.e+-]+ s fits"):
            simulate(config, with_depth=False)


def test_the_event_model_refuses_frames_whose_motion_would_not_fit(monkeypatch):
    """The rendered frames' own changes (here a log step of 1000 over 100 × 100 pixels, 5·10⁷ events at
    C = 0.02) are counted before any event is made."""
    from spectral_cam.sensor.events import simulate_events

    from spectral_cam import machine

    monkeypatch.setattr(machine, "available_bytes", lambda: 1e9)
    config = sc.scene_from_dict({"sensor": {"kind": "event", "event_threshold": 0.02, "event_threshold_sigma": 0.0,
                                            "event_refractory_s": 0.0}})
    with pytest.raises(ConfigError, match="events"):
        simulate_events([np.zeros((100, 100)), np.full((100, 100), 1000.0)], [0.0, 1.0], config)
