"""Issue 16 #4: mechanical (cat's-eye) vignetting emerges from a prescription's clear apertures —
the thin lens's cos⁴ law has none — and disappears when the lens is stopped down; the stress
study reports where the thin lens stops describing each bundled lens."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.optics.prescription import load_prescription


def _passing(lens, field_deg, grid=121):
    """Mask of a parallel bundle at ``field_deg`` (meridional plane y-z) over a square 1.3× the
    entrance pupil, on the pupil's plane: which rays pass every aperture."""
    pupil_z, radius = lens.entrance_pupil()
    axis = np.linspace(-1.3 * radius, 1.3 * radius, grid)
    gx, gy = np.meshgrid(axis, axis)
    tilt = np.radians(field_deg)
    direction = np.tile([0.0, np.sin(tilt), np.cos(tilt)], (gx.size, 1))
    origins = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, pupil_z)], axis=1) - direction * (pupil_z + 1.0)
    return lens.trace(origins, direction)[2].reshape(gx.shape), axis


def test_the_double_gauss_shows_cats_eye_vignetting_wide_open_and_none_stopped_down():
    """At f/2 and 20° off axis the double Gauss's front and rear elements clip the bundle to
    less than half its axial area, into a shape narrower in the meridional direction than the
    sagittal (the cat's eye); at f/8 the stop alone limits it (≥ 95 % of the axial area)."""
    lens = load_prescription("dgauss_50mm")
    axial, axis = _passing(lens, 0.0)
    tilted, _ = _passing(lens, 20.0)
    assert tilted.sum() / axial.sum() < 0.5
    rows, cols = np.nonzero(tilted)
    meridional, sagittal = np.ptp(axis[rows]), np.ptp(axis[cols])
    assert meridional < 0.85 * sagittal
    stopped = lens.stopped_down(8.0)
    assert stopped.traced_f_number() == pytest.approx(8.0, rel=1e-3)
    assert _passing(stopped, 20.0)[0].sum() / _passing(stopped, 0.0)[0].sum() > 0.95


def test_stopping_down_refuses_to_open_a_lens():
    from spectral_cam.errors import ConfigError

    with pytest.raises(ConfigError, match="opens to f/2.02 at most"):
        load_prescription("dgauss_50mm").stopped_down(1.4)


@pytest.mark.timeout(120)
def test_the_stress_study_says_where_the_thin_lens_holds(tmp_path):
    """Every bundled lens gets its rows; the double Gauss's in-focus spot shrinks as it stops
    down and falls below a pixel somewhere in its range, and its figure is written."""
    from spectral_cam.apps.stress import StressSettings, lens_study, plot_lenses

    result = lens_study(StressSettings())
    cases = {row["case"] for row in result["rows"]}
    assert cases == {"dgauss_50mm", "dgauss_f2_100mm_glass", "telephoto_250mm", "wide_56deg_100mm"}
    spots = np.asarray(result["data"]["dgauss_50mm"]["spot_px"])[:, 0]
    assert spots[0] > 1.0 and spots[-1] < 1.0 and np.all(np.diff(spots[:4]) < 0)
    assert (tmp_path / plot_lenses(result, tmp_path)[0]).stat().st_size > 10_000
    import csv  # the README cites docs/stress/lenses.csv: the study writes it (issue 25 #19)

    with open(tmp_path / "lenses.csv", newline="") as handle:
        assert {row["case"] for row in csv.DictReader(handle)} == cases
