"""Sensor physics against independent references: √n, the camera equation by hand (scipy
constants), cos⁴θ, auto exposure, gain and the noise profile, switches and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.constants as const

from spectral_cam import sensor as S
from spectral_cam import spectra
from spectral_cam.errors import ConfigError, SensorError
from spectral_cam.image import SpectralImage
from spectral_cam.scene import scene_from_dict

WAVELENGTHS = np.arange(400.0, 701.0, 10.0)
EDGES = np.append(WAVELENGTHS - 5.0, WAVELENGTHS[-1] + 5.0)
F_MM, N, Z_M = 8.0, 2.8, 2.0  # scene.py defaults: focal length, f-number, focus distance
QUIET = {"read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0}


def working_f_number(n=N, f_mm=F_MM, z_m=Z_M):
    f = f_mm * 1e-3
    return n * (1.0 + f / (z_m - f))  # N·(1 + m), m = f/(z − f)


def image(size, spectrum):
    height, width = size
    data = np.broadcast_to(np.asarray(spectrum, dtype=np.float32), (height, width, len(WAVELENGTHS))).copy()
    return SpectralImage(data, WAVELENGTHS.copy(), EDGES.copy())


def narrow_band(size, radiance, wavelength_nm=550.0):
    spectrum = np.zeros(len(WAVELENGTHS))
    spectrum[int(np.argmin(abs(WAVELENGTHS - wavelength_nm)))] = radiance
    return image(size, spectrum)


def photons_per_second(band_radiance, wavelength_nm, pitch_um, n_w):
    """μ_p / t by hand: E = π·L/(1 + 4·N_w²), photons = E·A·λ/(h·c)."""
    irradiance = math.pi * band_radiance / (1.0 + 4.0 * n_w ** 2)
    return irradiance * (pitch_um * 1e-6) ** 2 * wavelength_nm * 1e-9 / (const.h * const.c)


def config(sensor=None, exposure=None, **sections):
    data = {"sensor": {"width_px": 64, "height_px": 64, **(sensor or {})},
            "exposure": {"time_s": 0.01, **(exposure or {})}}
    data.update(sections)
    return scene_from_dict(data)


# ----------------------------------------------------------------------------- √n law
SQRT_N_SENSOR = {"model": "ideal", "cfa": "none", "peak_qe": 1.0, "width_px": 256, "height_px": 256,
                 "bit_depth": 16, "black_level_dn": 0, "full_well_e": 65535.0, "vignetting": False, **QUIET}


@pytest.mark.parametrize("method", S.SHOT_NOISE_METHODS)
@pytest.mark.parametrize("photons", [10, 100, 1000, 10000])
def test_sqrt_n_law(photons, method):
    rate = photons_per_second(1.0, 550.0, 6.0, working_f_number())
    cfg = config(SQRT_N_SENSOR, {"time_s": photons / rate})
    raw = S.expose(narrow_band((256, 256), 1.0), cfg, frame_seed=photons, shot_noise_method=method)
    assert raw.meta["K_dn_per_e"] == 1.0  # (2^16 − 1 − 0) / 65535
    values = raw.mosaic.astype(float)
    snr = values.mean() / values.std()
    assert snr == pytest.approx(math.sqrt(photons), rel=0.02)
    assert values.mean() == pytest.approx(photons, rel=0.01)


@pytest.mark.parametrize("method", S.SHOT_NOISE_METHODS)
def test_mean_unbiased_below_one_photon(method):
    photons = 0.3
    rate = photons_per_second(1.0, 550.0, 6.0, working_f_number())
    cfg = config(SQRT_N_SENSOR, {"time_s": photons / rate})
    raw = S.expose(narrow_band((256, 256), 1.0), cfg, frame_seed=3, shot_noise_method=method)
    values = raw.mosaic.astype(float)
    standard_error = math.sqrt(photons / values.size)
    assert abs(values.mean() - photons) < 4 * standard_error
    assert values.var() == pytest.approx(photons, rel=0.05)  # Poisson: variance = mean


# ----------------------------------------------------------------------------- camera equation
def hand_qe(model, wavelengths_nm, peak_qe):
    """η_c(λ) ∝ S_c(λ)/λ with max over channels = peak_qe, written out independently."""
    msds = spectra.camera_sensitivities(model)
    wl = np.asarray(msds.wavelengths, dtype=float)
    per_photon = np.asarray(msds.values, dtype=float) / wl[:, None]
    per_photon = per_photon / per_photon.max() * peak_qe
    return np.stack([np.interp(wavelengths_nm, wl, per_photon[:, c], left=0, right=0) for c in range(3)], -1)


def test_camera_equation_hand_computation():
    model, pitch_um, t, peak_qe, lens_t, dark = "nikon_d850", 4.0, 0.02, 0.55, 0.9, 30.0
    wl, irradiance = spectra.absolute_irradiance("D65", 800.0)
    radiance = spectra.band_integrals(0.4 * irradiance / np.pi, wl, spectra.parse_bands("400:700:10"))
    cfg = config({"model": model, "cfa": "RGGB", "pixel_pitch_um": pitch_um, "peak_qe": peak_qe,
                  "vignetting": False, "read_noise_e": 2.0, "dark_current_e_per_s": dark,
                  "dsnu_e": 1.0, "prnu": 0.01, "bit_depth": 14, "full_well_e": 40000.0, "base_iso": 100.0},
                 {"time_s": t}, lens={"transmission": lens_t})
    raw = S.expose(image((64, 64), radiance), cfg, frame_seed=11)

    n_w = working_f_number()
    eta = hand_qe(model, WAVELENGTHS, peak_qe)
    expected = np.zeros(3)
    for b, lam in enumerate(WAVELENGTHS):
        e_b = math.pi * radiance[b] * lens_t / (1 + 4 * n_w ** 2)  # W·m⁻²
        photons = e_b * (pitch_um * 1e-6) ** 2 * t * lam * 1e-9 / (const.h * const.c)
        expected += photons * eta[b]
    expected += dark * t
    k = (2 ** 14 - 1 - 256) / 40000.0
    electrons = (raw.mosaic.astype(float) - 256) / k
    measured = [electrons[0::2, 0::2].mean(),
                np.concatenate([electrons[0::2, 1::2].ravel(), electrons[1::2, 0::2].ravel()]).mean(),
                electrons[1::2, 1::2].mean()]
    assert expected.min() > 2000  # a meaningful signal in every channel
    np.testing.assert_allclose(measured, expected, rtol=0.005)


def test_vignetting_is_cos4():
    size, pitch_um = 64, 40.0
    cfg = config({"model": "ideal", "cfa": "none", "width_px": size, "height_px": size, "pixel_pitch_um": pitch_um,
                  "shot_noise": False, "bit_depth": 16, "full_well_e": 1e6, **QUIET}, {"time_s": 1.0})
    rate = photons_per_second(1.0, 550.0, pitch_um, working_f_number())
    radiance = 5e5 / (rate * 0.6)  # 5·10⁵ electrons on axis
    raw = S.expose(narrow_band((size, size), radiance), cfg)
    k = (2 ** 16 - 1 - 256) / 1e6
    electrons = (raw.mosaic.astype(float) - 256) / k
    f = F_MM * 1e-3
    v = f * Z_M / (Z_M - f)  # image distance
    x = (np.arange(size) + 0.5 - size / 2) * pitch_um * 1e-6
    r2 = x[None, :] ** 2 + x[:, None] ** 2
    cos4 = (v / np.sqrt(r2 + v * v)) ** 4
    on_axis = rate * 0.6 * radiance
    np.testing.assert_allclose(electrons, on_axis * cos4, rtol=2e-4, atol=1 / k)
    assert cos4.min() < 0.95  # the corners are measurably darker


# ----------------------------------------------------------------------------- exposure, gain
def test_auto_exposure_puts_brightest_channel_at_fraction_of_saturation():
    cfg = config({"model": "sony_ilce_7m3", "cfa": "GRBG", "vignetting": False, **QUIET},
                 {"time_s": "auto", "auto_fraction": 0.7, "metering": "etr"})
    wl, irradiance = spectra.absolute_irradiance("A", 300.0)
    radiance = spectra.band_integrals(0.9 * irradiance / np.pi, wl, spectra.parse_bands("400:700:10"))
    raw = S.expose(image((64, 64), radiance), cfg)
    k, sat = raw.meta["K_dn_per_e"], raw.meta["saturation_e"]
    assert sat == pytest.approx(min(cfg.sensor.full_well_e, (2 ** cfg.sensor.bit_depth - 1 - 256) / k))
    electrons = (raw.mosaic.astype(float) - 256) / k
    channel_means = [electrons[0::2, 1::2].mean(), electrons[0::2, 0::2].mean(), electrons[1::2, 0::2].mean()]
    assert max(channel_means) == pytest.approx(0.7 * sat, rel=0.01)


def test_auto_exposure_white_mask():
    size = 64
    data = np.zeros((size, size, len(WAVELENGTHS)), np.float32)
    data[:, : size // 2, 15] = 10.0  # bright left half
    data[:, size // 2:, 15] = 1.0  # the "white patch" on the right
    cfg = config({"model": "ideal", "cfa": "none", "vignetting": False, **QUIET}, {"time_s": "auto", "metering": "etr"})
    mask = np.zeros((size, size), bool)
    mask[:, size // 2:] = True
    raw = S.expose(SpectralImage(data, WAVELENGTHS, EDGES), cfg, white_mask=mask)
    electrons = (raw.mosaic.astype(float) - 256) / raw.meta["K_dn_per_e"]
    assert electrons[:, size // 2:].mean() == pytest.approx(0.8 * raw.meta["saturation_e"], rel=0.01)
    assert raw.meta["exposure_auto"] is True


@pytest.mark.parametrize("iso", [50.0, 100.0, 400.0])
def test_gain_saturation_and_noise_profile(iso):
    cfg = config({"bit_depth": 12, "black_level_dn": 200, "full_well_e": 15000.0, "base_iso": 100.0,
                  "read_noise_e": 3.0, "dark_current_e_per_s": 40.0}, {"time_s": 0.05, "iso": iso})
    raw = S.expose(image((64, 64), np.full(31, 0.01)), cfg)
    k = (4095 - 200) / 15000.0 * iso / 100.0
    assert raw.meta["K_dn_per_e"] == pytest.approx(k)
    assert raw.meta["saturation_e"] == pytest.approx(min(15000.0, (4095 - 200) / k))
    sigma_d = math.sqrt(3.0 ** 2 + 40.0 * 0.05)
    assert raw.meta["sigma_dark_e"] == pytest.approx(sigma_d)
    scale, offset = raw.noise_profile
    assert scale == pytest.approx(k / (4095 - 200))
    # x = (DN − B)/(W − B) keeps the dark signal, whose shot noise S·x counts: O is read noise only
    assert offset == pytest.approx((k * k * 3.0 ** 2 + 1 / 12) / (4095 - 200) ** 2)
    assert raw.white_level == 4095 and raw.black_level == 200
    for key in ("exposure_s", "iso", "seeds", "timings_s", "peak_qe"):
        assert key in raw.meta


def test_noise_off_is_deterministic_and_exact():
    cfg = config({"model": "ideal", "cfa": "none", "shot_noise": False, "vignetting": False, **QUIET},
                 {"time_s": 0.01})
    raw = S.expose(narrow_band((64, 64), 0.03), cfg)
    rate = photons_per_second(0.03, 550.0, 6.0, working_f_number()) * 0.6
    k = (4095 - 256) / 20000.0
    assert np.all(raw.mosaic == np.uint16(round(k * rate * 0.01 + 256)))


def test_patterns_from_sensor_seed_temporal_from_frame_seed():
    cfg = config({"model": "ideal", "cfa": "none", "dsnu_e": 5.0, "read_noise_e": 1.0, "dark_current_e_per_s": 0.0,
                  "bit_depth": 16, "full_well_e": 60000.0, "seed": 5})
    dark = narrow_band((64, 64), 0.0)
    a = S.expose(dark, cfg, frame_seed=1)
    b = S.expose(dark, cfg, frame_seed=1)
    c = S.expose(dark, cfg, frame_seed=2)
    assert np.array_equal(a.mosaic, b.mosaic)
    assert not np.array_equal(a.mosaic, c.mosaic)
    # the DSNU pattern is shared by frames of one camera: frames correlate strongly
    corr = np.corrcoef(a.mosaic.ravel().astype(float), c.mosaic.ravel().astype(float))[0, 1]
    assert corr > 0.8
    other = S.expose(dark, cfg.replace(**{"sensor.seed": 6}), frame_seed=1)
    corr_other = np.corrcoef(a.mosaic.ravel().astype(float), other.mosaic.ravel().astype(float))[0, 1]
    assert abs(corr_other) < 0.1
    prnu_unit, dsnu_unit = S.fixed_patterns(5, (64, 64))
    assert prnu_unit.mean() == pytest.approx(0.0, abs=1e-6) and prnu_unit.std() == pytest.approx(1.0, rel=1e-5)
    assert S.fixed_patterns(5, (64, 64))[1] is dsnu_unit  # cached


def test_expose_defaults_frame_seed_to_render_seed():
    cfg = config({"read_noise_e": 5.0}, render={"seed": 42})
    raw = S.expose(image((64, 64), np.full(31, 0.01)), cfg)
    assert raw.meta["seeds"] == {"sensor": 0, "frame": 42}
    assert np.array_equal(raw.mosaic, S.expose(image((64, 64), np.full(31, 0.01)), cfg, frame_seed=42).mosaic)


def test_quantum_efficiency_scaling():
    qe = S.quantum_efficiency("canon_eos_5d", WAVELENGTHS, peak_qe=0.5)
    assert qe.shape == (31, 3) and qe.max() <= 0.5 + 1e-12
    np.testing.assert_allclose(qe, hand_qe("canon_eos_5d", WAVELENGTHS, 0.5))
    assert np.all(S.quantum_efficiency("ideal", WAVELENGTHS, peak_qe=0.8, monochrome=True) == 0.8)


@pytest.mark.parametrize("cfa", ["RGGB", "BGGR", "GRBG", "GBRG"])
def test_cfa_sampling(cfa):
    # Light only the blue channel's band region: the blue sites must be brightest.
    cfg = config({"model": "nikon_d850", "cfa": cfa, "shot_noise": False, "vignetting": False, **QUIET},
                 {"time_s": "auto"})
    raw = S.expose(narrow_band((64, 64), 1.0, 450.0), cfg)
    tile = raw.mosaic[:2, :2].ravel()
    assert cfa[int(np.argmax(tile))] == "B"
    assert cfa[int(np.argmin(tile))] == "R"


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("bad, message", [(np.nan, "non-finite"), (np.inf, "non-finite"), (-1e-3, "negative")])
def test_bad_radiance_values(bad, message):
    data = np.full((64, 64, 31), 0.01, np.float32)
    data[10, 20, 5] = bad
    with pytest.raises(SensorError, match=message) as info:
        S.expose(SpectralImage(data, WAVELENGTHS, EDGES), config())
    assert "row 10, column 20" in str(info.value) and ">= 0" in str(info.value)


def test_bad_radiance_shape():
    with pytest.raises(SensorError, match="sensor.width_px"):
        S.expose(image((32, 64), np.full(31, 0.01)), config())
    data = SpectralImage(np.zeros((64, 64), np.float32), WAVELENGTHS, EDGES)
    with pytest.raises(SensorError, match=r"\(H, W, B\)"):
        S.expose(data, config())
    with pytest.raises(SensorError, match="bands"):
        S.expose(SpectralImage(np.zeros((64, 64, 30), np.float32), WAVELENGTHS, EDGES), config())


@pytest.mark.parametrize("key, value", [
    ("full_well_e", 0.0), ("full_well_e", -5.0), ("bit_depth", 7), ("bit_depth", 17),
    ("peak_qe", 0.0), ("peak_qe", 1.2), ("cfa", "RGBX"), ("cfa", "rggb"),
])
def test_bad_sensor_config(key, value):
    with pytest.raises(ConfigError, match=f"sensor.{key}"):
        scene_from_dict({"sensor": {key: value}})


def test_bad_sensor_values_in_plain_functions():
    with pytest.raises(SensorError, match=r"\(0, 1\]"):
        S.quantum_efficiency("ideal", WAVELENGTHS, peak_qe=1.5)
    with pytest.raises(SensorError, match="hybrid"):
        S.expose(image((64, 64), np.full(31, 0.01)), config(), shot_noise_method="gaussian")
    with pytest.raises(SensorError, match="frame_seed"):
        S.expose(image((64, 64), np.full(31, 0.01)), config(), frame_seed=-1)


def test_auto_exposure_needs_light():
    with pytest.raises(SensorError, match="no light"):
        S.expose(image((64, 64), np.zeros(31)), config(exposure={"time_s": "auto"}))


def test_noise_profile_predicts_the_temporal_variance_with_strong_dark_current():
    # 100 e⁻ of dark signal plus ~400 e⁻ of photo-signal: var(x) must equal S·x + O of the DNG
    # NoiseProfile, measured from the difference of two frames (temporal noise only)
    cfg = config({"width_px": 256, "height_px": 256, "bit_depth": 16, "black_level_dn": 1000,
                  "full_well_e": 60000.0, "read_noise_e": 4.0,
                  "dark_current_e_per_s": 2000.0, "dsnu_e": 0.0, "prnu": 0.0, "vignetting": False},
                 {"time_s": 0.05})
    scene = narrow_band((256, 256), 0.02)
    a, b = S.expose(scene, cfg, frame_seed=1), S.expose(scene, cfg, frame_seed=2)
    span = a.white_level - a.black_level
    xa = (a.mosaic.astype(float) - a.black_level) / span
    xb = (b.mosaic.astype(float) - b.black_level) / span
    measured = np.var(xa - xb) / 2
    scale, offset = a.noise_profile
    predicted = scale * np.mean((xa + xb) / 2) + offset
    assert measured == pytest.approx(predicted, rel=0.02)


def test_photon_constants_are_codatas():
    """h and c are written out (scipy.constants costs 70 ms of every run's start): exact SI values."""
    import scipy.constants

    from spectral_cam.sensor.radiometry import PLANCK_J_S, SPEED_OF_LIGHT_M_S, photons_per_joule

    assert PLANCK_J_S == scipy.constants.h and SPEED_OF_LIGHT_M_S == scipy.constants.c
    assert float(photons_per_joule(550.0)) == pytest.approx(550e-9 / (scipy.constants.h * scipy.constants.c),
                                                            rel=1e-15)
