"""Study (b): the sensor from 0.01 to 10⁵ electrons (:mod:`spectral_cam.apps.stress.exposure`).

The expected numbers are written out here (the camera equation, the ADC's white level and
gain) rather than taken from the code under test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.constants as const

from spectral_cam import sensor as S
from spectral_cam.apps.stress.exposure import (EXPOSURE_SENSORS, exposure_study, mono_config, neutral_chroma,
                                               plot_exposure)
from spectral_cam.radiance_targets import lambertian_radiance, narrow_band_flat, uniform_image
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.scene import scene_from_dict


def test_electrons_per_band_radiance_is_the_camera_equation():
    """π·L/(1 + 4N_w²)·A·λ/(h·c)·η by hand (EMVA 1288 §2.1), f = 8 mm, N = 2.8, z = 2 m."""
    config = mono_config(16, {}, 100.0, 0.01)
    f, n, z = 8e-3, 2.8, 2.0
    n_w = n * (1 + f / (z - f))
    expected = math.pi / (1 + 4 * n_w ** 2) * (6e-6) ** 2 * 550e-9 / (const.h * const.c) * 0.6
    assert S.electrons_per_band_radiance(config, 550.0) == pytest.approx(expected, rel=1e-9)


def _flat(size, band_radiance):
    return narrow_band_flat((size, size), band_radiance, 550.0)


def _pair_mean_electrons(config, level_e, seed, size):
    rate = S.electrons_per_band_radiance(config, 550.0) * 0.01
    frames = [S.expose(_flat(size, level_e / rate), config, frame_seed=seed + k) for k in (0, 1)]
    darks = [S.expose(_flat(size, 0.0), config, frame_seed=seed + 10 + k) for k in (0, 1)]
    gain = frames[0].meta["K_dn_per_e"]
    signal = np.concatenate([f.mosaic.ravel() for f in frames]).astype(float)
    dark = np.concatenate([d.mosaic.ravel() for d in darks]).astype(float)
    mean = (signal.mean() - dark.mean()) / gain
    # temporal variance from each pair's difference removes the fixed patterns
    var_s = np.var(frames[0].mosaic.astype(float) - frames[1].mosaic) / 2
    var_d = np.var(darks[0].mosaic.astype(float) - darks[1].mosaic) / 2
    return mean, math.sqrt((var_s + var_d) / signal.size) / gain, frames


@pytest.mark.parametrize("level_e", [0.01, 0.1, 1.0])
def test_mean_is_unbiased_from_0_01_to_1_electron(level_e):
    """The default chain (read noise 2.5 e⁻, dark current, DSNU, PRNU, black level 256,
    K = 0.19 DN/e⁻): the read noise dithers the ADC, so the dark-subtracted mean stays
    unbiased far below one DN."""
    config = mono_config(160, {}, 100.0, 0.01)
    mean, standard_error, _ = _pair_mean_electrons(config, level_e, 7, 160)
    assert abs(mean - level_e) < 4 * standard_error
    assert standard_error < 0.02


def test_without_dither_the_adc_swallows_sub_lsb_signal():
    """Documented failure: with no noise before the ADC, K = 0.19 DN/e⁻ rounds single
    electrons away (the exposure study charts it)."""
    config = mono_config(64, {"read_noise_e": 0.0, "dsnu_e": 0.0, "dark_current_e_per_s": 0.0, "prnu": 0.0},
                         100.0, 0.01)
    mean, _, _ = _pair_mean_electrons(config, 1.0, 3, 64)
    assert mean < 0.6


@pytest.mark.parametrize("iso, overrides, saturation_e", [
    (100.0, {"read_noise_e": 0.0, "dsnu_e": 0.0, "dark_current_e_per_s": 0.0, "prnu": 0.0}, 20000.0),
    (100.0, {}, 20000.0),
    (800.0, {}, (4095 - 256) / ((4095 - 256) / 20000.0 * 8)),  # ADC-limited: (W − B)/K
])
def test_clipping_at_saturation_is_exact(iso, overrides, saturation_e):
    config = mono_config(48, overrides, iso, 0.01)
    rate = S.electrons_per_band_radiance(config, 550.0) * 0.01
    raw = S.expose(_flat(48, 5 * saturation_e / rate), config, frame_seed=1)
    assert raw.meta["saturation_e"] == pytest.approx(saturation_e)
    assert raw.mosaic.max() == raw.white_level  # clipped, never wrapped past 16 bits
    electrons = (raw.mosaic.astype(float) - raw.black_level) / raw.meta["K_dn_per_e"]
    if overrides or iso > 100:  # no noise after the clip, or the ADC clips: every pixel at white
        assert np.all(raw.mosaic == raw.white_level)
    else:  # read noise after the full-well clip spreads ±0.5 DN below white
        assert raw.mosaic.min() >= raw.white_level - 3
        assert electrons.mean() == pytest.approx(saturation_e, rel=1e-3)


@pytest.mark.parametrize("illuminant", ["A", "D65"])
def test_no_colour_cast_in_clipped_highlights(illuminant):
    """A white reflector 4× past saturation: with highlight handling it develops neutral
    (CIELAB chroma < 1); without, the white-balance gains turn the clipped white coloured."""
    base = {"illuminant": {"spd": illuminant}, "sensor": {"width_px": 24, "height_px": 24, "vignetting": False}}
    image = uniform_image(lambertian_radiance(illuminant, [0.9])[0], (24, 24))
    probe = S.expose(image, scene_from_dict({**base, "exposure": {"time_s": "auto", "auto_fraction": 1.0, "metering": "etr"}}))
    raw = S.expose(image, scene_from_dict({**base, "exposure": {"time_s": 4 * probe.meta["exposure_s"]}}),
                   frame_seed=2)
    chroma = {}
    for method in ("clip", "desaturate", "none"):
        linear = develop(raw, ISPConfig(highlights=method, tone="linear")).linear
        chroma[method] = neutral_chroma(linear[4:-4, 4:-4].reshape(-1, 3).mean(axis=0))
    assert chroma["clip"] < 1.0 and chroma["desaturate"] < 1.0
    assert chroma["none"] > 20.0


def test_neutral_chroma_is_zero_for_greys_and_nan_without_light():
    assert neutral_chroma([0.3, 0.3, 0.3]) == pytest.approx(0.0, abs=0.01)  # sRGB matrix rounding: ~0.008
    assert neutral_chroma([1.0, 0.0, 1.0]) > 50.0
    assert math.isnan(neutral_chroma([0.0, 0.0, 0.0]))


def test_exposure_study_snr_follows_the_emva_model(tmp_path, tiny):
    result = exposure_study(tiny)
    data = result["data"]
    default = data["sensors"][EXPOSURE_SENSORS[0][0]]
    levels = np.asarray(data["levels_e"])
    usable = (levels >= 10) & (levels <= 0.7 * default["saturation_e"])
    ratio = np.asarray(default["snr"])[usable] / np.asarray(default["snr_model"])[usable]
    assert usable.sum() >= 2 and np.all(np.abs(ratio - 1) < 0.1)
    clipped = levels > 2 * default["saturation_e"]
    assert np.allclose(np.asarray(default["measured_e"])[clipped], default["saturation_e"], rtol=1e-3)
    assert max(data["highlights"]["A"]["chroma"]["clip"]) < 1.0
    files = plot_exposure(result, tmp_path)
    assert len(files) == 3 and all((tmp_path / name).stat().st_size > 1000 for name in files)
