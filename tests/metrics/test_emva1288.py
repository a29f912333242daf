"""EMVA 1288 round trip: simulate flat fields, recover the sensor's parameters."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.constants as const

from spectral_cam import sensor as S
from spectral_cam.metrics.emva1288 import pair_statistics, photon_transfer, plot_photon_transfer, spatial_nonuniformity
from spectral_cam.image import SpectralImage
from spectral_cam.scene import scene_from_dict

WAVELENGTHS = np.arange(400.0, 701.0, 10.0)
EDGES = np.append(WAVELENGTHS - 5.0, WAVELENGTHS[-1] + 5.0)
PITCH_UM, T_S, F_NUMBER = 5.0, 0.1, 4.0
READ_E, DARK_E_PER_S, DSNU_E, PRNU = 3.0, 50.0, 2.0, 0.01


def narrow_band(size, radiance, wavelength_nm):
    data = np.zeros((size, size, len(WAVELENGTHS)), np.float32)
    data[..., int(np.argmin(abs(WAVELENGTHS - wavelength_nm)))] = radiance
    return SpectralImage(data, WAVELENGTHS, EDGES)


def photons_per_radiance(wavelength_nm):
    """μ_p per unit band radiance, by hand: π/(1 + 4N_w²)·A·t·λ/(h·c); N_w = N(1 + f/(z − f))."""
    n_w = F_NUMBER * (1 + 8e-3 / (2.0 - 8e-3))
    return math.pi / (1 + 4 * n_w ** 2) * (PITCH_UM * 1e-6) ** 2 * T_S * wavelength_nm * 1e-9 / (const.h * const.c)


def sensor_config(**sensor):
    iso = sensor.pop("iso", 100.0)
    return scene_from_dict({
        # base ISO 100 whatever camera's curves are named: the references below are at ISO 100
        "sensor": {"pixel_pitch_um": PITCH_UM, "read_noise_e": READ_E, "dark_current_e_per_s": DARK_E_PER_S,
                   "dsnu_e": DSNU_E, "prnu": PRNU, "peak_qe": 0.7, "vignetting": False, "seed": 7,
                   "base_iso": 100.0, **sensor},
        "exposure": {"time_s": T_S, "iso": iso},
        "lens": {"f_number": F_NUMBER},
    })


def series(cfg, size, wavelength_nm, photon_levels, *, stacks=True):
    """Frame pairs over an illumination series, one dark pair, dark and 50 % stacks."""
    per_l = photons_per_radiance(wavelength_nm)
    pairs = []
    for i, photons in enumerate(photon_levels):
        flat = narrow_band(size, photons / per_l, wavelength_nm)
        pairs.append((S.expose(flat, cfg, frame_seed=2 * i + 1), S.expose(flat, cfg, frame_seed=2 * i + 2)))
    dark = narrow_band(size, 0.0, wavelength_nm)
    dark_pairs = [(S.expose(dark, cfg, frame_seed=10_001), S.expose(dark, cfg, frame_seed=10_002))]
    if not stacks:
        return pairs, dark_pairs, None, None
    dark_stack = [S.expose(dark, cfg, frame_seed=20_000 + i) for i in range(16)]
    return pairs, dark_pairs, dark_stack, None


def photon_levels(saturation_photons):
    """Low points, a linear range, and dense steps (0.75 %) around saturation, where the
    variance peak that defines μ_y.sat must be resolved."""
    low = np.linspace(0.004, 0.05, 6)
    return np.concatenate([low, np.linspace(0.06, 0.88, 28), np.linspace(0.9, 1.2, 41)]) * saturation_photons


def test_round_trip_monochrome():
    # ADC-limited: ISO 2× base, so saturation = (2^14 − 1 − 256)/K < full well.
    cfg = sensor_config(model="ideal", cfa="none", width_px=192, height_px=192, bit_depth=14,
                        full_well_e=30000.0, black_level_dn=256, iso=200.0)
    k_ref = (2 ** 14 - 1 - 256) / 30000.0 * 2.0
    sigma_d_ref = math.sqrt(READ_E ** 2 + DARK_E_PER_S * T_S)
    saturation_ref = min(30000.0, (2 ** 14 - 1 - 256) / k_ref)
    assert k_ref * sigma_d_ref >= 1.0  # the dark noise dithers the quantiser
    levels = photon_levels(saturation_ref / 0.7)
    pairs, dark_pairs, dark_stack, _ = series(cfg, 192, 550.0, levels)
    half = narrow_band(192, 0.5 * saturation_ref / 0.7 / photons_per_radiance(550.0), 550.0)
    bright_stack = [S.expose(half, cfg, frame_seed=30_000 + i) for i in range(16)]
    result = photon_transfer(pairs, dark_pairs, photons_per_pixel=levels, dark_stack=dark_stack,
                             bright_stack=bright_stack)
    assert result.channels == ("Y",)
    assert result.gain == pytest.approx(k_ref, rel=0.03)
    assert result.sigma_d_e == pytest.approx(sigma_d_ref, rel=0.03)
    assert result.sigma_d_e_intercept == pytest.approx(sigma_d_ref, rel=0.3)  # the standard's check
    assert result.dsnu_e == pytest.approx(DSNU_E, rel=0.03)
    assert result.prnu == pytest.approx(PRNU, rel=0.03)
    assert result.saturation_e == pytest.approx(saturation_ref, rel=0.05)
    assert result.quantum_efficiency[0] == pytest.approx(0.7, rel=0.03)
    good = (result.mean_dn[:, 0] - result.mean_dark_dn[:, 0]) < 0.7 * saturation_ref * k_ref
    model = np.sqrt(0.7 * levels[good]) / np.sqrt(1 + (sigma_d_ref ** 2 + 1 / 12 / k_ref ** 2) / (0.7 * levels[good]))
    np.testing.assert_allclose(result.snr[good, 0], model, rtol=0.05)


def test_round_trip_cfa_narrow_band_qe():
    # Full-well limited at base ISO; narrow-band light at λ₀ = 530 nm lights all three colours.
    wavelength = 530.0
    cfg = sensor_config(model="nikon_d850", cfa="GBRG", width_px=256, height_px=256, bit_depth=14,
                        full_well_e=20000.0, black_level_dn=512, prnu=0.005)
    k_ref = (2 ** 14 - 1 - 512) / 20000.0
    eta_ref = S.quantum_efficiency("nikon_d850", [wavelength], peak_qe=0.7)[0]  # r, g, b
    levels = photon_levels(20000.0 / eta_ref.max())
    pairs, dark_pairs, dark_stack, _ = series(cfg, 256, wavelength, levels)
    result = photon_transfer(pairs, dark_pairs, photons_per_pixel=levels, dark_stack=dark_stack)
    assert result.channels == ("R", "G", "B")
    np.testing.assert_allclose(result.quantum_efficiency, eta_ref, rtol=0.03)
    assert result.gain == pytest.approx(k_ref, rel=0.03)
    assert result.saturation_e_per_channel[1] == pytest.approx(20000.0, rel=0.05)
    assert np.isnan(result.saturation_e_per_channel[0])  # red never saturates at 530 nm
    np.testing.assert_allclose(result.dsnu_e_per_channel, DSNU_E, rtol=0.03)


def test_pair_statistics_against_analytic_variance():
    rng = np.random.default_rng(0)
    fixed = rng.normal(0, 10, (200, 200))  # a fixed pattern the pair difference must remove
    a = 100 + fixed + rng.normal(0, 3, fixed.shape)
    b = 100 + fixed + rng.normal(0, 3, fixed.shape)
    means, variances = pair_statistics(a, b)
    assert means["Y"] == pytest.approx(100 + fixed.mean(), abs=0.05)
    assert variances["Y"] == pytest.approx(9.0, rel=0.02)
    stack = [100 + fixed + rng.normal(0, 3, fixed.shape) for _ in range(8)]
    _, spatial, temporal = spatial_nonuniformity(stack)
    assert spatial["Y"] == pytest.approx(fixed.var(ddof=1), rel=0.01)
    assert temporal["Y"] == pytest.approx(9.0, rel=0.02)


def test_plot_and_errors(tmp_path):
    cfg = sensor_config(model="ideal", cfa="none", width_px=32, height_px=32, bit_depth=12,
                        full_well_e=8000.0, black_level_dn=64, iso=400.0)
    levels = photon_levels(2500.0 / 0.7)
    pairs, dark_pairs, _, _ = series(cfg, 32, 550.0, levels, stacks=False)
    result = photon_transfer(pairs, dark_pairs, photons_per_pixel=levels)
    path = plot_photon_transfer(result, tmp_path / "ptc.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert result.summary()["K_dn_per_e"] == pytest.approx(result.gain)
    with pytest.raises(ValueError, match="three exposure points"):
        photon_transfer(pairs[:2], dark_pairs)
    with pytest.raises(ValueError, match="dark pair"):
        photon_transfer(pairs, dark_pairs * 2)
    with pytest.raises(ValueError, match="photons_per_pixel"):
        photon_transfer(pairs, dark_pairs, photons_per_pixel=levels[:-1])
