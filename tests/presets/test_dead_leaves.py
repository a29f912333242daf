"""Issue 15 #2: the dead_leaves preset against the model's own formulas (radius law, coverage,
1/f² spectrum) and its depth labels against the layout's geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spectral_cam import render
from spectral_cam.errors import ConfigError
from spectral_cam.optics import ThinLens
from spectral_cam.presets.dead_leaves import dead_leaves_layout, expected_coverage, radius_cdf

pytestmark = pytest.mark.timeout(300)


def _config(make_scene, **scene):
    return make_scene(scene={"preset": "dead_leaves", "depths_m": [1.0, 4.0], **scene},
                      sensor={"width_px": 128, "height_px": 96}, lens={"model": "pinhole"},
                      render={"spp": 4, "max_depth": 1})


def test_radii_follow_the_r_minus_3_law(make_scene):
    """Kolmogorov–Smirnov against F(r) = (r_min⁻² − r⁻²)/(r_min⁻² − r_max⁻²): D below the 1 %
    critical value 1.63/√n."""
    config = _config(make_scene, leaf_radius_px=[2.0, 60.0], leaf_coverage=0.999)
    lens = ThinLens.from_config(config.lens, config.sensor)
    layout = dead_leaves_layout(config, lens, ("a", "b"))
    radii = np.sort(layout.radius_px)
    n = len(radii)
    cdf = radius_cdf(radii, 2.0, 60.0)
    d = max(np.max(np.arange(1, n + 1) / n - cdf), np.max(cdf - np.arange(n) / n))
    assert n > 1000 and d < 1.63 / math.sqrt(n), (n, d)
    depths = np.log(layout.depth_m)  # log-uniform over 1–4 m, farthest first
    assert np.all(np.diff(layout.depth_m) <= 0) and depths.min() >= 0 and depths.max() <= math.log(4.0)
    assert abs(depths.mean() - math.log(4.0) / 2) < 4 * math.log(4.0) / math.sqrt(12 * n)


def _raster(layout, h, w):
    """Depth of the nearest disc at each pixel centre (the backdrop's where none), and the
    pixels whose centre lies more than 1 px from every disc edge."""
    rows, columns = np.mgrid[0:h, 0:w] + 0.5
    depth = np.full((h, w), layout.backdrop_depth_m)
    clear = np.ones((h, w), bool)
    for c, r, radius, z in zip(layout.column_px, layout.row_px, layout.radius_px, layout.depth_m):  # far → near
        distance = np.hypot(columns - c, rows - r)
        depth = np.where(distance < radius, z, depth)
        clear &= np.abs(distance - radius) > 1.0
    return depth, clear


def test_depth_labels_match_the_layout_geometry(make_scene):
    """The rendered depth label is the layout's geometry: each pixel whose centre lies clear of
    every disc edge (> 1 px) has the depth of the nearest disc covering it (or the backdrop's)."""
    config = _config(make_scene, leaf_radius_px=[3.0, 40.0], leaf_coverage=0.8, leaf_seed=3)
    image = render(config)
    lens = ThinLens.from_config(config.lens, config.sensor)
    layout = dead_leaves_layout(config, lens, ("x",) * 99)
    expected, clear = _raster(layout, *image.depth_m.shape)
    assert clear.mean() > 0.5
    np.testing.assert_allclose(image.depth_m[clear], expected[clear], rtol=1e-4)


def test_coverage_is_the_boolean_models(make_scene):
    """Over 30 layouts the covered fraction averages the Boolean model's 1 − exp(−N·ā/A)
    (ā = π·C·ln(r_max/r_min)) within 3 standard errors; one layout's spread is ~0.07 here
    (a few large discs dominate)."""
    covered, model = [], None
    for seed in range(30):
        config = _config(make_scene, leaf_radius_px=[3.0, 40.0], leaf_coverage=0.8, leaf_seed=seed)
        lens = ThinLens.from_config(config.lens, config.sensor)
        layout = dead_leaves_layout(config, lens, ("x",))
        depth, _ = _raster(layout, lens.height_px, lens.width_px)
        covered.append(float((depth < layout.backdrop_depth_m).mean()))
        domain = layout.domain_px
        model = expected_coverage(len(layout), 3.0, 40.0, (domain[2] - domain[0]) * (domain[3] - domain[1]))
    assert model == pytest.approx(0.8, abs=0.01)
    covered = np.array(covered)
    assert abs(covered.mean() - model) < 3 * covered.std(ddof=1) / math.sqrt(len(covered)), (covered.mean(), model)


def test_the_all_in_focus_image_has_a_one_over_f_squared_spectrum(make_scene):
    """The radially averaged power spectrum of the rendered luminance falls as 1/f^α with
    α ≈ 2 between 1/r_max and 1/r_min (Gousseau & Roueff 2007; a finite layout measures
    1.7–2.2): the fitted α lies in [1.6, 2.4]."""
    config = _config(make_scene, leaf_radius_px=[2.0, 100.0], leaf_coverage=0.99).replace(
        **{"sensor.width_px": 256, "sensor.height_px": 256, "render.spp": 4})
    image = render(config, with_depth=False)
    luminance = image.data.sum(axis=-1)
    luminance = luminance - luminance.mean()
    power = np.abs(np.fft.fftshift(np.fft.fft2(luminance * np.outer(np.hanning(256), np.hanning(256))))) ** 2
    fy, fx = np.mgrid[-128:128, -128:128]
    radius = np.hypot(fx, fy).astype(int)
    band = np.arange(4, 33)  # well inside 1/r_max … 1/r_min: periods 64 to 8 px, radii 100 to 2 px
    spectrum = np.array([power[radius == f].mean() for f in band])
    alpha = -np.polyfit(np.log(band), np.log(spectrum), 1)[0]
    print(f"fitted alpha = {alpha:.2f}")
    assert 1.6 <= alpha <= 2.4, alpha


def test_a_coverage_that_needs_too_many_discs_is_refused_with_the_remedy(make_scene):
    config = _config(make_scene, leaf_radius_px=[0.5, 2000.0], leaf_coverage=0.9999)
    with pytest.raises(ConfigError, match="raise the smallest radius"):
        render(config)


def test_every_dataset_label_of_a_defocused_dead_leaves_scene(make_scene, tmp_path):
    """Through the thin lens at f/1.4 focused at 2 m: every label is written, and the defocus
    label is the thin-lens CoC of the depth label (A·f·(z − z_f)/(z·(z_f − f)) per pixel pitch)."""
    from spectral_cam.apps.dataset.labels import LABELS, write_item
    from spectral_cam.spectral_exr import read_depth_exr

    config = make_scene(scene={"preset": "dead_leaves", "depths_m": [1.0, 4.0], "leaf_radius_px": [3.0, 30.0]},
                        sensor={"width_px": 64, "height_px": 48}, render={"spp": 4},
                        lens={"model": "thin", "f_number": 1.4, "focus_distance_m": 2.0})
    meta = write_item(config, tmp_path / "item", outputs=list(LABELS), dataset={"id": "leaves"})
    assert {"raw.dng", "image.png", "depth.exr", "defocus.exr", "clean_rgb.exr", "all_in_focus.png"} <= set(meta["files"])
    import OpenEXR

    with OpenEXR.File(str(tmp_path / "item" / "defocus.exr"), separate_channels=True) as exr:
        coc = np.array(exr.channels()["CoC"].pixels)
    z = read_depth_exr(tmp_path / "item" / "depth.exr").astype(float)
    lens = ThinLens.from_config(config.lens, config.sensor)
    f, z_f = lens.focal_length_m, lens.focus_distance_m
    expected = 2 * lens.aperture_radius_m * f * (z - z_f) / (z * (z_f - f)) / lens.pixel_pitch_m
    np.testing.assert_allclose(coc, expected, rtol=1e-4, atol=1e-6)


def test_disc_polygons_keep_each_discs_area_and_outline():
    """Each disc is a regular polygon of its own area (πr², so the Boolean model's coverage is
    unchanged) whose edge stays within POLYGON_TOLERANCE_PX of the circle, facing the camera."""
    from spectral_cam.presets.dead_leaves import POLYGON_TOLERANCE_PX, disc_polygons

    radius = np.array([1.0, 3.0, 40.0, 120.0])
    pixel = 1e-3  # metres per pixel per metre of depth
    depth = np.array([1.0, 2.0, 3.0, 4.0])
    vertices, faces = disc_polygons(np.array([10.0, 20.0, 30.0, 40.0]), np.array([5.0, 6.0, 7.0, 8.0]), radius, depth,
                                    64, 48, pixel)
    v = vertices.astype(np.float64)
    a, b, c = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    normal = np.cross(b - a, c - a)
    assert np.all(normal[:, 2] < 0)  # towards the camera at the origin (area emitters are one-sided)
    owner = faces[:, 0]  # the fan's centre is the disc's own vertex
    area_px = np.bincount(owner, weights=0.5 * np.linalg.norm(normal, axis=1)) / (pixel * depth) ** 2
    np.testing.assert_allclose(area_px, np.pi * radius ** 2, rtol=1e-5)
    for disc in range(len(radius)):  # the polygon lies between its inscribed circle and circumcircle
        rim = c[owner == disc][:, :2] / (pixel * depth[disc])
        centre = a[owner == disc][0, :2] / (pixel * depth[disc])
        circumradius = np.linalg.norm(rim - centre, axis=1)
        sides = len(rim)
        inradius = circumradius * np.cos(np.pi / sides)
        assert np.all(circumradius - radius[disc] <= POLYGON_TOLERANCE_PX + 1e-4)
        assert np.all(radius[disc] - inradius <= POLYGON_TOLERANCE_PX + 1e-4)
