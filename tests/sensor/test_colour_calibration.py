"""Spectral colour calibration: DNG matrix normalisation, fit quality, independent XYZ."""

from __future__ import annotations

import colour
import numpy as np
import pytest

from spectral_cam import colour_ground_truth
from spectral_cam.sensor import colour_calibration as cal
from spectral_cam import sensor as S
from spectral_cam import spectra
from spectral_cam.errors import ConfigError
from spectral_cam.image import SpectralImage
from spectral_cam.scene import scene_from_dict


@pytest.mark.parametrize("camera", ["nikon_d850", "canon_eos_5d_mkiv", "sony_ilce_7m3"])
def test_color_matrix_maps_d65_white_to_camera_neutral(camera):
    matrix = cal.xyz_to_camera_matrix(camera, "D65")
    neutral = matrix @ colour_ground_truth.illuminant_white_xyz("D65")
    np.testing.assert_allclose(neutral, cal.as_shot_neutral(camera, "D65"), atol=1e-12)
    assert neutral.max() == pytest.approx(1.0)


def test_color_matrix_fit_residuals_small():
    matrix = cal.xyz_to_camera_matrix("nikon_d850", "D65")
    cam = cal.camera_responses("nikon_d850", "D65")
    white = cal.camera_responses("nikon_d850", "D65", [1.0])[0]
    predicted = colour_ground_truth.reflectance_xyz("D65") @ matrix.T
    residual = predicted - cam / white.max()
    assert np.sqrt(np.mean(residual ** 2)) < 0.01  # of a white at 1


@pytest.mark.filterwarnings("ignore::colour.utilities.ColourRuntimeWarning")
def test_reflectance_xyz_matches_colour_science_directly():
    patches = spectra.colorchecker_reflectances()
    name = "dark skin"
    shape = colour.SpectralShape(360, 830, 1)
    illuminant = colour.SDS_ILLUMINANTS["D65"].copy().align(shape)
    expected = colour.sd_to_XYZ(colour.SDS_COLOURCHECKERS["BabelColor Average"][name].copy().align(shape), illuminant=illuminant, method="Integration") / 100
    got = colour_ground_truth.reflectance_xyz("D65", [patches[name]])[0]
    np.testing.assert_allclose(got, expected, rtol=2e-3)
    np.testing.assert_allclose(colour_ground_truth.illuminant_white_xyz("D65"), [0.9505, 1.0, 1.089], atol=1e-3)


@pytest.mark.parametrize("illuminant", ["D65", "A"])
def test_camera_to_xyz_d65(illuminant):
    cam = cal.camera_responses("nikon_d850", illuminant)
    rgb = cam / cal.camera_responses("nikon_d850", illuminant, [1.0])[0]
    white_d65 = colour_ground_truth.illuminant_white_xyz("D65")
    cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(
        colour_ground_truth.illuminant_white_xyz(illuminant), white_d65, "Bradford")
    reference = colour_ground_truth.reflectance_xyz(illuminant) @ np.asarray(cat).T
    white_xy = colour.XYZ_to_xy(white_d65)
    errors = {}
    for method in cal.CORRECTION_METHODS:
        fit = cal.camera_to_xyz_d65("nikon_d850", illuminant, method=method)
        predicted = rgb @ fit.T if method == "linear" else fit(rgb)
        errors[method] = colour.delta_E(colour.XYZ_to_Lab(predicted, white_xy),
                                        colour.XYZ_to_Lab(reference, white_xy), method="CIE 2000").mean()
    linear = cal.camera_to_xyz_d65("nikon_d850", illuminant)
    np.testing.assert_allclose(linear @ np.ones(3), white_d65, atol=1e-12)  # white stays white
    assert errors["linear"] < 2.0
    assert errors["root_polynomial"] < errors["linear"]
    with pytest.raises(ConfigError, match="linear, root_polynomial"):
        cal.camera_to_xyz_d65("nikon_d850", illuminant, method="cubic")


def test_as_shot_neutral_agrees_with_simulated_sensor():
    bands = spectra.parse_bands("400:700:10")
    wl, irradiance = spectra.absolute_irradiance("A", 100.0)
    radiance = spectra.band_integrals(irradiance / np.pi, wl, bands)
    cfg = scene_from_dict({"sensor": {"width_px": 16, "height_px": 16}, "illuminant": {"spd": "A"},
                           "exposure": {"time_s": 0.001}})
    image = SpectralImage(np.broadcast_to(radiance.astype(np.float32), (16, 16, 31)).copy(),
                          np.asarray(bands.centres_nm), np.asarray(bands.edges_nm))
    raw = S.expose(image, cfg)
    np.testing.assert_allclose(raw.as_shot_neutral, cal.as_shot_neutral("nikon_d850", "A"), rtol=0.005)


