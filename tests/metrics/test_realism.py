"""Issue 23 #4 and issue 37 #8: the natural-image statistics, against colour-science and analytic
cases, and the bundled scenes against real photographs (scikit-image's sample photographs)
measured the same way."""

from __future__ import annotations

import colour
import numpy as np
import pytest
import skimage.data

import spectral_cam as sc
from spectral_cam.job import simulate
from spectral_cam.metrics.realism import (PHOTOGRAPHS, clipped_share, colourfulness, dark_channel, dark_channel_p25,
                                          detail_gradient_p95, firefly_share, flat_share, image_statistics,
                                          median_lightness, reference_photographs, resample_short_side,
                                          spectrum_slope)

pytestmark = pytest.mark.timeout(240)

SKIMAGE_PHOTOGRAPHS = ("astronaut", "coffee", "chelsea", "rocket")


def test_median_lightness_is_colour_sciences_cie_lab():
    image = skimage.data.coffee()
    xyz = colour.sRGB_to_XYZ(image / 255.0)
    lab = colour.XYZ_to_Lab(xyz, colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])
    assert median_lightness(image) == pytest.approx(float(np.median(lab[..., 0])), abs=0.3)


def test_a_brownian_field_has_the_power_spectrum_slope_of_natural_images():
    """Noise shaped to amplitude 1/f has power ∝ f⁻² (van der Schaaf & van Hateren 1996)."""
    rng = np.random.default_rng(0)
    f = np.hypot(*np.meshgrid(np.fft.fftfreq(256), np.fft.fftfreq(256), indexing="ij"))
    field = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal((256, 256))) / np.maximum(f, 1 / 256)))
    field = 0.5 + 0.15 * field / field.std()
    assert spectrum_slope(np.repeat(field[..., None], 3, axis=-1)) == pytest.approx(-2.0, abs=0.25)


def test_flat_grey_and_saturated_images_read_as_they_are():
    grey = np.full((64, 64, 3), 118, np.uint8)
    assert colourfulness(grey) == 0.0 and flat_share(grey) == 1.0 and clipped_share(grey) == 0.0
    assert median_lightness(grey) == pytest.approx(49.6, abs=0.1)  # 118/255 is L* ≈ 50: the SOS grey
    red = np.zeros((8, 8, 3), np.uint8)
    red[..., 0] = 255
    # Hasler & Süsstrunk: no spread, mean opponent (rg, yb) = (255, 127.5)
    assert clipped_share(red) == 1.0 and colourfulness(red) == pytest.approx(0.3 * np.hypot(255, 127.5))


def test_a_lone_bright_pixel_is_a_firefly_and_dark_noise_and_corners_are_not():
    rng = np.random.default_rng(2)
    frame = np.full((50, 50), 1.0) + 0.01 * rng.standard_normal((50, 50))
    frame[:10] = np.abs(0.001 * rng.standard_normal((10, 50)))  # dark and noisy: far above its median
    frame[30, 30] = 20.0
    frame[40:, 40:] = 30.0  # a bright lamp in a corner: its corner pixel's 5×5 median is dark, not a firefly
    assert firefly_share(frame) == pytest.approx(1 / 2500)


def _grey_with_lightness(lstar: np.ndarray) -> np.ndarray:
    """Float display sRGB (grey) whose CIE L* is ``lstar``: L* → Y (colour-science, CIE 1976)
    → sRGB encoding (colour-science's IEC 61966-2-1 CCTF)."""
    y = colour.colorimetry.luminance_CIE1976(lstar) / 100.0
    return np.repeat(colour.cctf_encoding(y, function="sRGB")[..., None], 3, axis=-1)


@pytest.mark.parametrize("slope", [(0.2, 0.0), (0.0, 0.35), (0.12, 0.16)])
def test_the_detail_of_a_linear_lightness_ramp_is_its_slope(slope):
    """A Gaussian blur leaves a linear function as it is and central differences are exact on it:
    the gradient magnitude of L* = 20 + a·x + b·y is √(a² + b²) L* per pixel away from the border."""
    a, b = slope
    y, x = np.mgrid[0:160, 0:240].astype(float)
    image = _grey_with_lightness(20 + a * x + b * y)
    assert detail_gradient_p95(image) == pytest.approx(np.hypot(a, b), rel=1e-6)


def test_detail_is_zero_on_a_flat_field_and_grows_with_contrast():
    """A flat field has no gradient. An L* sine of amplitude A and period P, blurred by a Gaussian of
    σ = 1 px (transfer exp(−2π²σ²/P²)), has the gradient amplitude 2πA/P·exp(−2π²/P²), times
    sin(2π/P)/(2π/P) for central differences; |cos| exceeds cos(0.05·π/2) over 5 % of a period,
    so that is the p95 of the magnitude as a share of the amplitude."""
    assert detail_gradient_p95(np.full((64, 64, 3), 0.4)) == 0.0
    period, amplitude = 40.0, 10.0
    x = np.arange(400)[None, :].repeat(100, axis=0)
    image = _grey_with_lightness(50 + amplitude * np.sin(2 * np.pi * x / period))
    peak = 2 * np.pi * amplitude / period * np.exp(-2 * np.pi ** 2 / period ** 2)
    central = np.sin(2 * np.pi / period) / (2 * np.pi / period)  # central differences on a sine of period P
    assert detail_gradient_p95(image) == pytest.approx(peak * central * np.cos(np.pi / 2 * 0.05), rel=0.01)


