"""Issue 16 #3–4: aperture blades and Brown–Conrady distortion of the thin-lens plugin, against
geometry: a defocused point images as a regular n-gon of the blades' orientation, brightness
scales with the opening's area, and rendered grid points land where the distortion formula
(OpenCV's) puts them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spectral_cam.optics import ThinLens

pytestmark = pytest.mark.timeout(300)


def _render(lens, objects, spp=256, **plugin):
    import mitsuba as mi

    from spectral_cam.render import choose_variant
    from spectral_cam.render.scene_dict import camera_dict

    mi.set_variant(choose_variant("auto"))
    film = {"type": "specfilm", "width": lens.width_px, "height": lens.height_px, "rfilter": {"type": "box"},
            "band": {"type": "spectrum", "value": [(540.0, 1.0), (560.0, 1.0)]}}
    camera = camera_dict(mi, lens, "spectral_thin", film, spp, "independent", glass="ideal", **plugin)
    scene = mi.load_dict({"type": "scene", "integrator": {"type": "path", "max_depth": 1}, "sensor": camera,
                          **objects(mi)})
    return np.asarray(mi.render(scene, spp=spp), dtype=np.float64)[..., 0]


def _dots(points, radius_m):
    def objects(mi):
        return {f"dot_{i}": {"type": "disk", "emitter": {"type": "area", "radiance": {"type": "uniform", "value": 1.0}},
                             "to_world": mi.ScalarTransform4f().translate([float(c) for c in p]).rotate([0, 1, 0], 180.0)
                             .scale(radius_m)} for i, p in enumerate(points)}
    return objects


def _lens(size=128, focal=0.025, f_number=2.0, focus=1.0, pitch=6e-6):
    return ThinLens(focal_length_m=focal, f_number=f_number, focus_distance_m=focus, sensor_width_m=size * pitch,
                    sensor_height_m=size * pitch, width_px=size, height_px=size)


def _spot_boundary(image):
    """A defocused spot (smoothed, above half its bright level) and the Fourier magnitudes of its
    boundary: along 360 directions from its centroid, the last radius still inside it."""
    from scipy import ndimage

    image = ndimage.gaussian_filter(image, 1.0)
    spot = image > 0.5 * np.percentile(image[image > 0.05 * image.max()], 75)
    rows, cols = np.nonzero(spot)
    cy, cx = rows.mean() + 0.5, cols.mean() + 0.5
    theta = np.radians(np.arange(360))[:, None]
    steps = np.arange(0.0, 60.0, 0.25)[None, :]
    inside = spot[np.clip((cy + steps * np.sin(theta)).astype(int), 0, spot.shape[0] - 1),
                  np.clip((cx + steps * np.cos(theta)).astype(int), 0, spot.shape[1] - 1)]
    profile = steps[0, np.argmin(np.cumprod(inside, axis=1), axis=1) - 1]
    return spot, np.abs(np.fft.rfft(profile - profile.mean()))


@pytest.mark.parametrize("blades, rotation, depth, vertex_up", [(5, 0.0, 3.0, True), (5, 0.0, 0.6, False),
                                                               (6, 30.0, 3.0, None), (7, 0.0, 3.0, True)])
def test_a_defocused_point_images_as_the_blades_regular_polygon(blades, rotation, depth, vertex_up):
    """A small source off focus (1 m) through n blades: the spot's boundary radius against angle
    has its strongest harmonic at n (a regular n-gon). With a vertex at the top of the opening
    (rotation 0), the spot of a source behind focus has its vertex up in the image — its
    centroid lies below its bounding box's middle (0.0955·R for a sharp pentagon of
    circumradius R) — and one in front of focus is flipped (rays cross before the sensor)."""
    spot, harmonics = _spot_boundary(_render(_lens(), _dots([(0.0, 0.0, depth)], 0.0005 * depth), blades=blades,
                                             blade_rotation_deg=rotation))
    rows, _ = np.nonzero(spot)
    cy = rows.mean() + 0.5
    assert np.argmax(harmonics[1:12]) + 1 == blades
    if vertex_up is not None:
        middle = (rows.min() + rows.max() + 1) / 2
        offset = (cy - middle) / (0.5 * (rows.max() + 1 - rows.min()))  # + : centroid below the middle
        assert (offset > 0.02) == vertex_up and (offset < -0.02) == (not vertex_up), offset


@pytest.mark.parametrize("blades", [3, 5, 8])
def test_brightness_scales_with_the_openings_area(blades):
    """A uniform wall: n blades inscribed in the f/2 circle pass (n/2π)·sin(2π/n) of the round
    opening's light (0.41, 0.76, 0.90) — within 1 %."""
    def wall(mi):
        return {"wall": {"type": "rectangle", "emitter": {"type": "area", "radiance": {"type": "uniform", "value": 1.0}},
                         "to_world": mi.ScalarTransform4f().translate([0, 0, 2.0]).rotate([0, 1, 0], 180.0).scale(10.0)}}

    lens = _lens(size=32)
    ratio = _render(lens, wall, spp=64, blades=blades).mean() / _render(lens, wall, spp=64).mean()
    assert ratio == pytest.approx(blades / (2 * math.pi) * math.sin(2 * math.pi / blades), rel=0.01)


