"""Issue 16 #2: the prescription camera (a Mitsuba sensor plugin tracing real surfaces) against
the camera equation, the designs' stated f-numbers and its own focus, and through the chain."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.optics.prescription import PRESCRIPTION_NAMES, load_prescription
from spectral_cam.optics import ThinLens

pytestmark = pytest.mark.timeout(300)

WIDTH, PITCH = 64, 20e-6
BAND_NM = (540.0, 560.0)


def _render(name, focus_m, objects, spp=256, width=WIDTH, pitch=PITCH):
    import mitsuba as mi

    from spectral_cam.render import choose_variant
    from spectral_cam.render.scene_dict import camera_dict

    mi.set_variant(choose_variant("auto"))
    design = load_prescription(name)
    lens = ThinLens(focal_length_m=design.focal_length_m(), f_number=design.traced_f_number(), focus_distance_m=focus_m,
                    sensor_width_m=width * pitch, sensor_height_m=width * pitch, width_px=width, height_px=width)
    film = {"type": "specfilm", "width": width, "height": width, "rfilter": {"type": "box"},
            "band": {"type": "spectrum", "value": [(BAND_NM[0], 1.0), (BAND_NM[1], 1.0)]}}
    camera = camera_dict(mi, lens, "prescription", film, spp, "independent", prescription=name)
    scene = mi.load_dict({"type": "scene", "integrator": {"type": "path", "max_depth": 1}, "sensor": camera,
                          **objects(mi)})
    return np.asarray(mi.render(scene, spp=spp), dtype=np.float64)[..., 0], lens, design


@pytest.mark.parametrize("name", PRESCRIPTION_NAMES)
def test_on_axis_irradiance_is_the_camera_equations_at_the_traced_f_number(name):
    """A uniform wall (L = 1) 1 km away, the lens focused on it: the on-axis film value is the
    irradiance πL/(4N²) of a lens obeying the sine condition at its traced f-number, expressed
    in the film's units (× (1 + 4N_w²)/π per nm, which the sensor's camera equation undoes),
    times the change of the exit pupil's solid angle, (r² + d_p²)/(r² + d_b²), from the paraxial
    image plane (where N is defined) to the best-focus plane the sensor stands on (1.036 for the
    aberrated wide angle, whose best focus lies 1.8 mm nearer) — within 2 % (measured < 0.3 %)."""
    def wall(mi):
        return {"wall": {"type": "rectangle", "emitter": {"type": "area", "radiance": {"type": "uniform", "value": 1.0}},
                         "to_world": mi.ScalarTransform4f().translate([0, 0, 1000.0]).rotate([0, 1, 0], 180.0)
                         .scale(5000.0)}}

    image, lens, design = _render(name, 1000.0, wall)
    n = design.traced_f_number()
    measured = image[28:36, 28:36].mean() / (BAND_NM[1] - BAND_NM[0])
    pupil_distance, pupil_radius = design.exit_pupil()
    object_to_vertex = 1000.0 - design.entrance_pupil()[0]
    paraxial = design.image_distance_m(object_to_vertex) + pupil_distance
    best = design.focus_image_distance_m(object_to_vertex) + pupil_distance
    nearer = (pupil_radius ** 2 + paraxial ** 2) / (pupil_radius ** 2 + best ** 2)
    expected = (1 + 4 * lens.working_f_number ** 2) / (4 * n * n) * nearer
    assert measured == pytest.approx(expected, rel=0.02)


@pytest.mark.parametrize("name, stated", [("dgauss_50mm", 2.0), ("telephoto_250mm", 5.6)])
def test_the_traced_f_number_is_the_designs_stated_one(name, stated):
    """The widest axial bundle that passes every aperture gives f/2.02 and f/5.59 for the
    stated f/2 and f/5.6 (the paraxial stop image alone says f/2.03 and f/5.42: in the
    telephoto another element, not the stop, clips the axial bundle)."""
    assert load_prescription(name).traced_f_number() == pytest.approx(stated, rel=0.02)


def _source(distance_m, radius_m):
    def objects(mi):
        return {"source": {"type": "disk", "emitter": {"type": "area", "radiance": {"type": "uniform", "value": 1.0}},
                           "to_world": mi.ScalarTransform4f().translate([0.0, 0.0, distance_m])
                           .rotate([0, 1, 0], 180.0).scale(radius_m)}}
    return objects


def _spot_rms_px(image):
    yy, xx = np.mgrid[0:image.shape[0], 0:image.shape[1]] + 0.5
    total = image.sum()
    cy, cx = (image * yy).sum() / total, (image * xx).sum() / total
    return float(np.sqrt((image * ((yy - cy) ** 2 + (xx - cx) ** 2)).sum() / total))


def _traced_spot_rms_px(design, object_distance_m, pitch):
    """RMS spot radius on the best-focus plane the camera puts its sensor on
    (:meth:`Prescription.focus_image_distance_m`) of an axial point, from NumPy's real-ray trace
    (:meth:`Prescription.trace`, itself checked against ABCD and Seidel): rays aimed at a fine
    grid over the front element, those that pass."""
    pupil_z, _ = design.entrance_pupil()
    s = object_distance_m - pupil_z
    extent = design.surfaces[0].semi_diameter_m
    grid = np.linspace(-extent, extent, 301)
    gx, gy = (a.ravel() for a in np.meshgrid(grid, grid))
    origins = np.tile([0.0, 0.0, -s], (gx.size, 1))
    o, d, passed = design.trace(origins, np.stack([gx, gy, np.full(gx.size, s)], axis=1))
    plane = design.vertices_m()[-1] + design.focus_image_distance_m(s)
    hit = o[passed] + ((plane - o[passed, 2]) / d[passed, 2])[:, None] * d[passed]
    return float(np.sqrt(np.mean(hit[:, 0] ** 2 + hit[:, 1] ** 2))) / pitch


def test_the_sensor_stands_where_the_lens_focuses_the_focus_distance():
    """The double Gauss focused at 3 m: a 0.25 mm source at 3 m images as its own disc blurred
    by the lens's residual aberration at f/2 — the rendered spot's RMS radius equals
    √(disc² + aberration²) with the aberration from NumPy's independent trace, within 10 %; the
    same source at 1.5 m blurs to the thin-lens circle of confusion of the same focal length and
    f-number within 15 % (a thick lens focuses nearly as a thin one on axis)."""
    pitch = 6e-6
    sharp, lens, design = _render("dgauss_50mm", 3.0, _source(3.0, 0.00025), width=96, pitch=pitch)
    disc_px = 0.00025 * lens.image_distance_m / 3.0 / pitch / np.sqrt(2)
    expected = np.hypot(disc_px, _traced_spot_rms_px(design, 3.0, pitch))
    assert _spot_rms_px(sharp) == pytest.approx(expected, rel=0.10)
    blurred, _, _ = _render("dgauss_50mm", 3.0, _source(1.5, 0.00025), width=96, pitch=pitch)
    disc_rms = float(lens.coc_diameter_px(1.5)) / 2 / np.sqrt(2)  # a uniform disc of that diameter
    assert _spot_rms_px(blurred) == pytest.approx(disc_rms, rel=0.15)


def test_a_prescription_renders_through_the_whole_chain(make_scene):
    from spectral_cam.job import simulate

    config = make_scene(scene={"preset": "colorchecker", "distance_m": 20.0},
                        lens={"model": "prescription", "prescription": "dgauss_50mm", "focus_distance_m": 20.0},
                        render={"spp": 8})
    assert config.lens.focal_length_mm == pytest.approx(50.36, abs=0.01)
    assert config.lens.f_number == pytest.approx(2.018, abs=0.001)
    sim = simulate(config)
    assert sim.radiance.meta["lens_model"] == "prescription"
    assert np.isfinite(sim.developed.image.astype(float)).all()
    record = sim.radiance.meta["prescription"]  # what the trace says the lens is
    assert record["focal_length_mm"] == pytest.approx(50.36, abs=0.01) and record["stated_f_number"] == 2.0
    assert record["fov_x_deg_traced"] == pytest.approx(record["fov_x_deg_thin_lens"], rel=0.03)


def test_the_traced_field_of_view_is_the_chief_rays():
    """The field of view from the trace: the chief ray of half that angle lands on the sensor's
    edge (to 1e-6 m), and a distant 20° point images at f·tan 20° within 2 % on the double Gauss
    (its distortion and best-focus shift are small)."""
    design = load_prescription("dgauss_50mm")
    sensor = design.focus_image_distance_m()
    fov = design.field_of_view_deg(0.018, sensor)
    assert design.image_height_m(fov / 2, sensor) == pytest.approx(0.018, abs=1e-6)
    assert design.image_height_m(20.0, sensor) == pytest.approx(design.focal_length_m() * np.tan(np.radians(20.0)),
                                                                 rel=0.02)


@pytest.mark.parametrize("blades, rounding", [(5, 0.0), (6, 0.5)])
def test_blades_in_the_stop_pass_the_openings_area(blades, rounding):
    """Blades closing the double Gauss's stop: on axis a uniform wall is as bright as the
    opening's area allows, ½∫r(φ)²dφ/π of the round stop's (pentagon 0.757; six blades half
    rounded 0.91) within 2 % — the stop limits the axial bundle, so the trace carries the shape."""
    import math

    import mitsuba as mi

    from spectral_cam.render import choose_variant
    from spectral_cam.render.scene_dict import camera_dict

    mi.set_variant(choose_variant("auto"))
    design = load_prescription("dgauss_50mm")
    lens = ThinLens(focal_length_m=design.focal_length_m(), f_number=design.traced_f_number(), focus_distance_m=1000.0,
                    sensor_width_m=WIDTH * PITCH, sensor_height_m=WIDTH * PITCH, width_px=WIDTH, height_px=WIDTH)
    film = {"type": "specfilm", "width": WIDTH, "height": WIDTH, "rfilter": {"type": "box"},
            "band": {"type": "spectrum", "value": [(540.0, 1.0), (560.0, 1.0)]}}
    wall = {"type": "rectangle", "emitter": {"type": "area", "radiance": {"type": "uniform", "value": 1.0}},
            "to_world": mi.ScalarTransform4f().translate([0, 0, 1000.0]).rotate([0, 1, 0], 180.0).scale(5000.0)}

    def centre(**shape):
        camera = camera_dict(mi, lens, "prescription", film, 128, "independent", prescription="dgauss_50mm", **shape)
        scene = mi.load_dict({"type": "scene", "integrator": {"type": "path", "max_depth": 1}, "sensor": camera,
                              "wall": wall})
        return np.asarray(mi.render(scene, spp=128), dtype=np.float64)[28:36, 28:36, 0].mean()

    phi = np.linspace(0.0, 2 * math.pi, 100001)[:-1]
    sector = 2 * math.pi / blades
    polygon = math.cos(math.pi / blades) / np.cos(np.mod(phi, sector) - sector / 2)
    area = float(np.mean(((1 - rounding) * polygon + rounding) ** 2))
    assert centre(blades=blades, blade_rounding=rounding) / centre() == pytest.approx(area, rel=0.02)


def test_a_prescription_says_which_scene_values_it_replaces():
    """Issue 25 #15: scenes/dof.toml's 25 mm f/1.4 became 50.36 mm f/2.02 without a word. The focal
    length is the design's, said; an f-number is kept when the lens can close to it (issue 39 #11)
    and refused when it is faster than the design's."""
    import warnings

    from spectral_cam import load_scene
    from spectral_cam.errors import ConfigError, SceneWarning

    with pytest.warns(SceneWarning, match=r"replaces lens.focal_length_mm = 25.* by its 50.36"):
        config = load_scene("scenes/dof.toml", overrides={"lens.model": "prescription", "lens.f_number": 4.0})
    assert config.lens.focal_length_mm == pytest.approx(50.36, abs=0.01) and config.lens.f_number == 4.0
    with warnings.catch_warnings():
        warnings.simplefilter("error", SceneWarning)  # its own values again: nothing to say
        config.replace(**{"lens.focus_distance_m": 3.0})
    with pytest.raises(ConfigError, match=r"lens.f_number = 1.4: .* opens to f/2.018 at most"):
        load_scene("scenes/dof.toml", overrides={"lens.model": "prescription"})


