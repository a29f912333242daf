"""Issue 16 #2: even-asphere surfaces, against Descartes' perfect refracting conics: a single
surface from index n₁ into n₂ brings parallel light to one point when it is a conic of
eccentricity e = n₁/n₂ (conic constant k = −e²); a sphere leaves spherical aberration."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.optics.prescription import load_prescription

N = 1.5168  # N-BK7 at the d line


def _lens(tmp_path, rows, name="lens"):
    path = tmp_path / f"{name}.csv"
    path.write_text("# test lens\nradius_mm,thickness_mm,nd,vd,glass,semi_diameter_mm,conic,a4,a6\n" + rows)
    return load_prescription(str(path))


def _axis_crossings(lens, heights):
    origins = np.stack([np.zeros_like(heights), heights, np.full_like(heights, -1.0)], axis=1)
    o, d, passed = lens.trace(origins, np.tile([0.0, 0.0, 1.0], (len(heights), 1)))
    assert passed.all()
    return o[:, 2] - o[:, 1] * d[:, 2] / d[:, 1]


def test_descartes_ellipsoid_focuses_parallel_light_perfectly_into_glass(tmp_path):
    """Air into glass (e = 1/n, k = −1/n²), R = 50 mm: rays at 1–20 mm from the axis all cross it
    at the paraxial focus nR/(n − 1) within 10⁻⁹ of it; the sphere of the same radius spreads its
    crossings by millimetres."""
    heights = np.linspace(1e-3, 20e-3, 12)
    ellipsoid = _lens(tmp_path, f"0,0,1,,STOP,25,0,0,0\n50,0,{N},,,25,{-1 / N ** 2},0,0\n", "ellipsoid")
    sphere = _lens(tmp_path, f"0,0,1,,STOP,25,0,0,0\n50,0,{N},,,25,0,0,0\n", "sphere")
    focus = N * 0.05 / (N - 1)
    assert np.allclose(_axis_crossings(ellipsoid, heights), focus, rtol=1e-9)
    assert np.ptp(_axis_crossings(sphere, heights)) > 1e-3


def test_the_newton_intersection_agrees_with_the_spheres_closed_form(tmp_path):
    """A conic constant of 10⁻¹² (numerically a sphere) sends the asphere tracer down its Newton
    path: the rays leave where the closed-form sphere sends them (10⁻¹⁰ m), and A₄ bends them."""
    heights = np.linspace(1e-3, 12e-3, 8)
    newton = _lens(tmp_path, f"0,0,1,,STOP,20,0,0,0\n40,8,{N},,,20,1e-12,0,0\n-40,0,1,,,20,0,0,0\n", "newton")
    closed = _lens(tmp_path, f"0,0,1,,STOP,20,0,0,0\n40,8,{N},,,20,0,0,0\n-40,0,1,,,20,0,0,0\n", "closed")
    assert np.allclose(_axis_crossings(newton, heights), _axis_crossings(closed, heights), atol=1e-10)
    bent = _lens(tmp_path, f"0,0,1,,STOP,20,0,0,0\n40,8,{N},,,20,0,-2e-6,0\n-40,0,1,,,20,0,0,0\n", "bent")
    assert np.abs(_axis_crossings(bent, heights) - _axis_crossings(closed, heights)).max() > 1e-4
    assert bent.focal_length_m() == pytest.approx(closed.focal_length_m())  # A₄ leaves the paraxial power


def test_a_rendered_aspheric_singlet_focuses_tighter_than_the_spherical_one(tmp_path):
    """Plano-convex, flat side to the object, f ≈ 97 mm at f/4: the glass-to-air surface a
    hyperboloid (e = n, k = −n²) renders a distant point as a spot several times smaller than the
    spherical surface's, through the drjit camera."""
    from tests.optics.test_prescription_render import _render, _source, _spot_rms_px

    rows = "0,1,1,,STOP,12.5,0,0,0\n0,5,{n},,,12.5,0,0,0\n-50,0,1,,,12.5,{k},0,0\n"
    for name, k in (("hyperbolic", -N ** 2), ("spherical", 0.0)):
        _lens(tmp_path, rows.format(n=N, k=k), name)
    sharp, _, _ = _render(str(tmp_path / "hyperbolic.csv"), 500.0, _source(500.0, 0.01), width=64, pitch=4e-6)
    round_, _, _ = _render(str(tmp_path / "spherical.csv"), 500.0, _source(500.0, 0.01), width=64, pitch=4e-6)
    assert _spot_rms_px(sharp) < 0.4 * _spot_rms_px(round_)
