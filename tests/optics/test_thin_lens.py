"""Thin-lens geometry of the renders against the textbook formulas.

References: the Gaussian lens equation 1/f = 1/z + 1/v and the circle of confusion
c = A·f·|z − z_f| / (z·(z_f − f)), A = f/N (Ray, Applied Photographic Optics, 3rd ed.,
ch. 10). The second moment of a uniform disc of diameter D is E[r²] = D²/8; convolving
with a uniform source disc of radius a adds a²/2, and pixel integration adds 1/12 px² per
axis (variances of independent blurs add).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from spectral_cam import render
from spectral_cam.metrics.blur import disc_diameter_from_moments, second_moment

FOCAL_M, F_NUMBER, FOCUS_M, PITCH_M, SIZE_PX = 0.05, 2.0, 2.0, 10e-6, 64


def coc_px(depth_m: float) -> float:
    aperture = FOCAL_M / F_NUMBER
    return aperture * FOCAL_M * abs(depth_m - FOCUS_M) / (depth_m * (FOCUS_M - FOCAL_M)) / PITCH_M


def image_distance_m() -> float:
    return 1.0 / (1.0 / FOCAL_M - 1.0 / FOCUS_M)


def source_scene(make_scene, depths, radius_m, model="thin", spp=1024, seed=0, size_px=SIZE_PX):
    return make_scene(
        scene={"preset": "point_sources", "depths_m": list(depths), "source_radius_m": radius_m},
        lens={"focal_length_mm": FOCAL_M * 1e3, "f_number": F_NUMBER, "focus_distance_m": FOCUS_M, "model": model},
        sensor={"width_px": size_px, "height_px": size_px, "pixel_pitch_um": PITCH_M * 1e6},
        # geometry only: diffraction (which "auto" applies at f/2 with 10 µm pixels) is off
        render={"spp": spp, "seed": seed, "max_depth": 2, "diffraction": "off"},
    )


@pytest.mark.timeout(120)
@pytest.mark.parametrize("depth_m", [1.5, 3.0, 5.0])
def test_defocus_blur_matches_circle_of_confusion(make_scene, depth_m):
    source_px = 3.0  # source disc radius in the image, px
    radius_m = source_px * PITCH_M * depth_m / image_distance_m()
    image = render(source_scene(make_scene, [depth_m], radius_m), with_depth=False)
    # a pixel-integrated disc of radius r px has ⟨r²⟩ = r²/2 + 2/12 before the blur
    measured = disc_diameter_from_moments(image.data.sum(axis=-1), source_px ** 2 / 2 + 2 / 12)
    expected = coc_px(depth_m)
    assert measured == pytest.approx(expected, rel=0.02), f"z = {depth_m} m"


@pytest.mark.timeout(120)
def test_pinhole_renders_every_depth_sharp_with_the_same_field_of_view(make_scene):
    depths = [1.5, 2.0, 3.0]  # blur discs of ~21 px fit their windows
    radius_m, size = 1.2e-3, 96  # source images of 2–4 px radius, well sampled
    sharp = render(source_scene(make_scene, depths, radius_m, "pinhole", 256, size_px=size), with_depth=False)
    blurred = render(source_scene(make_scene, depths, radius_m, "thin", 1024, size_px=size), with_depth=False)
    # the preset puts the sources at ±0.6 of the half field (and on axis), whatever the depth
    expected_columns = [size / 2 - 0.6 * size / 2, size / 2, size / 2 + 0.6 * size / 2]
    for depth, column in zip(depths, expected_columns):
        window = slice(int(column) - 16, int(column) + 16)
        source_px = radius_m * image_distance_m() / depth / PITCH_M
        cx, cy, m2 = second_moment(sharp.data[:, window].sum(axis=-1).astype(np.float64))
        cx += window.start
        # sharp: only the source's own image and the pixel box, no defocus
        assert math.sqrt(m2) == pytest.approx(math.sqrt(source_px ** 2 / 2 + 2 / 12), rel=0.05)
        assert (cx, cy) == pytest.approx((column, size / 2), abs=0.1)
        if abs(depth - FOCUS_M) > 0.5:
            bx, by, bm2 = second_moment(blurred.data[:, window].sum(axis=-1).astype(np.float64))
            assert (bx + window.start, by) == pytest.approx((column, size / 2), abs=0.5)
            assert bm2 > 4 * m2  # the thin lens blurs the same source


@pytest.mark.timeout(60)
def test_depth_is_camera_space_z_not_ray_length(make_scene):
    # a wide (≈ 94° diagonal) view of a plane 3 m away: the corner ray is ~1.47× longer
    config = make_scene(
        scene={"preset": "flat_field", "distance_m": 3.0},
        lens={"focal_length_mm": 4.0, "f_number": 4.0, "focus_distance_m": 3.0, "model": "pinhole"},
        sensor={"width_px": 40, "height_px": 30, "pixel_pitch_um": 150.0},
        render={"spp": 1},
    )
    image = render(config)
    assert image.depth_m[0, 0] == pytest.approx(3.0, rel=1e-4)
    assert image.depth_m[-1, -1] == pytest.approx(3.0, rel=1e-4)
    assert np.allclose(image.depth_m, 3.0, rtol=1e-4)


@pytest.mark.timeout(60)
def test_same_seed_identical_different_seed_differs(make_scene):
    def run(seed):
        return render(make_scene(render={"spp": 4, "seed": seed}), with_depth=False).data

    first, again, other = run(7), run(7), run(8)
    assert np.array_equal(first, again)
    assert not np.array_equal(first, other)
    # different noise, same expectation: the frame means agree to Monte-Carlo precision
    assert other.mean() == pytest.approx(first.mean(), rel=0.05)


def test_thin_lens_quantities_follow_the_gaussian_lens_equation():
    from spectral_cam.optics import ThinLens

    lens = ThinLens(FOCAL_M, F_NUMBER, FOCUS_M, 0.036, 0.024, 3600, 2400)
    v = image_distance_m()
    assert lens.image_distance_m == pytest.approx(v)
    assert lens.aperture_radius_m == pytest.approx(FOCAL_M / (2 * F_NUMBER))
    assert lens.working_f_number == pytest.approx(F_NUMBER * v / FOCAL_M)
    assert lens.fov_x_deg == pytest.approx(math.degrees(2 * math.atan(0.018 / v)))
    assert lens.coc_diameter_px(3.0) == pytest.approx(coc_px(3.0) * PITCH_M / 10e-6)


def test_depth_of_field_limits_put_the_circle_of_confusion_at_its_limit():
    from spectral_cam.optics import ThinLens

    lens = ThinLens(FOCAL_M, 5.6, 3.0, 0.036, 0.024, 3600, 2400)
    c = 30e-6  # the classic full-frame acceptable CoC
    near, far = lens.depth_of_field_m(c)
    assert coc_for(lens, near) == pytest.approx(c, rel=1e-9)
    assert coc_for(lens, far) == pytest.approx(c, rel=1e-9)
    hyper = lens.hyperfocal_distance_m(c)
    at_hyper = ThinLens(FOCAL_M, 5.6, hyper, 0.036, 0.024, 3600, 2400)
    assert at_hyper.depth_of_field_m(c)[1] == math.inf  # focused at H, sharp to infinity
    assert at_hyper.depth_of_field_m(c)[0] == pytest.approx(hyper / 2, rel=0.01)  # near limit ≈ H/2


def coc_for(lens, depth):
    """c = A·f·|z − z_f| / (z·(z_f − f)), A = f/N, written out independently of optics/thin_lens.py."""
    f, zf = lens.focal_length_m, lens.focus_distance_m
    return (f / lens.f_number) * f * abs(depth - zf) / (depth * (zf - f))


def test_project_and_unproject_are_inverse():
    from spectral_cam.optics import ThinLens

    lens = ThinLens(FOCAL_M, 2.0, 2.0, 64 * PITCH_M, 48 * PITCH_M, 64, 48)
    column, row = lens.project(0.01, -0.02, 2.5)
    x, y = lens.unproject(column, row, 2.5)
    assert (x, y) == pytest.approx((0.01, -0.02))
    assert lens.project(0.0, 0.0, 7.0) == pytest.approx((32.0, 24.0))  # the axis hits the centre
