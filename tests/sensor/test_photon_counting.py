"""Issue 30 #1: single-photon sensors. Binary frames' mean and variance equal 1 − e^(−H) and its
Bernoulli variance for the H of the camera equation (an independent integral) within 1 %; the
maximum-likelihood reconstruction is unbiased within its predicted standard error; the dark bit rate
equals DCR·t_f within 2 %; a SPAD's dead time and afterpulsing follow the counting statistics; the
reconstruction develops through the ISP; bad settings are refused."""

from __future__ import annotations

import math

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.errors import ConfigError
from spectral_cam.image import SpectralImage
from spectral_cam.sensor.photon_counting import expected_count, expose_photon_counting

pytestmark = pytest.mark.timeout(120)

PLANCK, LIGHT = 6.62607015e-34, 299792458.0


def _flat(radiance_w, *, frames=400, shape=(48, 48), exposure_s=4e-3, **sensor):
    """A monochrome flat field of band radiance ``radiance_w`` (W·m⁻²·sr⁻¹ in the 10-nm band at 550 nm)."""
    data = np.full((*shape, 1), radiance_w, np.float32)
    radiance = SpectralImage(data, (550.0,), (545.0, 555.0))
    scene = sc.scene_from_dict({"sensor": {"width_px": shape[1], "height_px": shape[0], "model": "ideal", "cfa": "none",
                                           "kind": "qis", "jot_frames": frames, "vignetting": False,
                                           "pixel_pitch_um": 1.1, "dark_current_e_per_s": 0.0, **sensor},
                                "lens": {"f_number": 2.0, "focal_length_mm": 50.0, "focus_distance_m": 1e6},
                                "exposure": {"time_s": exposure_s}})
    return scene, expose_photon_counting(radiance, scene)


def _camera_equation_h(scene, radiance_w, frame_s) -> float:
    """Detections per frame, written out: π·L·/(1 + 4N²) · A · t · λ/(h·c) · η — the ideal sensor's
    flat η = peak_qe·(λ/λ_max)… read from its own definition: QE ∝ λ (flat per photon), peak_qe at the
    grid's longest wavelength; here one band, so η(550) = peak_qe·550/700 (the default grid ends at 700)."""
    n = scene.lens.f_number  # at infinity the working f-number is N
    irradiance = math.pi * radiance_w / (1 + 4 * n * n)
    photons = irradiance * (scene.sensor.pixel_pitch_um * 1e-6) ** 2 * frame_s * 550e-9 / (PLANCK * LIGHT)
    return photons * scene.sensor.peak_qe


def test_binary_frames_follow_one_minus_exp_minus_h_with_bernoulli_variance():
    """H from the test's own camera-equation integral (checked against the record's mean within 1 %);
    the frames' mean 1 − e^(−H) within 1 % and their per-jot variance p(1 − p) within 3 %."""
    radiance = 0.3
    scene, capture = _flat(radiance)
    h = capture.meta["mean_detections_per_frame"]
    from spectral_cam.sensor.radiometry import quantum_efficiency

    eta = float(quantum_efficiency("ideal", np.array([550.0]), peak_qe=scene.sensor.peak_qe, monochrome=True)[0, 0])
    expected_h = _camera_equation_h(scene, radiance, capture.frame_s) * eta / scene.sensor.peak_qe
    assert h == pytest.approx(expected_h, rel=0.01)
    assert 0.2 < h < 3  # a regime where the binary response bends
    p = 1 - math.exp(-h)
    bits = capture.counts.astype(float)
    assert bits.mean() == pytest.approx(p, rel=0.01)
    assert bits.var(axis=0).mean() == pytest.approx(p * (1 - p), rel=0.03)


@pytest.mark.parametrize("radiance", [0.1, 0.3, 0.8])
def test_the_maximum_likelihood_reconstruction_is_unbiased_within_its_standard_error(radiance):
    """Over 2 304 jots of 400 frames: the bias of −ln(1 − S/F) is under a quarter of its per-jot
    standard error √((e^H − 1)/F) (unbiased within it), and is the delta method's second-order
    (e^H − 1)/(2F) — the convex logarithm's, 0.024 at H = 3 — within 3 standard errors of the mean over
    the jots; the per-jot scatter matches the predicted error within 10 %."""
    scene, capture = _flat(radiance)
    h = capture.meta["mean_detections_per_frame"]
    estimate = capture.reconstruct()
    per_jot = math.sqrt(math.expm1(h) / capture.frames)
    bias = estimate.mean() - h
    assert abs(bias) < 0.25 * per_jot
    assert bias == pytest.approx(math.expm1(h) / (2 * capture.frames), abs=3 * per_jot / math.sqrt(estimate.size))
    assert estimate.std() == pytest.approx(per_jot, rel=0.10)
    assert capture.standard_error().mean() == pytest.approx(per_jot, rel=0.10)


def test_the_dark_bit_rate_is_the_dark_count_rate_times_the_frame_time():
    """No light, DCR 50 Hz, 4 ms over 400 frames (10 µs each): bits at 1 − e^(−DCR·t) ≈ DCR·t within 2 %;
    the reconstruction takes the dark counts off (mean within its standard error of 0)."""
    scene, capture = _flat(0.0, dark_current_e_per_s=50.0, shape=(96, 96), frames=2000, exposure_s=0.2)
    expected = 1 - math.exp(-50.0 * capture.frame_s)
    assert capture.counts.mean() == pytest.approx(expected, rel=0.02)
    error = math.sqrt(math.expm1(50.0 * capture.frame_s) / capture.frames) / math.sqrt(96 * 96)
    assert abs(capture.reconstruct().mean()) < 4 * error


