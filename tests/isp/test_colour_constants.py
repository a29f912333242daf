"""The colorimetric constants the ISP writes out (to keep ``import colour`` out of a develop)
against colour-science's own tables and functions."""

from __future__ import annotations

import colour
import numpy as np
import pytest

from spectral_cam.isp import colour_correction as cc

pytestmark = pytest.mark.timeout(60)


def test_srgb_matrices_are_colour_sciences():
    to_rgb, to_xyz = cc._srgb_matrices()
    space = colour.models.RGB_COLOURSPACE_sRGB
    np.testing.assert_array_equal(to_xyz, space.matrix_RGB_to_XYZ)
    np.testing.assert_array_equal(to_rgb, space.matrix_XYZ_to_RGB)
    np.testing.assert_allclose(cc.xyz_d65_white(), colour.xy_to_XYZ(space.whitepoint), atol=1e-15)


@pytest.mark.parametrize("illuminant", ["A", "D50", "D65", "FL2", "FL11"])
def test_mccamy_cct_is_colour_sciences(illuminant):
    xy = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"][illuminant]
    expected = colour.xy_to_CCT(xy, method="McCamy 1992")
    assert cc.mccamy_cct(colour.xy_to_XYZ(xy)) == pytest.approx(expected, rel=1e-12)


def test_bradford_adaptation_is_colour_sciences():
    a = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["A"])
    d65 = cc.xyz_d65_white()
    expected = colour.adaptation.matrix_chromatic_adaptation_VonKries(a, d65, transform="Bradford")
    np.testing.assert_allclose(cc.von_kries_bradford(a, d65), expected, atol=1e-12)
    np.testing.assert_allclose(cc.BRADFORD, colour.adaptation.CAT_BRADFORD, atol=0)
