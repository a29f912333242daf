"""Study (a): demosaicing on checkerboards and a zone plate (:mod:`spectral_cam.apps.stress.demosaic`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spectral_cam.apps.stress.demosaic import checkerboard, demosaic_errors, demosaic_study, plot_demosaic, zone_plate
from spectral_cam.errors import ConfigError
from spectral_cam.isp.demosaic import bayer_methods


def test_checkerboard_and_zone_plate_are_what_they_claim():
    board = checkerboard(2, (4, 6))
    np.testing.assert_array_equal(board, [[1, 1, 0, 0, 1, 1], [1, 1, 0, 0, 1, 1],
                                          [0, 0, 1, 1, 0, 0], [0, 0, 1, 1, 0, 0]])
    np.testing.assert_array_equal(checkerboard(2, (4, 6), offset=(1, 1))[0], [1, 0, 0, 1, 1, 0])
    plate, frequency = zone_plate(64)
    assert plate.min() >= 0 and plate.max() <= 1
    # local frequency k·r rises linearly to 0.5 cycles/px at the middle of each edge
    assert frequency[32, 63] == pytest.approx(0.5 * math.hypot(31.5, 0.5) / 32)
    assert frequency[32, 32] == pytest.approx(0.5 * math.hypot(0.5, 0.5) / 32)
    with pytest.raises(ConfigError, match="square size"):
        checkerboard(0, (4, 4))


def test_bilinear_fails_on_1px_squares_and_recovers_on_8px():
    """A 1-px black-and-white checkerboard puts white on every R and B site and black on
    every G site (RGGB): the mosaic is indistinguishable from a flat magenta, so every
    channel is wrong by half the white level on average and the false colour is total."""
    errors = {}
    for size in (1, 2, 4, 8):
        runs = [demosaic_errors(checkerboard(size, (64, 64), offset=(dy, dx)), method="bilinear")
                for dy in (0, 1) for dx in (0, 1)]
        errors[size] = (np.mean([r["mae_all"] for r in runs]), np.mean([r["false_colour"] for r in runs]))
    assert errors[1][0] == pytest.approx(0.5, abs=1e-6) and errors[1][1] == pytest.approx(1.0, abs=1e-6)
    assert errors[8][0] < 0.12 and errors[8][1] < 0.25
    assert errors[1][0] > errors[2][0] > errors[4][0] > errors[8][0]


@pytest.mark.parametrize("method", bayer_methods())
def test_every_method_is_lossless_on_constant_fields(method):
    for level in (0.0, 0.37, 1.0):
        result = demosaic_errors(np.full((32, 36), level, np.float32), method=method)
        assert result["mae"].max() < 2e-3 and result["false_colour"] < 2e-3, (level, result["mae"])


def test_demosaic_study_charts_error_against_size_and_frequency(tmp_path, tiny):
    result = demosaic_study(tiny, methods=["bilinear", "malvar2004"])
    data = result["data"]["methods"]
    for method, entry in data.items():
        assert entry["checker_mae"][0] == pytest.approx(0.5, abs=1e-6)  # 1-px squares
        rings = entry["zone_mae"]
        assert rings[0] < 0.01 < rings[-1]  # flat centre fine, near-Nyquist ring broken
        assert entry["zone_lossless_frequency"] > 0
        assert entry["zone_lossless_feature_px"] == pytest.approx(0.5 / entry["zone_lossless_frequency"])
    # gradient correction keeps detail lossless to a higher frequency than bilinear
    assert data["malvar2004"]["zone_lossless_frequency"] >= data["bilinear"]["zone_lossless_frequency"]
    metrics = {(r["case"], r["metric"]) for r in result["rows"]}
    assert ("bilinear", "lossless zone-plate half period") in metrics
    files = plot_demosaic(result, tmp_path)
    assert all((tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for name in files)
