"""ISP stages on synthetic data, each checked against an independent reference (theory,
OpenCV, colour-science, scikit-image, or a file read back by another library)."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import cv2
import numpy as np
import pytest

from spectral_cam.errors import ConfigError
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.isp import config as isp_config
from spectral_cam.cfa import channel_index, opencv_bayer_code, opencv_bayer_name
from spectral_cam.isp.demosaic import DEMOSAIC, bayer_methods, demosaic
from spectral_cam.isp.denoise import (DENOISERS, NoiseModel, denoise_mosaic, estimate_noise,
                                      generalized_anscombe, inverse_generalized_anscombe)
from spectral_cam.isp.encode import quantise, write_image, write_outputs
from spectral_cam.isp.highlights import HIGHLIGHTS
from spectral_cam.isp.normalise import normalise
from spectral_cam.isp.sharpen import unsharp_mask
from spectral_cam.isp.tone import TONE, filmic, srgb_eotf, srgb_oetf
from spectral_cam.isp.white_balance import WHITE_BALANCE, apply_white_balance, white_balance_gains
from spectral_cam.metrics.image_quality import psnr, ssim
from spectral_cam.raw import RawImage

pytestmark = pytest.mark.timeout(120)

PATTERNS = ("RGGB", "BGGR", "GRBG", "GBRG")
METHODS = tuple(bayer_methods())  # the Bayer mosaics of these tests; larger tiles: tests/raw/test_cfa_tiles.py
# where each pattern has its first red site (row, column)
RED_SITE = {"RGGB": (0, 0), "GRBG": (0, 1), "GBRG": (1, 0), "BGGR": (1, 1)}


def sample_cfa(rgb: np.ndarray, cfa: str) -> np.ndarray:
    """Bayer-sample an (H, W, 3) image: each pixel keeps its CFA colour."""
    index = channel_index(rgb.shape[:2], cfa)
    return np.take_along_axis(rgb, index[..., None].astype(np.intp), axis=-1)[..., 0]


def inner(a: np.ndarray, border: int) -> np.ndarray:
    return a[border:-border, border:-border]


# ----------------------------------------------------------------------------- config
def test_config_defaults_round_trip_and_registries():
    config = ISPConfig()
    assert ISPConfig.from_dict(config.to_dict()) == config
    custom = ISPConfig(white_balance="manual", wb_gains=(2, 1, 1.5), demosaic="menon2007", denoise=0.7,
                       highlights="desaturate", colour_matrix="dng", tone="filmic", sharpen=0.5,
                       outputs=("png", "exr"))
    assert ISPConfig.from_dict(custom.to_dict()) == custom
    assert custom.denoise_strength == 0.7 and ISPConfig(denoise="auto").denoise_strength == 1.0
    # the light config module names exactly what the stage registries implement
    assert isp_config.DEMOSAIC_METHODS == tuple(DEMOSAIC)
    assert isp_config.DENOISE_METHODS == tuple(DENOISERS)
    assert isp_config.HIGHLIGHT_METHODS == tuple(HIGHLIGHTS)
    assert isp_config.TONE_METHODS == tuple(TONE)
    assert isp_config.WHITE_BALANCE_METHODS == tuple(WHITE_BALANCE)


@pytest.mark.parametrize("field, value, valid", [
    ("demosaic", "ahd", "bilinear"),
    ("white_balance", "auto", "grey_world"),
    ("tone", "gamma", "filmic"),
    ("colour_matrix", "xyz", "root_polynomial"),
    ("highlights", "reconstruct", "desaturate"),
    ("outputs", ("bmp",), "exr"),
    ("denoise", "strong", "auto"),
    ("denoise_method", "bm3d", "nlmeans"),
])
def test_config_rejects_unknown_names_listing_valid_ones(field, value, valid):
    with pytest.raises(ConfigError, match=valid):
        ISPConfig(**{field: value})


def test_config_rejects_bad_numbers():
    with pytest.raises(ConfigError, match="three positive gains"):
        ISPConfig(white_balance="manual")
    with pytest.raises(ConfigError):
        ISPConfig(denoise=-1.0)
    with pytest.raises(ConfigError):
        ISPConfig(sharpen_radius_px=0.0)
    with pytest.raises(ConfigError):
        ISPConfig(jpeg_quality=101)


def test_config_fields_survive_the_scene_reader_coercion():
    """The scene reader coerces [isp] values by the field annotations (TOML ints, lists)."""
    from spectral_cam.scene import scene_from_dict

    custom = ISPConfig(wb_gains=(2.0, 1.0, 1.5), denoise=1.5, outputs=("png", "tiff"), jpeg_quality=90)
    toml_like = {key: list(value) if isinstance(value, tuple) else value for key, value in custom.to_dict().items()}
    toml_like["denoise"] = 1  # TOML int for a float | str field
    assert scene_from_dict({"isp": toml_like}).isp == dataclasses.replace(custom, denoise=1.0)
    assert scene_from_dict({"isp": {"denoise": "auto"}}).isp.denoise == "auto"


def test_config_module_imports_nothing_heavy():
    code = ("import sys, spectral_cam.isp.config, spectral_cam.isp; "
            "heavy = [m for m in ('cv2', 'colour', 'skimage', 'scipy', 'colour_demosaicing') if m in sys.modules]; "
            "print(heavy); sys.exit(1 if heavy else 0)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stdout + result.stderr


# ----------------------------------------------------------------------------- CFA / OpenCV
@pytest.mark.parametrize("cfa", PATTERNS)
def test_opencv_bayer_name_matches_a_known_mosaic(cfa):
    """A flat colour sampled with our pattern must come back as that colour from OpenCV's
    conversion; every other OpenCV Bayer name permutes or mixes it."""
    colour = np.array([20, 120, 220], np.uint8)
    mosaic = sample_cfa(np.broadcast_to(colour, (8, 10, 3)).copy(), cfa)
    expected = {"RGGB": "BG", "BGGR": "RG", "GRBG": "GB", "GBRG": "GR"}[cfa]
    assert opencv_bayer_name(cfa) == expected
    for name in ("BG", "RG", "GB", "GR"):
        out = cv2.cvtColor(mosaic, getattr(cv2, f"COLOR_Bayer{name}2RGB"))
        matches = np.array_equal(out[2:-2, 2:-2], np.broadcast_to(colour, out[2:-2, 2:-2].shape))
        assert matches == (name == expected)
    assert opencv_bayer_code(cfa) == getattr(cv2, f"COLOR_Bayer{expected}2RGB")


def test_normalise_maps_black_to_zero_and_white_to_one():
    mosaic = np.array([[256, 4095], [1000, 200]], np.uint16)
    out = normalise(mosaic, black_level=256, white_level=4095)
    np.testing.assert_allclose(out, (mosaic.astype(float) - 256) / (4095 - 256), rtol=1e-6)
    per_site = normalise(mosaic, black_level=np.array([[256, 250], [260, 200]]), white_level=4095)
    np.testing.assert_allclose(per_site[1, 1], 0.0, atol=1e-7)
    assert out.dtype == np.float32 and out[1, 1] < 0  # unclipped below black


# ----------------------------------------------------------------------------- demosaic
def textbook_scene(h=256, w=384):
    y, x = np.mgrid[0:h, 0:w].astype(float)
    rgb = np.stack([255 * x / (w - 1), 255 * y / (h - 1), 128 + 64 * np.sin(x / 6)], axis=-1)
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


def test_bilinear_equals_opencv_on_the_textbook_scene():
    mosaic = sample_cfa(textbook_scene(), "RGGB")
    reference = cv2.cvtColor(mosaic, cv2.COLOR_BayerBG2RGB).astype(np.float64)
    ours = demosaic(mosaic.astype(np.float32), "RGGB", method="bilinear")
    assert np.max(np.abs(inner(ours, 2) - inner(reference, 2))) <= 1.0


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("shape", [(32, 48), (31, 45)])
def test_every_method_reproduces_a_flat_colour(method, shape):
    colour = np.array([0.2, 0.5, 0.35], np.float32)
    for cfa in PATTERNS:
        mosaic = sample_cfa(np.broadcast_to(colour, shape + (3,)).copy(), cfa)
        out = demosaic(mosaic, cfa, method=method)
        assert out.shape == shape + (3,) and out.dtype == np.float32
        tolerance = 1e-5 if method in ("bilinear", "malvar2004", "ea") else 2e-3
        np.testing.assert_allclose(inner(out, 3), np.broadcast_to(colour, inner(out, 3).shape), atol=tolerance)


@pytest.mark.parametrize("method", ["bilinear", "malvar2004"])
@pytest.mark.parametrize("cfa", PATTERNS)
def test_linear_methods_are_exact_on_linear_ramps(method, cfa):
    """Both kernels sum to one and are symmetric, so they interpolate any per-channel
    linear function exactly (Malvar's correction terms cancel on linear data)."""
    y, x = np.mgrid[0:40, 0:52].astype(np.float32)
    rgb = np.stack([0.1 + 0.01 * x, 0.2 + 0.015 * y, 0.3 + 0.004 * x - 0.006 * y], axis=-1)
    out = demosaic(sample_cfa(rgb, cfa), cfa, method=method)
    np.testing.assert_allclose(inner(out, 2), inner(rgb, 2), atol=2e-6)


@pytest.mark.parametrize("method", METHODS)
def test_every_method_reconstructs_a_smooth_colour_field(method):
    y, x = np.mgrid[0:64, 0:80].astype(np.float32)
    rgb = np.stack([0.5 + 0.2 * np.sin(x / 11), 0.4 + 0.2 * np.cos(y / 9), 0.3 + 0.1 * np.sin((x + y) / 13)], -1)
    out = demosaic(sample_cfa(rgb, "GBRG"), "GBRG", method=method)
    assert np.sqrt(np.mean((inner(out, 4) - inner(rgb, 4)) ** 2)) < 2e-3


@pytest.mark.parametrize("method", ["bilinear", "malvar2004", "vng", "ea"])
@pytest.mark.parametrize("cfa", PATTERNS)
def test_methods_keep_the_measured_samples(method, cfa):
    rng = np.random.default_rng(3)
    rgb = rng.uniform(0.05, 0.95, (21, 27, 3)).astype(np.float32)
    mosaic = sample_cfa(rgb, cfa)
    out = demosaic(mosaic, cfa, method=method)
    kept = np.take_along_axis(out, channel_index(mosaic.shape, cfa)[..., None].astype(np.intp), -1)[..., 0]
    np.testing.assert_allclose(kept, mosaic, atol=1e-6)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("cfa", ["BGGR", "GRBG", "GBRG"])
def test_all_cfa_phases_match_the_rggb_result_on_a_crop(method, cfa):
    """Demosaicing image I sampled with phase P equals the RGGB result on I cropped to
    start on a red site (in the interior)."""
    rng = np.random.default_rng(4)
    base = cv2.GaussianBlur(rng.uniform(0, 1, (49, 61, 3)).astype(np.float32), (0, 0), 1.2)
    out = demosaic(sample_cfa(base, cfa), cfa, method=method)
    dy, dx = RED_SITE[cfa]
    crop = base[dy:, dx:]
    reference = demosaic(sample_cfa(crop, "RGGB"), "RGGB", method=method)
    # rcd reads up to 13 px away (the mirrored borders differ by 9e-5 at 8 px in, 0 from 12 px)
    margin = 12 if method == "rcd" else 8
    np.testing.assert_allclose(inner(out[dy:, dx:], margin), inner(reference, margin), atol=1e-5)


def correlated_scene(h=128, w=160, supersample=4):
    """A grey zone plate (left) and coloured slanted edges (right), area-sampled 4×4."""
    yy, xx = np.mgrid[0:h * supersample, 0:w * supersample].astype(np.float64) / supersample
    rgb = np.empty(yy.shape + (3,))
    half = w / 2
    r2 = (xx - half / 2) ** 2 + (yy - h / 2) ** 2
    grey = 0.5 + 0.35 * np.cos(np.pi * r2 / (2.2 * h))
    rgb[:] = grey[..., None]
    right = xx >= half
    side = (xx - 0.75 * w) * np.cos(0.1) + (yy - h / 2) * np.sin(0.1) > 0
    band = (yy // (h / 4)).astype(int) % 2 == 0
    # light and dark shades of two hues: the channels change together across each edge
    colours = {(0, 0): (0.25, 0.18, 0.12), (0, 1): (0.75, 0.55, 0.36),
               (1, 0): (0.12, 0.17, 0.26), (1, 1): (0.36, 0.52, 0.78)}
    for (b, s), c in colours.items():
        region = right & (band == b) & (side == s)
        rgb[region] = c
    return rgb.reshape(h, supersample, w, supersample, 3).mean(axis=(1, 3)).astype(np.float32)


def test_gradient_methods_beat_bilinear_on_correlated_channels():
    truth = correlated_scene()
    mosaic = sample_cfa(truth, "RGGB")
    scores = {m: psnr(inner(demosaic(mosaic, "RGGB", method=m), 4), inner(truth, 4)) for m in METHODS}
    assert scores["malvar2004"] > scores["bilinear"] + 1.0
    assert scores["menon2007"] > scores["bilinear"] + 1.0
    assert ssim(inner(demosaic(mosaic, "RGGB", method="malvar2004"), 4), inner(truth, 4)) > \
        ssim(inner(demosaic(mosaic, "RGGB", method="bilinear"), 4), inner(truth, 4))


def test_unknown_demosaic_method_lists_the_valid_ones():
    with pytest.raises(ConfigError, match="malvar2004"):
        demosaic(np.zeros((4, 4), np.float32), "RGGB", method="ahd")
    with pytest.raises(ConfigError, match="RGGB"):
        demosaic(np.zeros((4, 4), np.float32), "RGBW", method="bilinear")


# ----------------------------------------------------------------------------- white balance
def test_as_shot_white_balance_makes_the_neutral_grey():
    neutral = np.array([0.45, 1.0, 0.62])
    mosaic = sample_cfa(np.broadcast_to(0.7 * neutral, (6, 8, 3)).astype(np.float32).copy(), "GRBG")
    gains = white_balance_gains(mosaic, "GRBG", method="as_shot", as_shot_neutral=neutral)
    np.testing.assert_allclose(gains, [1 / 0.45, 1.0, 1 / 0.62], rtol=1e-6)
    balanced = apply_white_balance(mosaic, "GRBG", gains=gains)
    np.testing.assert_allclose(balanced, 0.7, rtol=1e-6)


def test_grey_world_equalises_channel_means_and_ignores_clipped_samples():
    rng = np.random.default_rng(5)
    rgb = rng.uniform(0, 1, (40, 40, 3)) * np.array([0.5, 0.9, 0.3])
    rgb[:4, :4] = 1.0  # clipped corner: excluded
    mosaic = sample_cfa(rgb.astype(np.float32), "RGGB")
    gains = white_balance_gains(mosaic, "RGGB", method="grey_world")
    index = channel_index(mosaic.shape, "RGGB")
    ok = mosaic < 1.0
    means = [mosaic[(index == c) & ok].mean() * gains[c] for c in range(3)]
    np.testing.assert_allclose(means, means[1], rtol=1e-5)
    assert gains.min() == pytest.approx(1.0)


def test_white_patch_makes_the_brightest_patch_neutral():
    rng = np.random.default_rng(6)
    rgb = rng.uniform(0, 0.3, (60, 60, 3))
    rgb[20:40, 20:40] = (0.5, 0.9, 0.7)  # the white patch, seen through the camera
    gains = white_balance_gains(sample_cfa(rgb.astype(np.float32), "BGGR"), "BGGR", method="white_patch")
    np.testing.assert_allclose(np.array([0.5, 0.9, 0.7]) * gains / 0.9, 1.0, rtol=1e-5)


def test_manual_gains_and_errors():
    np.testing.assert_allclose(white_balance_gains(np.zeros((4, 4), np.float32), "RGGB", method="manual",
                                                   gains=(4.0, 2.0, 3.0)), [2.0, 1.0, 1.5])
    with pytest.raises(ConfigError, match="grey_world"):
        white_balance_gains(np.zeros((4, 4), np.float32), "RGGB", method="auto")
    with pytest.raises(ConfigError, match="AsShotNeutral"):
        white_balance_gains(np.zeros((4, 4), np.float32), "RGGB", method="as_shot")


# ----------------------------------------------------------------------------- tone, sharpen
def test_srgb_oetf_matches_colour_science():
    import colour

    x = np.concatenate([np.linspace(-0.05, 0.01, 50), np.linspace(0.01, 1.5, 400)]).astype(np.float32)
    np.testing.assert_allclose(srgb_oetf(x), colour.cctf_encoding(x.astype(float), function="sRGB"), atol=2e-6)
    np.testing.assert_allclose(srgb_eotf(srgb_oetf(x)), x, atol=2e-6)
    y = filmic(np.linspace(0, 20, 200))
    assert np.all(np.diff(y) >= 0) and y.min() >= 0 and y.max() <= 1


def test_unsharp_mask_matches_the_definition_with_scikit_image_blur():
    """out = x + a·(x − G_σ * x); the reference blur is scikit-image's Gaussian.
    (skimage.filters.unsharp_mask itself returns garbage with scikit-image 0.26 on
    NumPy 2.4, so the definition is spelled out.)"""
    from skimage.filters import gaussian

    rng = np.random.default_rng(7)
    image = cv2.GaussianBlur(rng.uniform(0, 1, (48, 56, 3)).astype(np.float32), (0, 0), 2.0)
    ours = unsharp_mask(image, amount=0.8, radius_px=1.5)
    blurred = gaussian(image.astype(np.float64), sigma=1.5, mode="mirror", truncate=4.0, channel_axis=-1,
                       preserve_range=True)
    reference = image + 0.8 * (image - blurred)
    np.testing.assert_allclose(ours, reference, atol=1e-4)
    np.testing.assert_array_equal(unsharp_mask(image, amount=0.0), image)


# ----------------------------------------------------------------------------- highlights
def clipped_raw(highlights_neutral=(0.5, 1.0, 0.7)):
    """A flat grey target whose centre is clipped in all channels (a blown-out white)."""
    h, w = 40, 40
    camera = np.broadcast_to(0.4 * np.asarray(highlights_neutral), (h, w, 3)).copy()
    camera[12:28, 12:28] = 5.0  # far beyond saturation
    dn = np.clip(np.rint(256 + camera * (4095 - 256)), 0, 4095)
    return RawImage(sample_cfa(dn, "RGGB").astype(np.uint16), "RGGB", 256, 4095,
                    as_shot_neutral=np.asarray(highlights_neutral))


@pytest.mark.parametrize("method", ["clip", "desaturate"])
def test_highlight_handling_keeps_clipped_whites_neutral(method):
    raw = clipped_raw()
    config = ISPConfig(colour_matrix="none", tone="linear", demosaic="malvar2004", highlights=method)
    out = develop(raw, config).linear
    centre = out[14:26, 14:26]
    assert np.max(np.abs(centre - centre[..., 1:2])) < 1e-6  # R = G = B
    np.testing.assert_allclose(centre, 1.0, atol=1e-6)
    # far from the clipped area the grey stays untouched (0.4 after white balance)
    np.testing.assert_allclose(out[:6, :6], 0.4, atol=2e-3)


def test_without_highlight_handling_clipped_whites_turn_magenta():
    out = develop(clipped_raw(), ISPConfig(colour_matrix="none", tone="linear", highlights="none")).linear
    r, g, b = out[20, 20]
    assert r > 1.5 * g and b > 1.3 * g


# ----------------------------------------------------------------------------- denoise
def poisson_gaussian_flat(level_e, shape, *, gain=0.19, sigma_d=2.5, black=256, white=4095, seed=0):
    rng = np.random.default_rng(seed)
    electrons = rng.poisson(level_e, shape) + rng.normal(0, sigma_d, shape)
    dn = np.rint(electrons * gain) + black
    model = NoiseModel.from_sensor(gain_dn_per_e=gain, dark_noise_e=sigma_d, black_level=black, white_level=white)
    return ((dn - black) / (white - black)).astype(np.float32), level_e * gain / (white - black), model


def test_noise_model_from_sensor_is_the_dng_noise_profile():
    model = NoiseModel.from_sensor(gain_dn_per_e=0.5, dark_noise_e=3.0, black_level=100, white_level=1100)
    assert model.gain == pytest.approx(0.5 / 1000)
    assert model.offset == pytest.approx((0.25 * 9 + 1 / 12) / 1000 ** 2)


@pytest.mark.parametrize("level_e", [20, 300, 3000])
def test_generalized_anscombe_stabilises_the_variance_to_one(level_e):
    x, _, model = poisson_gaussian_flat(level_e, (200_000,))
    assert np.var(generalized_anscombe(x, noise=model)) == pytest.approx(1.0, abs=0.05)


@pytest.mark.parametrize("counts", [2.0, 5.0, 20.0])
def test_exact_unbiased_inverse_recovers_the_mean_where_the_algebraic_one_is_biased(counts):
    """E[f(z)] mapped back must give the true count (Mäkitalo & Foi 2013); the algebraic
    inverse underestimates it by about 1/4 count."""
    rng = np.random.default_rng(8)
    model = NoiseModel(1.0, 1.0)
    z = rng.poisson(counts, 4_000_000) + rng.normal(0, 1.0, 4_000_000)
    expected = np.array([np.mean(generalized_anscombe(z, noise=model).astype(np.float64))])
    exact = inverse_generalized_anscombe(expected, noise=model)[0]
    algebraic = inverse_generalized_anscombe(expected, noise=model, method="algebraic")[0]
    assert exact == pytest.approx(counts, abs=0.03)
    assert counts - algebraic > 0.2


def test_bilateral_in_the_limit_reduces_variance_by_its_kernel_factor():
    """With the range kernel wide open the bilateral filter is the spatial Gaussian
    (σ = 2 px, radius 3 px), which divides white-noise variance by (Σw)²/Σw²."""
    x, truth, model = poisson_gaussian_flat(3000, (2 * 256, 2 * 256))
    y, xx = np.mgrid[-3:4, -3:4]
    w = np.exp(-(xx ** 2 + y ** 2) / 8.0) * (xx ** 2 + y ** 2 <= 9)
    expected = w.sum() ** 2 / (w ** 2).sum()
    out = denoise_mosaic(x, "RGGB", noise=model, strength=100.0, method="bilateral")
    factor = np.var(inner(x, 8)) / np.var(inner(out, 8))
    assert factor == pytest.approx(expected, rel=0.05)
    assert np.mean(out) == pytest.approx(truth, rel=2e-3)


@pytest.mark.parametrize("method", list(DENOISERS))
def test_denoise_lowers_noise_without_biasing_the_mean(method):
    """At 8 e⁻ (σ_d = 2.5 e⁻) the exact unbiased inverse keeps the mean within 1.5 %;
    the algebraic inverse is biased low by about 1/4 count (≈ 3 %)."""
    x, truth, model = poisson_gaussian_flat(8, (2 * 160, 2 * 160))
    out = denoise_mosaic(x, "GRBG", noise=model, strength=1.0, method=method)
    assert np.var(out) < np.var(x) / 8
    standard_error = np.std(x) / np.sqrt(x.size)
    assert abs(np.mean(out) - truth) < abs(np.mean(x) - truth) + 0.015 * truth + 3 * standard_error
    algebraic = denoise_mosaic(x, "GRBG", noise=model, strength=1.0, method=method, inverse="algebraic")
    assert np.mean(algebraic) < truth * 0.98


def test_estimate_noise_recovers_a_gaussian_sigma():
    rng = np.random.default_rng(9)
    mosaic = (0.3 + rng.normal(0, 0.01, (256, 256))).astype(np.float32)
    assert np.sqrt(estimate_noise(mosaic, "RGGB").offset) == pytest.approx(0.01, rel=0.05)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("bits", [8, 16])
def test_quantise_is_the_iec_digital_encoding(dtype, bits):
    """IEC 61966-2-1 §5: code = round(top·clip(V, 0, 1)); computed here in float64 with NumPy
    (rounding half to even, as the encoder does) on values across and outside [0, 1]."""
    top = 2 ** bits - 1
    rng = np.random.default_rng(3)
    values = np.concatenate([rng.uniform(-0.3, 1.3, 30000), np.arange(top + 1) / top, [0.0, 1.0, -0.0]])
    image = values[: values.size // 3 * 3].reshape(-1, 1, 3).astype(dtype)
    expected = np.rint(np.clip(image.astype(np.float32).astype(np.float64), 0, 1) * top)
    codes = quantise(image, bits=bits)
    assert codes.dtype == (np.uint8 if bits == 8 else np.uint16)
    np.testing.assert_array_equal(codes, expected)
    with pytest.raises(ConfigError, match="NaN or infinite"):
        quantise(np.where(np.arange(3) == 1, np.nan, image[:1]), bits=bits)


# ----------------------------------------------------------------------------- encoders
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_our_png_is_read_pixel_for_pixel_by_libpng_and_pillow(dtype):
    """png_bytes deflates slices on parallel threads into one zlib stream: libpng (OpenCV)
    and Pillow, two independent decoders that check the CRCs and Adler-32, read it back exactly."""
    import io

    from PIL import Image

    from spectral_cam.isp.encode import png_bytes

    rng = np.random.default_rng(4)
    top = np.iinfo(dtype).max
    smooth = cv2.resize(rng.uniform(0, top, (40, 30, 3)).astype(np.float32), (1500, 2000))
    image = np.clip(smooth + rng.normal(0, top / 100, smooth.shape), 0, top).astype(dtype)  # 9 or 18 MB
    encoded = png_bytes(image, workers=2)
    back = cv2.imdecode(np.frombuffer(encoded, np.uint8), cv2.IMREAD_UNCHANGED)[..., ::-1]
    np.testing.assert_array_equal(back, image)
    decoded = Image.open(io.BytesIO(encoded))
    assert decoded.size == (1500, 2000)
    if dtype == np.uint8:  # Pillow reduces 16-bit RGB to 8 bits; libpng above reads those exactly
        np.testing.assert_array_equal(np.asarray(decoded), image)
    else:
        decoded.load()  # still decodes it whole: every CRC and the Adler-32 checked


def test_encoders_round_trip(tmp_path):
    import OpenEXR
    import tifffile

    from spectral_cam.isp.pipeline import DevelopedImage

    y, x = np.mgrid[0:24, 0:32].astype(np.float32)
    linear = np.stack([x / 31, y / 23, 0.5 + 0.5 * np.sin(x / 5)], -1).astype(np.float32) * 1.2
    display = srgb_oetf(linear)
    developed = DevelopedImage(display, linear)
    files = write_outputs(developed, tmp_path, ("png", "png16", "jpeg", "tiff", "exr"), stem="img")
    assert [f.name for f in files] == ["img.png", "img.16bit.png", "img.jpg", "img.tif", "img.exr"]
    png8 = cv2.imread(str(files[0]), cv2.IMREAD_UNCHANGED)[..., ::-1]
    np.testing.assert_array_equal(png8, quantise(display, bits=8))
    png16 = cv2.imread(str(files[1]), cv2.IMREAD_UNCHANGED)[..., ::-1]
    assert png16.dtype == np.uint16
    np.testing.assert_array_equal(png16, quantise(display, bits=16))
    np.testing.assert_array_equal(tifffile.imread(files[3]), quantise(display, bits=16))
    jpeg = cv2.imread(str(files[2]))[..., ::-1]
    assert psnr(jpeg.astype(float), quantise(display, bits=8).astype(float), data_range=255) > 30
    with OpenEXR.File(str(files[4]), separate_channels=True) as exr:
        channels = exr.channels()
        back = np.stack([channels[c].pixels for c in "RGB"], -1)
    np.testing.assert_array_equal(back, linear)  # linear and unclipped (values > 1 kept)
    assert not [p for p in tmp_path.iterdir() if ".partial-" in p.name]
    with pytest.raises(ConfigError, match="exr"):
        write_image(developed, tmp_path / "x.bmp")


# ----------------------------------------------------------------------------- pipeline
def test_develop_flat_grey_target_with_dng_matrix_is_neutral():
    """A grey target seen through a camera whose XYZ → camera matrix is C: with the DNG
    transform the developed colour must be the D65 grey, R = G = B."""
    cm = np.array([[0.9, 0.2, -0.1], [-0.3, 1.2, 0.1], [0.05, -0.2, 0.9]])
    d65 = np.array([0.95047, 1.0, 1.08883])
    neutral = cm @ d65
    neutral = neutral / neutral.max()
    dn = np.rint(256 + 0.5 * neutral * (4095 - 256))
    raw = RawImage(sample_cfa(np.broadcast_to(dn, (16, 20, 3)).copy(), "GBRG").astype(np.uint16), "GBRG", 256, 4095,
                   color_matrix=cm, as_shot_neutral=neutral)
    out = develop(raw, ISPConfig(colour_matrix="dng", tone="linear"))
    np.testing.assert_allclose(out.linear, 0.5, atol=2e-3)
    stages = ["normalise", "denoise", "shading", "white_balance", "demosaic", "highlights", "colour", "tone", "sharpen"]
    assert list(out.timings_s) == stages and out.total_s > 0
    display = develop(raw, ISPConfig(colour_matrix="dng", tone="srgb")).image
    np.testing.assert_allclose(display, srgb_oetf(np.float32(0.5)), atol=2e-3)


def test_develop_errors_and_monochrome():
    raw = RawImage(np.full((8, 8), 1000, np.uint16), "RGGB", 256, 4095)
    with pytest.raises(ConfigError, match="camera_to_xyz"):
        develop(raw, ISPConfig(colour_matrix="fitted", white_balance="grey_world"))
    with pytest.raises(ConfigError, match="AsShotNeutral"):
        develop(raw)
    mono = develop(RawImage(np.full((9, 7), 2175, np.uint16), "none", 256, 4095), ISPConfig(tone="linear"))
    np.testing.assert_allclose(mono.linear, (2175 - 256) / (4095 - 256), rtol=1e-6)


def test_fitted_and_root_polynomial_transforms_from_raw_meta():
    """The RAW's meta can carry the camera → XYZ(D65) transform: a (3, 3) matrix for
    "fitted"/"auto", a (3, N) root-polynomial matrix for "root_polynomial". Reference:
    colour-science's own XYZ → sRGB conversion of M·rgb."""
    import colour

    rng = np.random.default_rng(10)
    camera = cv2.GaussianBlur(rng.uniform(0.1, 0.6, (24, 30, 3)).astype(np.float32), (0, 0), 3.0)
    dn = np.rint(256 + camera * (4095 - 256))
    mosaic = sample_cfa(dn, "BGGR").astype(np.uint16)
    matrix = np.array([[0.6, 0.25, 0.12], [0.26, 0.9, -0.16], [0.07, -0.37, 1.39]])
    raw = RawImage(mosaic, "BGGR", 256, 4095, as_shot_neutral=np.ones(3), meta={
        "camera_to_xyz_d65": matrix,
        "camera_to_xyz_d65_root_polynomial": np.hstack([matrix, np.zeros((3, 3))]),
    })
    normalised = ((mosaic.astype(np.float64) - 256) / (4095 - 256)).astype(np.float32)
    balanced = demosaic(normalised, "BGGR", method="bilinear")
    reference = colour.XYZ_to_RGB(balanced.astype(float) @ matrix.T, colour.models.RGB_COLOURSPACE_sRGB)
    for method in ("auto", "fitted", "root_polynomial"):
        out = develop(raw, ISPConfig(colour_matrix=method, demosaic="bilinear", tone="linear"))
        assert out.meta["colour_transform"] == ("fitted" if method == "auto" else method)
        np.testing.assert_allclose(out.linear, reference, atol=2e-5)


@pytest.mark.parametrize("method", ["grey_world", "white_patch"])
def test_automatic_white_balance_ignores_blown_pixels_that_read_just_under_white(method):
    # a tungsten-like neutral (true gains 2.222, 1, 1.667), 30 % of the frame clipped at full
    # well before read noise, so blown pixels scatter just below 1.0 (K = 0.27 DN/e⁻, σ_read 3 e⁻)
    from spectral_cam.isp.white_balance import white_balance_gains

    rng = np.random.default_rng(3)
    neutral = np.array([0.45, 1.0, 0.6])
    height, width = 120, 160
    index = np.zeros((height, width), int)
    index[0::2, 1::2] = index[1::2, 0::2] = 1
    index[1::2, 1::2] = 2
    level = np.where(np.arange(width)[None, :] < 0.7 * width, 0.5, 4.0)  # right 30 %: far over white
    mosaic = np.minimum(level * neutral[index], 1.0)
    mosaic = mosaic + rng.normal(0.0, 3.0 * 0.27 / 4031, mosaic.shape)
    gains = white_balance_gains(mosaic.astype(np.float32), "RGGB", method=method)
    assert gains == pytest.approx([1 / 0.45, 1.0, 1 / 0.6], rel=0.02)
