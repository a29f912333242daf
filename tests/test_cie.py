"""CIE colorimetry without colour-science (:mod:`spectral_cam.cie`, and the ISP's constants)
against colour-science's own tables and functions: the reference is the installed
colour-science itself, imported here and nowhere on the render path."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import colour
import numpy as np
import pytest

from spectral_cam import cie, colour_ground_truth, spectra
from spectral_cam.isp import colour_correction as cc

pytestmark = pytest.mark.timeout(120)

OBSERVER = "CIE 1931 2 Degree Standard Observer"
SCENES = Path(__file__).resolve().parents[1] / "scenes"


def test_srgb_matrices_are_colour_sciences():
    to_rgb, to_xyz = cc._srgb_matrices()
    space = colour.models.RGB_COLOURSPACE_sRGB
    np.testing.assert_array_equal(to_xyz, space.matrix_RGB_to_XYZ)
    np.testing.assert_array_equal(to_rgb, space.matrix_XYZ_to_RGB)
    np.testing.assert_allclose(cc.xyz_d65_white(), colour.xy_to_XYZ(space.whitepoint), atol=1e-15)


@pytest.mark.parametrize("illuminant", ["A", "D50", "D65", "FL2", "FL11"])
def test_mccamy_cct_is_colour_sciences(illuminant):
    xy = colour.CCS_ILLUMINANTS[OBSERVER][illuminant]
    expected = colour.xy_to_CCT(xy, method="McCamy 1992")
    assert cc.mccamy_cct(colour.xy_to_XYZ(xy)) == pytest.approx(expected, rel=1e-12)


def test_bradford_adaptation_is_colour_sciences():
    a = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS[OBSERVER]["A"])
    d65 = cc.xyz_d65_white()
    expected = colour.adaptation.matrix_chromatic_adaptation_VonKries(a, d65, transform="Bradford")
    np.testing.assert_allclose(cie.bradford_adaptation(a, d65), expected, atol=1e-12)
    np.testing.assert_allclose(cie.BRADFORD, colour.adaptation.CAT_BRADFORD, atol=0)


def _same_spectra(ours, theirs):
    assert len(ours) == len(theirs)
    for mine, sd in zip(ours, theirs):
        assert mine.name == sd.name
        np.testing.assert_array_equal(mine.wavelengths, sd.wavelengths)
        np.testing.assert_array_equal(mine.values, sd.values)


def _named(mapping):
    out = []
    for name, sd in mapping.items():
        sd = sd.copy()
        sd.name = name
        out.append(sd)
    return out


@pytest.mark.parametrize("key", ["illuminants", "light_sources", "colorchecker", "rawtoaces", "cie2017", "cri",
                                 "cqs"])
def test_shipped_datasets_are_colour_sciences_tables(key):
    from colour.quality import cfi2017

    reference = {
        "illuminants": lambda: _named(colour.SDS_ILLUMINANTS),
        "light_sources": lambda: _named(colour.SDS_LIGHT_SOURCES),
        "colorchecker": lambda: _named(colour.SDS_COLOURCHECKERS["BabelColor Average"]),
        "rawtoaces": lambda: colour.characterisation.read_training_data_rawtoaces_v1().to_sds(),
        "cie2017": lambda: cfi2017.load_TCS_CIE2017(cfi2017.SPECTRAL_SHAPE_CIE2017).to_sds(),
        "cri": lambda: _named(colour.quality.SDS_TCS["CIE 1995"]),
        "cqs": lambda: _named(colour.quality.SDS_VS["NIST CQS 9.0"]),
    }[key]()
    _same_spectra(cie.dataset(key), reference)


def test_shipped_cmfs_cameras_and_white_points_are_colour_sciences():
    cmfs = colour.MSDS_CMFS[OBSERVER]
    np.testing.assert_array_equal(cie.cmfs_1931().wavelengths, cmfs.wavelengths)
    np.testing.assert_array_equal(cie.cmfs_1931().values, cmfs.values)
    for key in spectra.COLOUR_CAMERA_KEYS:
        ours = spectra.camera_sensitivities(key)
        np.testing.assert_array_equal(ours.values, colour.MSDS_CAMERA_SENSITIVITIES[key].values)
    for name, xy in colour.CCS_ILLUMINANTS[OBSERVER].items():
        np.testing.assert_array_equal(cie.illuminant_xy(name), xy)


@pytest.mark.parametrize("kelvin", [1000.0, 2856.0, 6504.0, 20000.0])
def test_blackbody_is_colour_sciences_planck_law(kelvin):
    expected = colour.sd_blackbody(kelvin, colour.SpectralShape(360, 830, 1))
    ours = spectra.illuminant(f"blackbody:{kelvin:g}")
    np.testing.assert_array_equal(ours.wavelengths, expected.wavelengths)
    ratio = ours.values / expected.values  # colour-science truncates c1 = 2πhc² to 3.741771e-16
    np.testing.assert_allclose(ratio, 3.741771852e-16 / 3.741771e-16, rtol=1e-12)


@pytest.mark.parametrize("kelvin", [4000.0, 5003.0, 6504.0, 7000.0, 7500.0, 20000.0])
def test_daylight_is_colour_sciences_cie_d_series(kelvin):
    xy = colour.temperature.CCT_to_xy_CIE_D(kelvin * 1.4388 / 1.4380)
    expected = colour.sd_CIE_illuminant_D_series(xy).align(colour.SpectralShape(360, 830, 1))
    ours = spectra.illuminant(f"daylight:{kelvin:g}")
    np.testing.assert_array_equal(ours.wavelengths, expected.wavelengths)
    np.testing.assert_allclose(ours.values, expected.values, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("xy", [(0.31270, 0.32900), (0.44757, 0.40745), (0.3457, 0.3585), (0.38, 0.36),
                                (0.30, 0.34), (0.2600, 0.2700), (0.55, 0.40)])
def test_robertson_cct_and_duv_are_colour_sciences(xy):
    uv = colour.xy_to_UCS_uv(np.array(xy))
    np.testing.assert_allclose(cie.xy_to_uv_1960(xy), uv, atol=1e-15)
    expected = colour.temperature.uv_to_CCT_Robertson1968(uv)
    cct, duv = cie.cct_robertson1968(uv)
    assert cct == pytest.approx(expected[0], rel=1e-12)
    assert duv == pytest.approx(expected[1], abs=1e-12)


@pytest.mark.parametrize("degree", [1, 2, 3, 4])
def test_root_polynomial_terms_are_colour_sciences_expansion(degree):
    from colour.characterisation import polynomial_expansion_Finlayson2015

    rgb = np.random.default_rng(degree).uniform(-0.1, 1.2, (50, 3))  # noise makes some negative
    expected = polynomial_expansion_Finlayson2015(rgb, degree=degree, root_polynomial_expansion=True)
    np.testing.assert_allclose(cie.root_polynomial_terms(rgb, degree), expected, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("illuminant", ["D65", "A", "FL11", "LED-B3"])
def test_reflectance_xyz_is_colour_sciences_integration(illuminant):
    from colour.colorimetry import sd_to_XYZ_integration

    shape = colour.SpectralShape(360, 830, 1)
    power = colour.SDS_ILLUMINANTS[illuminant].copy()
    patches = list(colour.SDS_COLOURCHECKERS["BabelColor Average"].values())
    grid = np.arange(360.0, 831.0)
    rho = np.stack([np.interp(grid, sd.wavelengths, sd.values) for sd in patches])
    light = colour.SpectralDistribution(dict(zip(grid, np.interp(grid, power.wavelengths, power.values,
                                                                 left=0.0, right=0.0))))
    expected = sd_to_XYZ_integration(rho, colour.MSDS_CMFS[OBSERVER], light, shape=shape) / 100.0
    np.testing.assert_allclose(colour_ground_truth.reflectance_xyz(illuminant), expected, rtol=1e-12, atol=1e-14)


def test_spectrum_converts_to_colour_science_and_back():
    patch = spectra.reflectance("dark skin")
    sd = patch.to_colour()
    assert isinstance(sd, colour.SpectralDistribution) and sd.name == "dark skin"
    np.testing.assert_array_equal(sd.values, patch.values)
    curves = spectra.camera_sensitivities("nikon_d850").to_colour()
    assert isinstance(curves, colour.MultiSpectralDistributions) and list(curves.labels) == ["r", "g", "b"]


def test_a_render_job_never_imports_colour_science(tmp_path):
    """The fixed cost: a whole render → expose → develop → files job, as the CLI runs it, with
    colour-science not imported (0.5–1 s and ~77 MB it would add to every run)."""
    code = ("import sys\nfrom spectral_cam.cli import main\n"
            f"rc = main(['render', {str(SCENES / 'colorchecker.toml')!r}, '-o', {str(tmp_path / 'out')!r}, '-q', "
            "'--set', 'render.spp=2', '--set', 'sensor.width_px=48', '--set', 'sensor.height_px=32'])\n"
            "heavy = [m for m in ('colour', 'pandas', 'matplotlib', 'skimage', 'scipy.interpolate') if m in sys.modules]\n"
            "print(rc, heavy)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=110)
    assert done.stdout.strip().splitlines()[-1] == "0 []", done.stdout + done.stderr