def test_the_dark_channel_of_a_colour_field_is_its_darkest_channel():
    field = np.full((48, 64, 3), (200, 120, 60), np.uint8)
    assert np.all(dark_channel(field) == 60.0) and dark_channel_p25(field) == 60.0
    floating = np.full((48, 64, 3), (0.25, 0.9, 0.5))
    assert dark_channel_p25(floating) == pytest.approx(0.25 * 255)


def test_a_black_square_darkens_the_dark_channel_over_itself_and_seven_pixels_around():
    """He et al.'s 15 × 15 minimum spreads a black square of side s to s + 14 (7 each side), and cuts
    at the frame's edge (a corner square of side s to s + 7)."""
    image = np.full((100, 100, 3), 255, np.uint8)
    image[40:60, 30:50] = 0  # s = 20
    expected = np.full((100, 100), 255.0)
    expected[33:67, 23:57] = 0.0
    np.testing.assert_array_equal(dark_channel(image), expected)
    assert dark_channel_p25(image) == 255.0  # 34² = 11.6 % of the frame: under a quarter

    image = np.full((80, 80, 3), 255, np.uint8)
    image[25:55, 25:55] = 0  # 30² = 14 % of the pixels, but (30 + 14)² = 30 % of the dark channel
    assert np.percentile(image.min(axis=-1), 25) == 255 and dark_channel_p25(image) == 0.0

    corner = np.full((50, 50, 3), 200, np.uint8)
    corner[:10, :10] = 0
    assert int(np.sum(dark_channel(corner) == 0)) == 17 ** 2


def test_resampling_to_a_short_side_keeps_the_mean_and_the_aspect():
    rng = np.random.default_rng(3)
    image = rng.random((640, 960, 3))
    half = resample_short_side(image, 320)
    blocks = image.reshape(320, 2, 480, 2, 3).mean(axis=(1, 3))  # area averaging by 2 is the 2 × 2 mean
    np.testing.assert_allclose(half, blocks, atol=1e-6)
    odd = resample_short_side(image[:427, :640], 320)  # the photographs' 640 × 427
    assert odd.shape == (320, 480, 3) and odd.mean() == pytest.approx(image[:427, :640].mean(), rel=2e-3)
    portrait = resample_short_side(rng.random((600, 512, 3)), 320)
    assert portrait.shape == (375, 320, 3)
    smooth = np.repeat(np.linspace(0.1, 0.9, 451)[None, :, None], 300, axis=0).repeat(3, axis=-1)
    larger = resample_short_side(smooth, 320)  # enlarged (bilinear): a ramp stays a ramp
    assert larger.shape == (320, 481, 3) and larger.mean() == pytest.approx(smooth.mean(), rel=1e-3)
    ours = rng.random((320, 480, 3))
    assert resample_short_side(ours, 320) is ours  # our frames' size: left as they are
    grey = np.full((600, 900, 3), 118, np.uint8)  # 8-bit stays 8-bit and flat stays flat
    small = resample_short_side(grey, 320)
    assert small.dtype == np.uint8 and np.all(small == 118)


def test_image_statistics_measures_after_resampling():
    """At a short side of 320 px the 1-px-scale measures see the resampled pixels: a ramp's detail
    scales with the inverse of the size (here ÷ 2)."""
    x = np.arange(960.0)[None, :].repeat(640, axis=0)
    image = _grey_with_lightness(20 + 0.05 * x)
    full, resampled = image_statistics(image), image_statistics(image, short_side=320)
    assert full["detail"] == pytest.approx(0.05, rel=1e-4)
    assert resampled["detail"] == pytest.approx(0.10, rel=1e-3)
    assert {"median_L", "clipped", "colourfulness", "detail", "dark_p25", "fireflies"} <= set(resampled)


def test_the_reference_photographs_are_photographs_of_ordinary_scenes():
    """Every package's photographs load offline where the package is installed, as 8-bit colour
    images of at least 300 px on the short side; their measures lie in the range the issue
    reports for photographs (detail 4.4–14.6 L*/px, dark channel p25 0–32, colourfulness 36–86)."""
    photographs = reference_photographs()
    assert {"skimage.data.astronaut", "skimage.data.coffee", "skimage.data.chelsea", "skimage.data.rocket",
            "matplotlib grace_hopper.jpg"} <= set(photographs) <= set(PHOTOGRAPHS)
    for name, image in photographs.items():
        assert image.dtype == np.uint8 and image.ndim == 3 and image.shape[2] == 3 and min(image.shape[:2]) >= 300
        stats = image_statistics(image, short_side=320)
        assert 4.0 <= stats["detail"] <= 15.0, name
        assert 0 <= stats["dark_p25"] <= 32, name
        assert 35 <= stats["colourfulness"] <= 87, name


@pytest.mark.parametrize("name", ["colorchecker", "tabletop", "vegetation"])
def test_bundled_scenes_look_like_photographs(name):
    """At a quarter of their pixels (16 spp), the bundled scenes' median L* lies inside the range of
    scikit-image's sample photographs (± 2 for the smaller frame and fewer samples), with at
    most 1 % of pixels clipped."""
    photographs = [median_lightness(getattr(skimage.data, p)()) for p in SKIMAGE_PHOTOGRAPHS]
    config = sc.load_scene(f"scenes/{name}.toml", overrides={"sensor.width_px": 240, "sensor.height_px": 160,
                                                            "render.spp": 16})
    display = np.round(simulate(config, with_depth=False).developed.image * 255).astype(np.uint8)
    assert min(photographs) - 2 <= median_lightness(display) <= max(photographs) + 2
    assert clipped_share(display) <= 0.01
