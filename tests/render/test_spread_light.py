"""Issue 37 #5/#7: the light the robust estimator removes is given back, spread
(:func:`spectral_cam.render.robust.spread_removed_light`).

References, independent of the estimator: a normalised Gaussian keeps a sum (mirrored at the
edges, a symmetric kernel's weights still sum to 1 for every source); its peak is E/(2πσ²); the
light of the glass sphere's frame is the expected value the plain mean estimates without bias,
measured by a 16× longer render.
"""

from __future__ import annotations

import numpy as np
import pytest

import spectral_cam as sc

from spectral_cam.render.robust import (SPREAD_PEAK, SPREAD_SCALES_PX, adaptive_median_of_means,
                                        spread_removed_light)

pytestmark = pytest.mark.timeout(120)


def test_every_channels_light_over_the_frame_is_the_means():
    """Fireflies (1 % of the pixels, up to 300× the field) on a textured 3-channel field, some
    in the corners: after the median and the spread, each channel's frame sum is the mean's to
    float32 rounding (a normalised kernel mirrored at the edges keeps the sum)."""
    rng = np.random.default_rng(3)
    field = (0.5 + 0.4 * rng.random((96, 128, 1))) * np.array([1.0, 0.6, 0.3], np.float32)
    passes = np.repeat(field[None], 8, axis=0) * (1 + 0.05 * rng.standard_normal((8, 96, 128, 1)))
    hit = rng.random((96, 128)) < 0.01
    hit[0, 0] = hit[-1, -1] = hit[0, -1] = True
    rows, cols = np.nonzero(hit)
    passes[rng.integers(0, 8, rows.size), rows, cols] *= rng.uniform(20, 300, (rows.size, 1))
    passes = passes.astype(np.float32)
    mean = passes.mean(axis=0)
    estimate, _ = adaptive_median_of_means(passes)
    out = spread_removed_light(mean, estimate)
    assert estimate.sum() < 0.9 * mean.sum()  # the median dropped 15 % of the light
    np.testing.assert_allclose(out.sum(axis=(0, 1), dtype=np.float64), mean.sum(axis=(0, 1), dtype=np.float64),
                               rtol=2e-5)
    assert out.min() >= 0


@pytest.mark.parametrize("energy", [3.0, 40.0, 900.0])
def test_a_spread_peaks_at_most_its_share_of_the_light_around_it_with_the_narrowest_gaussian(energy):
    """One pixel's removed light E on a flat field of level A: the spread's peak, E/(2πσ²) for
    the Gaussian, is at most SPREAD_PEAK·A (+6 % for the discrete kernel's centre weight), and
    the next narrower scale would have exceeded it."""
    level = 2.0
    estimate = np.full((160, 160, 1), level, np.float32)
    mean = estimate.copy()
    mean[80, 80] += energy
    added = spread_removed_light(mean, estimate)[..., 0] - level
    assert added.sum() == pytest.approx(energy, rel=1e-4)
    assert added.max() <= 1.06 * SPREAD_PEAK * level
    sigma = next(s for s in SPREAD_SCALES_PX if energy / (2 * np.pi * s ** 2) <= SPREAD_PEAK * level)
    narrower = [s for s in SPREAD_SCALES_PX if s < sigma]
    if narrower:
        assert energy / (2 * np.pi * narrower[-1] ** 2) > SPREAD_PEAK * level
    assert added.max() == pytest.approx(energy / (2 * np.pi * sigma ** 2), rel=0.06)


def test_passes_that_agree_are_left_alone():
    """Where no pixel took the median, the estimate is returned as it was."""
    estimate = np.random.default_rng(0).random((32, 32, 4)).astype(np.float32)
    assert np.array_equal(spread_removed_light(estimate, estimate), estimate)
    with pytest.raises(ValueError, match="peak"):
        spread_removed_light(estimate, estimate, peak=0)


@pytest.mark.timeout(900)
def test_the_glass_spheres_caustic_light_comes_back():
    """The bundled glass sphere at 160 × 106 px (its view kept), 8 passes of 8 spp: the median
    alone loses the caustic field's rare paths (the frame's luminance 5–9 % below a 1024-spp
    render's, as measured); given back, the frame's light is the mean's and within 2.5 % of the
    long render (its own noise ~1 %), with no more fireflies than the median left."""
    from spectral_cam.metrics.realism import firefly_share

    scene = sc.load_scene("scenes/glass_sphere.toml")
    small = {"sensor.width_px": 160, "sensor.height_px": 106, "sensor.pixel_pitch_um": 3 * scene.sensor.pixel_pitch_um,
             "render.estimator": "mean", "render.bands": "camera", "render.spectral_output": False,
             "render.diffraction": "off"}

    def camera_film(spp, seed):  # (H, W, 6): r, g, b and X, Y, Z
        image = sc.render(scene.replace(**small, **{"render.spp": spp, "render.seed": seed}), with_depth=False)
        return np.asarray(image.data)

    passes = np.stack([camera_film(8, 700 + k) for k in range(8)])
    reference = camera_film(1024, 99)[..., 4]  # the camera film's Y
    mean = passes.mean(axis=0)
    estimate, _ = adaptive_median_of_means(passes)
    out = spread_removed_light(mean, estimate)
    y_ref = reference.mean()
    assert estimate[..., 4].mean() < 0.97 * y_ref  # the median's loss, which the spread undoes
    assert out[..., 4].mean() == pytest.approx(mean[..., 4].mean(), rel=1e-4)
    assert out[..., 4].mean() == pytest.approx(y_ref, rel=0.025)
    assert firefly_share(out[..., 4]) <= firefly_share(estimate[..., 4]) + 1e-4