def _brown_conrady(x, y, k1, k2, p1, p2, k3):
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2 ** 2 + k3 * r2 ** 3
    return (x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x), y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y)


def test_rendered_grid_points_land_where_brown_conrady_puts_them():
    """A 5 × 5 grid of small sources on a plane in focus (wide 1 mm lens, 0.38 of the focal
    length to the frame's edge), k = (−0.3, 0.05, 0.002, −0.003, 0): each source's centroid lies
    within 0.1 px of the formula's distorted position, x_d = x_u(1 + k₁r² + …) + tangential
    terms, in OpenCV's axes (x to the image's right, y down)."""
    size, pitch, focal, depth = 128, 6e-6, 1e-3, 2.0
    lens = _lens(size=size, focal=focal, f_number=16.0, focus=depth, pitch=pitch)
    scale = lens.image_distance_m / pitch  # pixels per unit of X/Z
    coefficients = (-0.3, 0.05, 0.002, -0.003, 0.0)
    grid = np.linspace(-0.7, 0.7, 5) * (size / 2) / scale  # undistorted x_u = X/Z
    points = [(-xu * depth, -yu * depth, depth) for yu in grid for xu in grid]  # camera x = −x_u, y = −y_u
    image = _render(lens, _dots(points, 1.5 / scale * depth), spp=256, distortion=coefficients)  # 1.5 px dots
    from scipy import ndimage

    labels, count = ndimage.label(image > 0.05 * image.max())
    centroids = np.array(ndimage.center_of_mass(image, labels, range(1, count + 1))) + 0.5  # (row, col)
    assert count == 25
    for yu in grid:
        for xu in grid:
            xd, yd = _brown_conrady(xu, yu, *coefficients)
            expected = np.array([size / 2 + yd * scale, size / 2 + xd * scale])
            nearest = centroids[np.argmin(np.linalg.norm(centroids - expected, axis=1))]
            assert np.linalg.norm(nearest - expected) < 0.1, (xu, yu, nearest, expected)
    # the dataset's undistortion map takes the image back to the ideal pinhole's: cv2.remap puts
    # each source where x_u = X/Z says, within 0.15 px (bilinear resampling of 3-px dots)
    import cv2

    from spectral_cam.optics.distortion import undistortion_map

    map_x, map_y = undistortion_map(lens, coefficients)
    straight = cv2.remap(image.astype(np.float32), map_x, map_y, cv2.INTER_LINEAR)
    labels, count = ndimage.label(straight > 0.05 * straight.max())
    centroids = np.array(ndimage.center_of_mass(straight, labels, range(1, count + 1))) + 0.5
    assert count == 25
    for yu in grid:
        for xu in grid:
            expected = np.array([size / 2 + yu * scale, size / 2 + xu * scale])
            assert np.min(np.linalg.norm(centroids - expected, axis=1)) < 0.15


