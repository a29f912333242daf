"""Linear Raw DNGs (three colours per pixel, PhotometricInterpretation 34892: phones' ProRAW,
converted raws; issue 13 #4): written, read back bit for bit, and developed by our ISP as LibRaw
develops them. References: LibRaw (rawpy) on the same file; colour-science's ground truth."""

from __future__ import annotations

import numpy as np
import pytest
import rawpy

from spectral_cam import expose, scene_from_dict
from spectral_cam.radiance_targets import reflectance_set, synthetic_chart
from spectral_cam.colour_ground_truth import patch_linear_srgb
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.metrics import colorchecker_delta_e, patch_means
from spectral_cam.raw import RawImage, read_raw, write_dng
from spectral_cam.sensor import signal_model

pytestmark = pytest.mark.timeout(120)

QUIET = {"shot_noise": False, "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0}


def _linear_chart_dng(tmp_path):
    """The ColorChecker under D65 as linear camera RGB (every channel at every pixel, through the
    sensor's own signal model), white at 0.7 of the range, with the sensor's D65 colour metadata."""
    chart = synthetic_chart(reflectance_set("colorchecker"), "D65", patch_px=16, gap_px=4)
    height, width = chart.radiance.data.shape[:2]
    config = scene_from_dict({"scene": {"preset": "flat_field"},
                              "sensor": {"width_px": width, "height_px": height, "vignetting": False, **QUIET}})
    mosaic_raw = expose(chart.radiance, config)  # for the colour metadata the sensor writes
    rgb = np.asarray(chart.radiance.data, float) @ np.asarray(signal_model(chart.radiance, config).weights, float)
    white = patch_means(rgb, [chart.patches[chart.white_index]])[0].max()
    black, top = 64.0, 4095
    dn = np.round(black + rgb / white * 0.7 * (top - black)).astype(np.uint16)
    raw = RawImage(dn, "linear", black, top, color_matrix=mosaic_raw.color_matrix,
                   as_shot_neutral=mosaic_raw.as_shot_neutral, camera_model="spectral_cam linear test")
    return chart, raw, write_dng(raw, tmp_path / "linear.dng")


def test_a_linear_raw_dng_round_trips_through_libraw(tmp_path):
    _, raw, path = _linear_chart_dng(tmp_path)
    back = read_raw(path)
    assert back.cfa == "linear" and back.mosaic.shape == raw.mosaic.shape
    np.testing.assert_array_equal(back.mosaic, raw.mosaic)
    np.testing.assert_allclose(back.as_shot_neutral, raw.as_shot_neutral, rtol=1e-5)
    np.testing.assert_allclose(back.color_matrix, raw.color_matrix, atol=2e-4)


def test_we_develop_a_linear_raw_dng_as_libraw_does(tmp_path):
    chart, _, path = _linear_chart_dng(tmp_path)
    ours = develop(read_raw(path), ISPConfig(colour_matrix="dng", tone="linear")).linear
    with rawpy.imread(str(path)) as handle:
        libraw = handle.postprocess(use_camera_wb=True, no_auto_bright=True, gamma=(1, 1), output_bps=16,
                                    output_color=rawpy.ColorSpace.sRGB, user_flip=0).astype(float) / 65535.0
    patches = chart.patches[:24]
    truth = patch_linear_srgb("D65")
    against_libraw = colorchecker_delta_e(ours, patch_means(libraw, patches), patches)
    against_truth = colorchecker_delta_e(ours, truth, patches)
    assert against_libraw["mean"] < 0.1, against_libraw["mean"]  # measured 0.018
    assert against_truth["mean"] < 1.0, against_truth["mean"]    # 0.95: what the D65 3×3 matrix allows
    # exposure: we map (DN − black)/(white − black) as the DNG spec says; LibRaw divides this
    # linear raw by the white level alone, (white − black)/white darker (measured to 0.1 %)
    y = np.array([0.2126, 0.7152, 0.0722])
    white = [chart.patches[chart.white_index]]
    ratio = (patch_means(ours, white)[0] @ y) / (patch_means(libraw, white)[0] @ y)
    assert ratio == pytest.approx(4095 / (4095 - 64), rel=2e-3)


def test_adobes_sdk_reads_a_linear_raw_dng_without_a_warning(tmp_path):
    """Issue 25 #17: WhiteLevel with one value for three samples made Adobe's SDK warn; one per
    sample (DNG 1.7.1.0 ch. 4) reads clean (the SDK prints each departure it notices)."""
    import subprocess
    import sys

    import tifffile

    import dngpy  # noqa: F401  (Adobe's DNG SDK: the test extra installs it; the script below imports it)
    _, _, path = _linear_chart_dng(tmp_path)
    with tifffile.TiffFile(path) as tif:
        assert len(np.atleast_1d(tif.pages[0].tags[50717].value)) == 3
    script = ("import sys, dngpy\n"
              "dng = dngpy.Dng(sys.argv[1])\n"
              "dng.raw_pixels, dng.metadata, dng.color_info\n")
    run = subprocess.run([sys.executable, "-c", script, str(path)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert "WhiteLevel" not in run.stdout + run.stderr, run.stdout + run.stderr
