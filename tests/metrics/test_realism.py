"""Issue 23 #4: the natural-image statistics, against colour-science and analytic cases, and the
bundled scenes against real photographs (scikit-image's sample photographs) measured the same way."""

from __future__ import annotations

import colour
import numpy as np
import pytest
import skimage.data

import spectral_cam as sc
from spectral_cam.job import simulate
from spectral_cam.metrics.realism import (clipped_share, colourfulness, firefly_share, flat_share, median_lightness,
                                          spectrum_slope)

pytestmark = pytest.mark.timeout(240)

PHOTOGRAPHS = ("astronaut", "coffee", "chelsea", "rocket")


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


@pytest.mark.parametrize("name", ["colorchecker", "tabletop", "vegetation"])
def test_bundled_scenes_look_like_photographs(name):
    """At a quarter of their pixels (16 spp), the bundled scenes' median L* lies inside the range of
    scikit-image's sample photographs (± 2 for the smaller frame and fewer samples), with at
    most 1 % of pixels clipped."""
    photographs = [median_lightness(getattr(skimage.data, p)()) for p in PHOTOGRAPHS]
    config = sc.load_scene(f"scenes/{name}.toml", overrides={"sensor.width_px": 240, "sensor.height_px": 160,
                                                            "render.spp": 16})
    display = np.round(simulate(config, with_depth=False).developed.image * 255).astype(np.uint8)
    assert min(photographs) - 2 <= median_lightness(display) <= max(photographs) + 2
    assert clipped_share(display) <= 0.01