def test_a_dataset_item_carries_its_undistortion_map(tmp_path):
    """The ``undistortion`` label: undistortion.exr whose maps are the Brown–Conrady forward
    model of each undistorted pixel (checked at a corner against the formula), and its record;
    an item with blades, distortion and motion also writes its all-in-focus image (the ideal
    pinhole: none of the three)."""
    import json

    import OpenEXR

    from spectral_cam.apps.dataset import generate_dataset, load_spec
    from spectral_cam.optics.distortion import distort

    spec = tmp_path / "spec.toml"
    spec.write_text('[dataset]\noutputs = ["raw", "undistortion", "all_in_focus"]\n[scene]\npreset = "dof_targets"\n'
                    '[lens]\nmodel = "spectral_thin"\nglass = "ideal"\nfocal_length_mm = 2.0\n'
                    'distortion = [-0.2, 0.0, 0.0, 0.0, 0.0]\nblades = 6\n'
                    '[exposure]\ntime_s = 0.01\n[motion]\ncamera_velocity_mps = [0.1, 0.0, 0.0]\n'
                    '[sensor]\nwidth_px = 32\nheight_px = 24\n[render]\nspp = 4\n')
    summary = generate_dataset(load_spec(spec), tmp_path / "out", n=1, scheduler="inline", progress=False)
    assert summary.rendered == 1
    item = next((tmp_path / "out").glob("items/*/undistortion.exr")).parent
    meta = json.loads((item / "meta.json").read_text())
    assert meta["undistortion"]["coefficients"] == [-0.2, 0.0, 0.0, 0.0, 0.0]
    assert (item / "all_in_focus.png").is_file() and meta["all_in_focus"]["lens_model"] == "pinhole"
    with OpenEXR.File(str(item / "undistortion.exr")) as exr:
        map_x = np.asarray(exr.channels()["map_x"].pixels)
    lens_table = meta["config"]["lens"]
    lens = ThinLens(focal_length_m=lens_table["focal_length_mm"] * 1e-3, f_number=lens_table["f_number"],
                    focus_distance_m=lens_table["focus_distance_m"], sensor_width_m=32 * 6e-6,
                    sensor_height_m=24 * 6e-6, width_px=32, height_px=24)
    scale = 6e-6 / lens.image_distance_m
    x0 = (0.5 - 16) * scale
    y0 = (0.5 - 12) * scale
    assert map_x[0, 0] == pytest.approx(distort(x0, y0, (-0.2, 0, 0, 0, 0))[0] / scale + 16 - 0.5, abs=1e-3)


@pytest.mark.parametrize("rounding", [0.0, 0.5, 1.0])
def test_rounded_blades_pass_their_openings_area(rounding):
    """Five blades rounded by ρ: the opening's area ½∫r(φ)²dφ with r = (1 − ρ)·r_gon + ρ (computed
    here by quadrature of the polygon's own boundary, cos(π/n)/cos(φ − sector middle)) sets the
    brightness of a uniform wall within 1 %: the pentagon's 0.757 at ρ = 0, the circle at ρ = 1."""
    def wall(mi):
        return {"wall": {"type": "rectangle", "emitter": {"type": "area", "radiance": {"type": "uniform", "value": 1.0}},
                         "to_world": mi.ScalarTransform4f().translate([0, 0, 2.0]).rotate([0, 1, 0], 180.0).scale(10.0)}}

    phi = np.linspace(0.0, 2 * math.pi, 200001)[:-1]
    sector = 2 * math.pi / 5
    polygon = math.cos(math.pi / 5) / np.cos(np.mod(phi, sector) - sector / 2)
    area_ratio = float(np.mean(((1 - rounding) * polygon + rounding) ** 2))
    lens = _lens(size=32)
    ratio = (_render(lens, wall, spp=64, blades=5, blade_rounding=rounding).mean()
             / _render(lens, wall, spp=64).mean())
    assert ratio == pytest.approx(area_ratio, rel=0.01)
    if rounding == 0.0:
        assert area_ratio == pytest.approx(5 / (2 * math.pi) * math.sin(2 * math.pi / 5), rel=1e-6)
    if rounding == 1.0:
        assert area_ratio == pytest.approx(1.0)


def test_rounded_blades_soften_the_polygon():
    """A defocused point through six blades: the 6-fold harmonic of the spot's boundary drops as
    the blades round (ρ = 0.7 keeps less than half of the straight blades' one)."""
    def harmonic(rounding):
        return _spot_boundary(_render(_lens(), _dots([(0.0, 0.0, 3.0)], 0.0015), blades=6,
                                      blade_rounding=rounding))[1][6]

    assert harmonic(0.7) < 0.5 * harmonic(0.0)
