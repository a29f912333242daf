"""Issue 16 #1: the glass catalogue and the thin-lens focal lengths it gives, against the SCHOTT
catalogue's own nd and νd and the textbook formulas of chromatic aberration (Hecht §6.3.2;
Kingslake & Johnson ch. 5)."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.errors import ConfigError
from spectral_cam.optics.glass import (GLASS_NAMES, LINES_NM, achromat_focal_length, glass, singlet_focal_length,
                                       thin_lens_focal_length)


@pytest.mark.parametrize("name", GLASS_NAMES)
def test_sellmeier_terms_give_the_catalogues_nd_and_abbe_number(name):
    """The catalogue prints nd to 5 decimals and νd to 2: the Sellmeier terms reproduce both."""
    g = glass(name)
    assert float(g.index(LINES_NM["d"])) == pytest.approx(g.nd_catalogue, abs=6e-6)
    assert g.abbe_number == pytest.approx(g.vd_catalogue, abs=0.006)


def test_a_singlets_longitudinal_colour_is_f_over_its_abbe_number():
    """f_C − f_F = f·(n_d − 1)(n_F − n_C)/((n_C − 1)(n_F − 1)) exactly (the lensmaker's power ∝
    n − 1), ≈ f/ν_d to 2 % (0.6 % for N-BK7, 1.5 % for N-SF11): blue focuses nearer."""
    for name in ("N-BK7", "F2", "N-SF11"):
        g = glass(name)
        f_f, f_d, f_c = singlet_focal_length(50.0, g, [LINES_NM[k] for k in "FdC"])
        assert f_d == pytest.approx(50.0) and f_f < f_d < f_c
        n_f, n_d, n_c = (float(g.index(LINES_NM[k])) for k in "FdC")
        assert f_c - f_f == pytest.approx(50.0 * (n_d - 1) * (n_f - n_c) / ((n_c - 1) * (n_f - 1)), rel=1e-12)
        assert f_c - f_f == pytest.approx(50.0 / g.abbe_number, rel=0.02)


def test_an_achromat_brings_f_and_c_together_and_leaves_the_secondary_spectrum():
    """N-BK7 + F2, f = 100 mm: F and C share one focus; the d line focuses
    Δf = −f·(P₁ − P₂)/(ν₁ − ν₂) from them (Kingslake & Johnson eq. 5-9; P = P_F,d), ≈ f/2000,
    and the shortest focus lies in the green (the classic secondary spectrum)."""
    crown, flint = glass("N-BK7"), glass("F2")
    f_f, f_d, f_c = achromat_focal_length(100.0, crown, flint, [LINES_NM[k] for k in "FdC"])
    assert f_f == pytest.approx(f_c, rel=1e-12) and f_d == pytest.approx(100.0)
    expected = -100.0 * (crown.partial_dispersion - flint.partial_dispersion) / (crown.abbe_number - flint.abbe_number)
    assert f_f - f_d == pytest.approx(expected, rel=0.02) and 100.0 / 3000 < f_f - f_d < 100.0 / 1500
    wavelengths = np.arange(420.0, 700.0, 1.0)
    assert 520.0 < wavelengths[np.argmin(achromat_focal_length(100.0, crown, flint, wavelengths))] < 580.0


def test_bad_glasses_are_refused_with_what_is_valid():
    with pytest.raises(ConfigError, match="unknown glass 'BK7'.*N-BK7"):
        thin_lens_focal_length("BK7", 0.05, 550.0)
    with pytest.raises(ConfigError, match="crown first"):
        thin_lens_focal_length("F2+N-BK7", 0.05, 550.0)
    with pytest.raises(ConfigError, match="one glass.*or a crown and a flint"):
        thin_lens_focal_length("N-BK7+F2+SF5", 0.05, 550.0)