def test_ideal_camera_has_identical_channels():
    responses = cal.camera_responses("ideal", "D65")
    np.testing.assert_allclose(responses[:, 0], responses[:, 2])
    with pytest.raises(ConfigError, match="three distinct"):
        cal.xyz_to_camera_matrix("ideal", "D65")


@pytest.mark.parametrize("illuminant", ["D65", "A"])
def test_root_polynomial_correction_keeps_white_neutral(illuminant):
    # the white-balanced white (1, 1, 1) must land on D65's white, as the 3×3 fit does
    import colour

    correction = cal.camera_to_xyz_d65("nikon_d850", illuminant, method="root_polynomial")
    xyz = correction(np.ones((1, 3)))[0]
    d65 = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])
    assert colour.delta_E(colour.XYZ_to_Lab(xyz, colour.XYZ_to_xy(d65)), [100, 0, 0], method="CIE 2000") < 0.05


# ----------------------------------------------------------------------------- issue 39 #8
def _flat_capture_dng(camera: str, path):
    """A 32 × 32 grey flat field exposed by ``camera`` (the full expose → write_dng path) as a DNG."""
    from spectral_cam.raw import write_dng

    bands = spectra.parse_bands("400:700:20")
    wl, irradiance = spectra.absolute_irradiance("D65", 100.0)
    radiance = spectra.band_integrals(0.18 * irradiance / np.pi, wl, bands)
    cfg = scene_from_dict({"sensor": {"width_px": 32, "height_px": 32, "model": camera},
                           "illuminant": {"spd": "D65"}, "exposure": {"time_s": 0.001}})
    image = SpectralImage(np.broadcast_to(radiance.astype(np.float32), (32, 32, len(bands.centres_nm))).copy(),
                          np.asarray(bands.centres_nm), np.asarray(bands.edges_nm))
    return write_dng(S.expose(image, cfg), path)


@pytest.mark.timeout(600)
def test_every_cameras_written_hue_sat_map_keeps_value_scale_exactly_1_at_zero_saturation(tmp_path):
    """Issue 39 #8. The DNG specification (ProfileHueSatMapData, ch. 6) wants the value scale of
    every zero-saturation entry to be exactly 1.0; Adobe's SDK (dng_hue_sat_map::SetDelta) warns
    "Value scale for zero saturation entries must be 1.0" and resets it otherwise (five cameras'
    maps stored 0.99999994 when a penalty pulled them towards 1). For each bundled camera the
    DNG written by expose → write_dng is read back with tifffile (the float32 the file holds), and
    Adobe's DNG SDK (dngpy, a test extra) parses every one of them without that warning."""
    import subprocess
    import sys

    import tifffile

    from spectral_cam.raw.dng import DNG_TAGS

    paths = []
    for camera in spectra.camera_names():
        path = _flat_capture_dng(camera, tmp_path / f"{camera}.dng")
        with tifffile.TiffFile(path) as tif:
            tags = tif.pages[0].tags
            hues, sats, values = tags[DNG_TAGS["ProfileHueSatMapDims"]].value
            for slot in (1, 2):
                data = np.asarray(tags[DNG_TAGS[f"ProfileHueSatMapData{slot}"]].value, dtype=np.float32)
                table = data.reshape(values, hues, sats, 3)
                zero_sat_value = table[:, :, 0, 2]
                assert np.all(zero_sat_value == np.float32(1.0)), (camera, slot, zero_sat_value[zero_sat_value != 1])
        paths.append(str(path))
    dngpy = pytest.importorskip("dngpy", reason="dngpy (Adobe's DNG SDK) is a test extra: pip install -e '.[test]'")
    assert dngpy
    script = ("import sys, dngpy\n"
              "for path in sys.argv[1:]:\n"
              "    dng = dngpy.Dng(path)\n"
              "    dng.raw_pixels, dng.metadata, dng.color_info\n")
    run = subprocess.run([sys.executable, "-c", script, *paths], capture_output=True, text=True, timeout=300,
                         check=False)
    assert run.returncode == 0, run.stderr
    assert "zero saturation" not in run.stdout + run.stderr, run.stdout + run.stderr