@pytest.mark.parametrize("header, content, message", [
    ("# stated_focal_length_mm: abc\n", None, r"header line '# stated_focal_length_mm: abc' needs a positive number"),
    ("", b"\xff\xfe radius_mm", r"not UTF-8 text"),
])
def test_a_broken_prescription_file_is_refused_naming_what_to_fix(tmp_path, header, content, message):
    """Issue 25 #12: a non-numeric header value raised ValueError, non-UTF-8 bytes UnicodeDecodeError."""
    from spectral_cam.errors import ConfigError
    from spectral_cam.optics.prescription import load_prescription

    path = tmp_path / "lens.csv"
    if content is None:
        path.write_text(header + "radius_mm,thickness_mm,nd,vd,glass,semi_diameter_mm\n"
                        "50,5,1.5,60,,10\ninf,1,1,,STOP,8\n-50,40,1,,,10\n")
    else:
        path.write_bytes(content)
    with pytest.raises(ConfigError, match=message):
        load_prescription(str(path))


GOOD = "radius_mm,thickness_mm,nd,vd,glass,semi_diameter_mm\n50,5,1.5,60,,10\ninf,1,1,,STOP,8\n-50,40,1,,,10\n"


@pytest.mark.parametrize("table, message", [
    (GOOD.replace("50,5,1.5", "50,-2,1.5"), r"surface 1: thickness_mm = -2"),
    (GOOD.replace("1.5,60,,10", "1.5,60,,inf"), r"surface 1: semi_diameter_mm = inf"),
    (GOOD.replace("50,5,1.5", "50,5,0"), r"surface 1: nd = 0"),
    (GOOD.replace("50,5,1.5", "nan,5,1.5"), r"surface 1: radius_mm = nan"),
    (GOOD.replace("50,5,1.5", "-50,5,1.5").replace("-50,40", "50,40"), r"paraxial focal length is -"),
])
def test_impossible_surfaces_are_refused_naming_the_surface_and_column(tmp_path, table, message):
    """Issue 25 #13: these reported "lens.f_number = inf" or "lens.focal_length_mm = …", keys the
    user never set."""
    from spectral_cam import scene_from_dict
    from spectral_cam.errors import ConfigError

    path = tmp_path / "lens.csv"
    path.write_text(table)
    with pytest.raises(ConfigError, match=message):
        scene_from_dict({"lens": {"model": "prescription", "prescription": str(path)}})
