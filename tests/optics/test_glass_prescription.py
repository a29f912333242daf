"""Issue 16 #1–2: a prescription with catalogue glasses (the f/2 double Gauss of ray-optics'
CODE V test file): clear apertures derived from its entrance pupil and field, its colour
correction, and its lateral colour — the chief ray's height at F against C — from the real trace
against the paraxial (ABCD) chief ray at each wavelength."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.optics.glass import LINES_NM
from spectral_cam.optics.prescription import load_prescription

NAME = "dgauss_f2_100mm_glass"


def test_the_derived_clear_apertures_pass_the_stated_pupil_and_field():
    """EFL 100.00 mm and back focus 61.488 mm as the source gives them, paraxial f/2.000 from the
    50 mm entrance pupil the stop was sized for, and no mechanical vignetting to the stated 14°:
    of a bundle filling the entrance pupil, every ray the stop passes passes every other surface
    (the stop alone limits it)."""
    lens = load_prescription(NAME)
    assert lens.focal_length_m() * 1e3 == pytest.approx(100.0, rel=1e-4)
    assert lens.back_focal_distance_m() * 1e3 == pytest.approx(61.487536, rel=1e-4)
    assert lens.f_number() == pytest.approx(2.0, rel=1e-3)
    pupil_z, radius = lens.entrance_pupil()
    axis = np.linspace(-radius, radius, 61) * 0.999
    gx, gy = (a.ravel() for a in np.meshgrid(axis, axis))
    keep = gx * gx + gy * gy <= (0.999 * radius) ** 2
    for field in (14.0, -14.0):
        tilt = np.radians(field)
        direction = np.tile([0.0, np.sin(tilt), np.cos(tilt)], (keep.sum(), 1))
        origins = np.stack([gx[keep], gy[keep], np.full(keep.sum(), pupil_z)], axis=1) - direction * (pupil_z + 1.0)
        from dataclasses import replace

        from spectral_cam.optics.prescription import Prescription

        stop_only = Prescription(NAME, "", "", tuple(
            s if s.stop else replace(s, semi_diameter_m=1.0) for s in lens.surfaces))
        passed = lens.trace(origins, direction)[2]
        assert passed.mean() > 0.5 and np.array_equal(passed, stop_only.trace(origins, direction)[2])


def test_the_achromatised_lens_nearly_joins_f_and_c():
    """Its F and C focal lengths differ by less than a tenth of an N-BK7 singlet's f/ν (0.78 mm
    at 50 mm → 1.56 mm at 100 mm): the glasses correct the colour."""
    lens = load_prescription(NAME)
    shift = abs(lens.focal_length_m(LINES_NM["F"]) - lens.focal_length_m(LINES_NM["C"]))
    assert shift < 0.1 * 0.1 / 64.17


@pytest.mark.parametrize("field_deg", [1.0, 2.0])
def test_lateral_colour_from_the_trace_is_the_paraxial_chief_rays(field_deg):
    """Chief ray (through the entrance pupil's centre) of a distant point at 1° and 2°: its height
    on the d-line focal plane differs between F and C — lateral colour, magnification against λ —
    by what the paraxial chief ray through each wavelength's system matrix says, within 2 %
    (0.3 % at 1°; higher orders grow with the field)."""
    lens = load_prescription(NAME)
    plane = lens.back_focal_distance_m()

    def paraxial(wavelength):
        pupil_z, _ = lens.entrance_pupil(wavelength)
        slope = np.tan(np.radians(field_deg))
        y, u = lens.system_matrix(wavelength) @ np.array([-slope * pupil_z, slope])
        return y + u * plane

    traced = lens.image_height_m(field_deg, plane, LINES_NM["F"]) - lens.image_height_m(field_deg, plane, LINES_NM["C"])
    expected = paraxial(LINES_NM["F"]) - paraxial(LINES_NM["C"])
    assert abs(expected) > 5e-7 and traced == pytest.approx(expected, rel=0.02)


def test_a_glass_prescription_renders_one_wavelength_per_ray(make_scene):
    from spectral_cam import render
    from spectral_cam.render.prescription_lens import _disperses

    assert _disperses(load_prescription(NAME)) and not _disperses(load_prescription("dgauss_50mm"))
    config = make_scene(scene={"preset": "dof_targets"}, lens={"model": "prescription", "prescription": NAME,
                                                               "focus_distance_m": 2.0}, render={"spp": 4})
    image = render(config, with_depth=False)
    assert image.meta["prescription"]["focal_length_mm"] == pytest.approx(100.0, rel=1e-4)
    assert np.isfinite(image.data).all() and image.data.max() > 0
