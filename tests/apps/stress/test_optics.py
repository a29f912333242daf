"""Study (c): circle-of-confusion and diffraction regimes (:mod:`spectral_cam.apps.stress.optics`).

References for the expected numbers are written out here (the thin-lens CoC, the Airy
diameter, the small-s diffraction MTF) rather than taken from the code under test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from spectral_cam.apps.stress.optics import OPTICS_RENDERS, chart_lens, optics_study, plot_optics


def test_chart_lens_is_the_scene_lens_of_a_480_by_320_sensor_of_6um_pixels():
    lens = chart_lens(50.0, 2.8, 0.1)
    assert lens.focal_length_m == pytest.approx(0.05) and lens.f_number == 2.8 and lens.focus_distance_m == 0.1
    assert (lens.width_px, lens.height_px) == (480, 320)
    assert lens.pixel_pitch_m == pytest.approx(6e-6)
    assert lens.working_f_number == pytest.approx(5.6)  # 1:1 macro: N·(1 + m), m = 1


def test_coc_and_diffraction_regime_numbers_against_the_formulas(tiny):
    result = optics_study(tiny.replace(optics_spp=16))
    rows = {(r["case"], r["metric"]): r["value"] for r in result["rows"]}
    f, zf, pitch = 50e-3, 2.0, 6e-6
    for n in (0.95, 64.0):
        aperture = f / n
        coc_inf = aperture * f / (zf - f)  # c = A·f·|z − z_f|/(z·(z_f − f)) → A·f/(z_f − f) at z = ∞
        n_w = n * (1 + f / (zf - f))
        case = f"50 mm f/{n:g} focused at 2 m"
        assert rows[(case, "CoC diameter of a point at infinity")] == pytest.approx(coc_inf / pitch, rel=1e-9)
        assert rows[(case, "Airy diameter 2.44·λ·N_w at 550 nm")] == pytest.approx(2.44 * 550e-9 * n_w / pitch,
                                                                                    rel=1e-9)
    # small-s expansion of the diffraction MTF: 1 − MTF ≈ (4/π)·λ·N·ν_Nyquist
    limit = rows[("6-um pixels", "f-number where diffraction costs 0.03 MTF at Nyquist (700 nm)")]
    assert limit == pytest.approx(0.03 * math.pi / 4 / (700e-9 * 0.5 / pitch), rel=0.03)
    regime = np.asarray(result["data"]["regime_map"]["regime"])
    n_grid = np.asarray(result["data"]["regime_map"]["f_numbers"])
    z_grid = np.asarray(result["data"]["regime_map"]["distances_m"])
    assert n_grid[0] == pytest.approx(0.95) and n_grid[-1] == pytest.approx(64.0)
    # the map is for the default 8-mm lens focused at 2 m with 6-µm pixels
    at_focus = int(np.argmin(abs(z_grid - 2.0)))
    assert regime[at_focus, -1] == 2  # f/64 in focus: the Airy disc (87 µm) dominates
    assert regime[0, 0] == 1  # f/0.95 at 0.1 m: defocus
    assert regime[-1, 0] == 1  # f/0.95 at 1000 m: CoC A·f/(z_f − f) = 34 µm > 6 µm
    assert regime[at_focus, 0] == 0  # f/0.95 in focus: the pixel


@pytest.mark.timeout(120)
def test_rendered_blur_matches_the_thin_lens_coc(tmp_path, tiny):
    """Tiny Mitsuba renders of one source: the blur diameter from second moments equals
    A·f·|z − z_f|/(z·(z_f − f)) at f/0.95, at 1:2 macro focus and at 10⁶-m focus."""
    result = optics_study(tiny)
    renders = {r["label"]: r for r in result["data"]["renders"]}
    for label in ("f/0.95", "focus 24 mm (1:2), f/8", "focus 1e6 m ('infinity'), f/1.4"):
        entry = renders[label]
        kwargs = dict(OPTICS_RENDERS)[label]
        f = 8e-3
        aperture = f / kwargs["f_number"]
        z, zf = kwargs["source_depth_m"], kwargs["focus_distance_m"]
        expected_px = aperture * f * abs(z - zf) / (z * (zf - f)) / 6e-6
        assert entry["predicted_coc_px"] == pytest.approx(expected_px, rel=1e-9)
        assert entry["measured_coc_px"] == pytest.approx(expected_px, rel=0.03), label
    assert renders["f/64 + diffraction"]["peak_ratio_diffraction"] < 0.5
    files = plot_optics(result, tmp_path)
    assert len(files) == 3 and all((tmp_path / name).read_bytes()[:4] == b"\x89PNG" for name in files)
