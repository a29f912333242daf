"""Issue 28 #1: honest calibration. The RAW's colour matrices are fitted on a training set (the
rawtoaces reflectances) disjoint from the sets a validation scores; the DNG and every cell say so,
and an out-of-sample score recomputed with colour-science alone (the camera's curves, the
reflectances and the DNG's own ColorMatrix and AsShotNeutral) equals the report's."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.apps.validate import plan_from_dict, run_plan
from spectral_cam.reflectance_sets import reflectance_set
from spectral_cam.sensor.colour_calibration import TRAINING_SET, xyz_to_camera_matrix
from spectral_cam.spectra import camera_sensitivities

pytestmark = pytest.mark.timeout(240)

NOISELESS = {"shot_noise": False, "read_noise_e": 0.0, "prnu": 0.0, "dsnu_e": 0.0, "dark_current_e_per_s": 0.0}


def _dng_tags(path):
    """ColorMatrix of the D65 slot (CalibrationIlluminant 21), AsShotNeutral and ProfileName, read
    with tifffile."""
    import tifffile

    def rational(tag):
        pairs = np.asarray(tag.value, dtype=float).reshape(-1, 2)
        return pairs[:, 0] / pairs[:, 1]

    with tifffile.TiffFile(path) as tif:
        tags = tif.pages[0].tags
        slot = 50721 if tags[50778].value == 21 else 50722
        return rational(tags[slot]).reshape(3, 3), rational(tags[50728]), tags[50936].value


def test_an_out_of_sample_score_recomputed_with_colour_science_equals_the_report(tmp_path):
    """CIE 2017's 99 samples under D65 on a D850, developed through the DNG's matrix, noise-free:
    colour-science's camera responses (1 nm) through the DNG's ColorMatrix (XYZ = C⁻¹·camera, the
    white at AsShotNeutral) give CIEDE2000 against colour-science's XYZ whose mean equals the
    report's within 0.02 (measured 0.009: the chart's 10-nm bands) and every patch within 0.3."""
    import colour

    plan = plan_from_dict({"validate": {"illuminants": ["D65"], "cameras": ["nikon_d850"],
                                        "reflectance_sets": ["cie2017"], "patch_px": 8, "gap_px": 2,
                                        "swatches": "none"},
                           "sensor": NOISELESS,
                           "pipeline": [{"type": "ours", "name": "dng",
                                         "isp": {"colour_matrix": "dng", "tone": "linear", "demosaic": "bilinear"}}]})
    result = run_plan(plan, tmp_path / "report")
    (cell,) = result.cells
    assert cell.calibration.startswith(f"out of sample (fitted on {TRAINING_SET}")
    matrix, neutral, profile = _dng_tags(next((tmp_path / "report" / "raw").glob("*.dng")))
    assert TRAINING_SET in profile

    shape = colour.SpectralShape(380, 780, 1)
    curves = camera_sensitivities("nikon_d850").to_colour().copy().align(
        shape, extrapolator_kwargs={"method": "Constant", "left": 0, "right": 0})
    d65 = colour.SDS_ILLUMINANTS["D65"].copy().align(shape)
    sds = [sd.to_colour().copy().align(shape) for sd in reflectance_set("cie2017").sds]
    camera = (np.stack([sd.values for sd in sds]) * d65.values) @ curves.values
    camera = camera / (d65.values @ curves.values) * neutral  # a white diffuser reads AsShotNeutral
    xyz = camera @ np.linalg.inv(matrix).T
    truth = np.stack([colour.sd_to_XYZ(sd, illuminant=d65) for sd in sds]) / 100
    white = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    delta = colour.delta_E(colour.XYZ_to_Lab(xyz, white), colour.XYZ_to_Lab(truth, white), method="CIE 2000")
    assert delta.mean() == pytest.approx(cell.stats["delta_e_mean"], abs=0.02)
    assert np.abs(delta - cell.delta_e[:len(sds)]).max() < 0.3


def test_the_matrices_are_fitted_on_the_training_set_not_the_colorchecker():
    """The DNG matrix is the white-preserving fit on the rawtoaces reflectances (refitting on them
    gives it exactly), differs from the ColorChecker fit, and a cell scoring the training set itself
    is marked in sample."""
    from spectral_cam.apps.validate import calibration_sample
    from spectral_cam.sensor.colour_calibration import training_record

    trained = xyz_to_camera_matrix("nikon_d850", "D65")
    refit = xyz_to_camera_matrix("nikon_d850", "D65", reflectances=list(reflectance_set(TRAINING_SET).sds))
    on_chart = xyz_to_camera_matrix("nikon_d850", "D65", reflectances=list(reflectance_set("colorchecker").sds))
    np.testing.assert_allclose(trained, refit, rtol=1e-12)
    assert np.abs(trained - on_chart).max() > 1e-3
    meta = {"colour_calibration": training_record()}
    assert training_record()["training_count"] == 190
    assert calibration_sample("rawtoaces", meta) == "in sample (rawtoaces)"
    assert calibration_sample("colorchecker", meta).startswith("out of sample")