def test_a_spads_dead_time_and_afterpulsing_follow_the_counting_statistics():
    """4-bit SPAD frames with a dead time of a tenth of the frame: the mean count equals
    Σ_n P(Γ(n, λ) ≤ t − (n − 1)τ) (scipy's incomplete gamma) within 1 %, below the Poisson mean;
    afterpulsing at 0.1 raises it by about a tenth."""
    base = dict(kind="spad", jot_bits=4, dead_time_s=1e-6)
    scene, capture = _flat(2.2, frames=400, exposure_s=4e-3, **base)
    h = capture.meta["mean_detections_per_frame"]
    mean = capture.counts.mean()
    assert mean == pytest.approx(float(expected_count(h, bits=4, frame_s=capture.frame_s, dead_time_s=1e-6)),
                                 rel=0.01)
    assert mean < 0.9 * min(h, 15)
    assert capture.reconstruct().mean() == pytest.approx(h, rel=0.02)
    _, after = _flat(2.2, frames=400, exposure_s=4e-3, afterpulsing=0.1, **base)
    assert after.counts.mean() / mean == pytest.approx(1.1, abs=0.03)


def test_a_colour_qis_capture_develops_through_the_isp_and_saves_its_bits(tmp_path):
    """An RGGB QIS of a grey D65 field: the reconstruction as a RawImage develops to a neutral grey
    (channel ratios within 5 %); the NPZ holds the packed bits, which unpack to the frames."""
    import json

    from spectral_cam.isp import ISPConfig, develop
    from spectral_cam.radiance_targets import lambertian_radiance, uniform_image

    radiance = uniform_image(lambertian_radiance("D65", [0.5], illuminance_lux=500.0)[0], (32, 32))
    scene = sc.scene_from_dict({"sensor": {"width_px": 32, "height_px": 32, "kind": "qis", "jot_frames": 512,
                                           "vignetting": False, "pixel_pitch_um": 1.1},
                                "illuminant": {"spd": "D65"}, "exposure": {"time_s": 0.01}})
    capture = expose_photon_counting(radiance, scene)
    rgb = develop(capture.to_raw(), ISPConfig(tone="linear", demosaic="bilinear")).linear.reshape(-1, 3).mean(axis=0)
    assert rgb[0] / rgb[1] == pytest.approx(1.0, abs=0.05) and rgb[2] / rgb[1] == pytest.approx(1.0, abs=0.05)
    path = capture.save(tmp_path / "qis.npz")
    with np.load(path) as npz:
        meta = json.loads(str(npz["meta"]))
        frames = np.unpackbits(npz["bits"], axis=-1, count=meta["shape"][1])
    assert np.array_equal(frames, capture.counts) and meta["frames"] == 512


@pytest.mark.parametrize(("key", "bad"), [("kind", "ccd"), ("jot_frames", 0), ("jot_bits", 9),
                                          ("dead_time_s", -1), ("afterpulsing", 2)])
def test_bad_single_photon_settings_are_refused_with_what_would_be_valid(key, bad):
    with pytest.raises(ConfigError, match=f"sensor.{key}"):
        sc.scene_from_dict({"sensor": {"kind": "spad", key: bad}})


def test_a_render_job_with_a_qis_writes_its_frames_and_develops_their_reconstruction(make_scene, tmp_path):
    """sensor.kind = "qis" through the job: photon_counts.npz beside raw.dng (the reconstruction) and the
    image; auto exposure puts the white at 1 − e^(−H) = 0.8 of a frame (H = 1.6), the bits' mean below."""
    import json

    from spectral_cam.job import render_job_files, simulate, write_files

    config = make_scene(scene={"preset": "colorchecker"}, sensor={"width_px": 96, "height_px": 64, "kind": "qis",
                                                                "jot_frames": 128},
                        render={"spp": 16, "bands": "camera", "spectral_output": False, "diffraction": "off"})
    sim = simulate(config, with_depth=False)
    names = [n for n in render_job_files(config) if n != "depth"]
    written = {p.name for p in write_files(sim, tmp_path, names)}
    assert {"photon_counts.npz", "raw.dng", "image.png"} <= written
    with np.load(tmp_path / "photon_counts.npz") as npz:
        meta = json.loads(str(npz["meta"]))
    assert meta["kind"] == "qis" and meta["frames"] == 128
    assert 0.05 < sim.photon_counts.counts.mean() < 0.8
    assert sim.developed.image.shape == (64, 96, 3)


@pytest.mark.parametrize(("kind", "names"), [("qis", "expose_photon_counting"), ("event", "simulate_events")])
def test_expose_refuses_a_non_integrating_sensor_and_names_the_way(kind, names):
    from spectral_cam.errors import SensorError
    from spectral_cam.radiance_targets import narrow_band_flat

    scene = sc.scene_from_dict({"sensor": {"width_px": 8, "height_px": 8, "kind": kind, "crop_margin_px": 0}})
    with pytest.raises(SensorError, match=names):
        sc.expose(narrow_band_flat((8, 8), 0.05), scene)
