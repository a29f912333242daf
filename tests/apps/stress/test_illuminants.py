"""Study (e): colour far from the D65 calibration (:mod:`spectral_cam.apps.stress.illuminants`)."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam import spectra
from spectral_cam.apps.stress.illuminants import (NARROW_LED_FWHM_NM, NARROW_LED_PEAKS_NM, PATCH_MARGIN,
                                                  STUDY_COLOUR_MATRICES, STUDY_WHITE_BALANCE, illuminant_study,
                                                  plot_illuminants, write_narrow_band_led)
from spectral_cam.radiance_targets import reflectance_set, synthetic_chart
from spectral_cam.colour_ground_truth import white_patch_index


def test_the_study_chart_is_lambertian():
    """The study's chart (6 × 4 patches, no gaps): the white patch's interior holds
    L_b = ∫_b ρ·E/π dλ of the white patch under 1000 lx of illuminant A."""
    chart = synthetic_chart(reflectance_set("colorchecker"), "A", patch_px=8, gap_px=0)
    assert chart.radiance.data.shape == (32, 48, 31) and len(chart.patches) == 24
    wl, irradiance = spectra.absolute_irradiance("A", 1000.0)
    white = spectra.colorchecker_reflectances()["white 9.5 (.05 D)"]
    rho = np.interp(wl, np.asarray(white.wavelengths), np.asarray(white.values))
    expected = spectra.band_integrals(rho * irradiance / np.pi, wl, spectra.parse_bands("400:700:10"))
    interior = chart.patches[white_patch_index()].interior(PATCH_MARGIN)
    assert chart.white_index == white_patch_index()
    assert interior == (slice(26, 30), slice(2, 6))  # the middle half of patch (row 3, column 0)
    np.testing.assert_allclose(chart.radiance.data[interior][0, 0], expected, rtol=1e-5)


def test_narrow_band_led_csv(tmp_path):
    path = write_narrow_band_led(tmp_path / "led.csv")
    sd = spectra.illuminant(str(path))
    wl, values = np.asarray(sd.wavelengths), np.asarray(sd.values)
    for peak in NARROW_LED_PEAKS_NM:
        window = np.abs(wl - peak) < 20
        above = wl[window][values[window] >= 0.5 * values[window].max()]
        assert above.max() - above.min() == pytest.approx(NARROW_LED_FWHM_NM, abs=1.5)


def test_delta_e_of_the_white_balance_choices_far_from_d65(tmp_path, tiny):
    result = illuminant_study(tiny, illuminants=["D65", "A", str(write_narrow_band_led(tmp_path / "led.csv"))])
    data = result["data"]["illuminants"]
    d65, tungsten = data["D65"]["results"], data["A"]["results"]
    assert d65["fitted/as_shot"]["mean"] < 2.0 and d65["dng/as_shot"]["mean"] < 2.0
    for results in data.values():  # a ColorChecker does not average to grey
        assert results["results"]["fitted/grey_world"]["mean"] > 2 * results["results"]["fitted/as_shot"]["mean"]
    # the D65-calibrated DNG matrix alone degrades under tungsten; the matrix fitted under A,
    # or ColorMatrix2 (A) interpolated by the white's colour temperature, does not
    assert tungsten["dng_d65/as_shot"]["mean"] > 1.5 * tungsten["fitted/as_shot"]["mean"]
    assert tungsten["dng/as_shot"]["mean"] < 1.2 * tungsten["fitted/as_shot"]["mean"]
    assert len(result["rows"]) == 3 * len(STUDY_COLOUR_MATRICES) * len(STUDY_WHITE_BALANCE)
    files = plot_illuminants(result, tmp_path)
    assert files == ["illuminants_delta_e.png"] and (tmp_path / files[0]).stat().st_size > 1000
