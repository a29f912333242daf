"""Blur measurement against known discs: second moments of a uniform disc (⟨r²⟩ = c²/8,
Bracewell 2000 ch. 8) and the disc-OTF fit on textures blurred by known discs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spectral_cam.metrics.blur import (
    disc_diameter_from_moments,
    measure_blur,
    second_moment,
)

pytestmark = pytest.mark.timeout(60)


def _supersampled_disc(size: int, diameter_px: float, ss: int = 16) -> np.ndarray:
    """A uniform disc, area-sampled on the pixel grid (16×16 points per pixel)."""
    offsets = (np.arange(size * ss) + 0.5) / ss - size / 2
    inside = (offsets[:, None] ** 2 + offsets[None, :] ** 2) <= (diameter_px / 2) ** 2
    return inside.reshape(size, ss, size, ss).mean(axis=(1, 3))


@pytest.mark.parametrize("diameter", [4.0, 9.0, 17.0])
def test_second_moment_of_a_disc_is_c_squared_over_8(diameter):
    cx, cy, m2 = second_moment(_supersampled_disc(40, diameter))
    assert (cx, cy) == pytest.approx((20.0, 20.0), abs=1e-9)
    # pixel integration adds the box's own ⟨r²⟩ = 2/12 on average (Bracewell: moments add);
    # sampling a hard edge on the pixel grid leaves an aliasing error of ~0.1 px²
    assert m2 == pytest.approx(diameter ** 2 / 8 + 2 / 12, abs=0.12)


def test_disc_diameter_from_moments_undoes_a_convolution():
    from scipy.signal import fftconvolve

    source = _supersampled_disc(64, 5.0)
    for diameter in (6.0, 12.0):
        kernel = _supersampled_disc(31, diameter)
        blurred = fftconvolve(source, kernel / kernel.sum(), mode="same")
        # the kernel is itself pixel-integrated: its box adds 2/12 px² on top of c²/8; the
        # ~0.1 px² aliasing of the discrete moments is 8·0.1/(2c) ≈ 0.07 px of diameter at 6 px
        measured = disc_diameter_from_moments(blurred, second_moment(source)[2] + 2 / 12)
        assert measured == pytest.approx(diameter, abs=0.07)
    assert disc_diameter_from_moments(source, source) == 0.0


def test_measure_blur_recovers_a_disc_on_supersampled_texture():
    """A smooth texture rendered at 16× and box-averaged (as the renderer integrates pixels),
    blurred by known discs before averaging: the fit recovers the diameters."""
    import cv2

    ss, height, width = 16, 40, 48
    rng = np.random.default_rng(0)
    coarse = rng.uniform(0.1, 0.9, (height // 4 + 2, width // 4 + 2)).astype(np.float32)
    fine = cv2.resize(coarse, ((width // 4 + 2) * 4 * ss, (height // 4 + 2) * 4 * ss),
                      interpolation=cv2.INTER_CUBIC)[:height * ss, :width * ss]

    def down(image):
        return image.reshape(height, ss, width, ss).mean(axis=(1, 3))

    sharp = down(fine)
    mask = np.zeros((height, width), dtype=bool)
    mask[10:-10, 10:-10] = True
    for diameter in (0.0, 2.5, 6.0):
        radius = diameter / 2 * ss
        reach = int(math.ceil(radius)) + 1
        yy, xx = np.mgrid[-reach:reach + 1, -reach:reach + 1]
        kernel = ((xx ** 2 + yy ** 2) <= radius ** 2).astype(np.float32)
        kernel /= kernel.sum()
        blurred = down(cv2.filter2D(fine, -1, kernel, borderType=cv2.BORDER_REFLECT))
        measured = measure_blur(sharp, blurred, mask, max_diameter_px=12.0)
        assert measured == pytest.approx(diameter, abs=0.03 + 0.02 * diameter)
    assert math.isnan(measure_blur(sharp, sharp, np.zeros_like(mask), max_diameter_px=4.0))
