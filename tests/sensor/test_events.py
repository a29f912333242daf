"""Issue 30 #2: event sensors. Noise-free: a step of Δ in log intensity makes floor(Δ/C) events per pixel
of the step's polarity; a moving edge's events cross each column at x/v within 2 % of the frame
interval; the refractory period holds everywhere; shot noise and leak come at their rates; the NPZ is
DSEC's layout."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.errors import ConfigError, SensorError
from spectral_cam.sensor.events import simulate_events

pytestmark = pytest.mark.timeout(120)

CLEAN = {"event_threshold_sigma": 0.0, "event_refractory_s": 0.0, "event_leak_hz": 0.0, "event_shot_noise_hz": 0.0}


def _config(**sensor):
    return sc.scene_from_dict({"sensor": {"kind": "event", "width_px": 16, "height_px": 8, **CLEAN, **sensor}})


@pytest.mark.parametrize("delta", [0.5, 1.03, -0.71, 2.0])
def test_a_log_step_makes_floor_delta_over_c_events(delta):
    """C = 0.2: Δ = 0.5 → 2 ON events a pixel, 1.03 → 5, −0.71 → 3 OFF, 2.0 → 10 (floor(|Δ|/C), to the
    float's rounding), their times spread linearly over the step's interval at k·C/|Δ|."""
    config = _config(event_threshold=0.2)
    base = np.zeros((8, 16))
    events = simulate_events([base, base + delta], [0.0, 1e-3], config)
    per_pixel = math.floor(abs(delta) / 0.2 + 1e-9)
    assert len(events) == per_pixel * base.size
    assert set(np.unique(events.p)) == {int(np.sign(delta))}
    pixel = (events.x == 3) & (events.y == 2)
    np.testing.assert_allclose(np.sort(events.t[pixel]), [k * 0.2 / abs(delta) * 1e-3 for k in range(1, per_pixel + 1)],
                               rtol=1e-9)


def test_a_moving_edge_fires_each_column_when_it_passes():
    """An edge of log contrast 1.1, one pixel wide, moving right at 2 000 px/s over 20 frames 0.5 ms apart:
    every pixel of columns 2–14 fires floor(1.1/0.2) = 5 ON events, the k-th when the edge has moved
    k·0.2/1.1 of a pixel into it, t = (c − 1 + 0.2k/1.1)/v, within 2 % of the frame interval (the
    known speed, from the events' timing)."""
    speed, frames, interval = 2000.0, 20, 0.5e-3
    columns = np.arange(16) + 0.5
    times = np.arange(frames) * interval
    logs = [np.broadcast_to(1.1 * np.clip(speed * t - columns + 1.5, 0.0, 1.0), (8, 16)) for t in times]
    events = simulate_events(logs, times, _config(event_threshold=0.2))
    for column in range(2, 15):
        selected = (events.x == column) & (events.y == 4)
        assert selected.sum() == 5 and np.all(events.p[selected] == 1)
        expected = (column - 1 + 0.2 * np.arange(1, 6) / 1.1) / speed
        np.testing.assert_allclose(np.sort(events.t[selected]), expected, atol=0.02 * interval)
    fitted = np.polyfit(events.t, events.x.astype(float), 1)[0]
    assert fitted == pytest.approx(speed, rel=0.02)  # the speed, back from the events


def test_the_refractory_period_holds_everywhere_and_defers_rather_than_drops():
    """A fast ramp (10 crossings in 1 ms) with a 0.25 ms refractory period: no two events of a pixel
    closer than 0.25 ms; the level is caught up after each wait (4 events a pixel, not 10, then none lost
    at the end beyond the last period's change)."""
    config = _config(event_threshold=0.2, event_refractory_s=2.5e-4)
    base = np.zeros((8, 16))
    events = simulate_events([base, base + 2.0], [0.0, 1e-3], config)
    for y, x in ((0, 0), (3, 7)):
        t = np.sort(events.t[(events.x == x) & (events.y == y)])
        assert np.all(np.diff(t) >= 2.5e-4 - 1e-12)
        assert len(t) == 4  # at 0.1, 0.35, 0.6, 0.85 ms


def test_shot_noise_and_leak_come_at_their_rates():
    """A static scene for 2 s: shot noise at 5 Hz gives 5 ± 4σ events per pixel-second, half each way; a
    leak of 0.5 Hz gives ON events at 0.5 Hz per pixel (the held level drifts C in 2 s)."""
    base = np.zeros((8, 16))
    noisy = simulate_events([base, base], [0.0, 2.0], _config(event_shot_noise_hz=5.0))
    expected = 5.0 * 2.0 * base.size
    assert abs(len(noisy) - expected) < 4 * math.sqrt(expected)
    assert abs(np.mean(noisy.p > 0) - 0.5) < 0.1
    leaky = simulate_events([base, base, base], [0.0, 1.0, 2.0], _config(event_leak_hz=0.5))
    assert len(leaky) == base.size and np.all(leaky.p == 1)
    np.testing.assert_allclose(leaky.t, 2.0, rtol=1e-9)


def test_events_save_in_dsec_layout_and_draw_an_event_frame(tmp_path):
    base = np.zeros((8, 16))
    events = simulate_events([base, base + 0.5], [0.0, 1e-3], _config())
    path = events.save(tmp_path / "events.npz")
    with np.load(path) as npz:
        assert npz["t"].dtype == np.int64 and set(np.unique(npz["p"])) == {1}
        assert json.loads(str(npz["meta"]))["shape"] == [8, 16]
        assert len(npz["x"]) == len(events)
    assert events.frame().sum() == len(events) and events.frame_rgb().shape == (8, 16, 3)


def test_bad_event_settings_are_refused():
    with pytest.raises(ConfigError, match="sensor.event_threshold"):
        sc.scene_from_dict({"sensor": {"kind": "event", "event_threshold": 0}})
    with pytest.raises(SensorError, match="at least two frames"):
        simulate_events([np.zeros((2, 2))], [0.0], _config())


def test_a_render_job_with_an_event_sensor_follows_a_panned_edge(make_scene, tmp_path):
    """sensor.kind = "event" through the job: 16 renders over 10 ms of a camera panning at 1 m/s past the
    slanted edge 2 m away; in every row the OFF events' columns against their times give the edge's image
    speed v·(v_img/p)/z within 2 %; events.npz, events.png and the APS frame (raw.dng, image.png) are
    written."""
    from spectral_cam.job import render_job_files, simulate, write_files

    config = make_scene(scene={"preset": "slanted_edge", "distance_m": 2.0},
                        sensor={"width_px": 96, "height_px": 64, "kind": "event", "event_frames": 16,
                                "event_leak_hz": 0.0, "event_refractory_s": 0.0},
                        lens={"model": "pinhole"}, exposure={"time_s": 0.01},
                        motion={"camera_velocity_mps": [1.0, 0.0, 0.0]},
                        render={"spp": 32, "bands": "camera", "spectral_output": False, "diffraction": "off"})
    sim = simulate(config, with_depth=False)
    events = sim.events
    expected = 1.0 / 2.0 * sim.lens.image_distance_m / sim.lens.pixel_pitch_m
    speeds = []
    for row in range(4, 60, 4):
        chosen = (events.y == row) & (events.p < 0)
        if chosen.sum() > 10:
            speeds.append(abs(np.polyfit(events.t[chosen], events.x[chosen].astype(float), 1)[0]))
    assert len(speeds) >= 10 and np.median(speeds) == pytest.approx(expected, rel=0.02), (np.median(speeds), expected)
    written = {p.name for p in write_files(sim, tmp_path, [n for n in render_job_files(config) if n != "depth"])}
    assert {"events.npz", "events.png", "raw.dng", "image.png"} <= written
