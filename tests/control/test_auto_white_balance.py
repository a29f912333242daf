"""Issue 17 #3: auto white balance estimators against the truth computed from the camera's own
curves with colour-science (blackbody and CIE daylight illuminants at several CCTs), grey world's
measured failure on foliage, and the controller's smoothing and modes."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.control import AutoWhiteBalance, estimate_white
from spectral_cam.control.white_balance_loop import angular_error_deg
from spectral_cam.reflectance_sets import reflectance_set
from spectral_cam.sensor.colour_calibration import camera_responses

pytestmark = pytest.mark.timeout(120)
CAMERA = "nikon_d850"


def _daylight(kelvin):
    import colour

    return colour.sd_CIE_illuminant_D_series(colour.temperature.CCT_to_xy_CIE_D(kelvin))


ILLUMINANTS = {"blackbody 2856 K": "blackbody:2856", "blackbody 4000 K": "blackbody:4000",
               "D50": _daylight(5003), "D65": "D65", "D75": _daylight(7504)}


def _frame(illuminant, reflectances, seed=0, tiles=12, px=12):
    """A mosaic of reflectance tiles (slightly blurred, so it has edges) as linear camera RGB
    through the camera's measured curves, and the truth: the camera RGB of a white diffuser."""
    from scipy import ndimage

    rgb = camera_responses(CAMERA, illuminant, reflectances)
    index = np.random.default_rng(seed).integers(len(rgb), size=(tiles, tiles))
    image = ndimage.gaussian_filter(rgb[index].repeat(px, 0).repeat(px, 1), (1, 1, 0))
    return image / image.max() * 0.8, camera_responses(CAMERA, illuminant, [1.0])[0]


@pytest.mark.parametrize("name", ILLUMINANTS)
def test_estimates_on_a_varied_scene_are_near_the_true_white(name):
    """Tiles of the 99 CIE 2017 samples: grey world within 2° of the truth (measured 0.6–1.4°),
    grey edge within 4° (1.6–3.6°), the locus estimate within 2.5° (1.5–2.3°)."""
    image, truth = _frame(ILLUMINANTS[name], reflectance_set("cie2017").sds)
    bounds = {"grey_world": 2.0, "grey_edge": 4.0, "locus": 2.5}
    for method, bound in bounds.items():
        assert angular_error_deg(estimate_white(image, method, camera=CAMERA), truth) < bound, method


def test_grey_world_fails_on_foliage_as_documented():
    """Green leaves with a little soil in daylight (D65): grey world's error exceeds 8° (measured
    9.8°) — the scene is not grey on average — while the edge-based and locus estimates stay
    near 5°: the failure the drift study shows."""
    names = reflectance_set("usgs_vegetation").names
    leaves = [sd for sd, n in zip(reflectance_set("usgs_vegetation").sds, names) if n.startswith("green")]
    foliage = leaves * 3 + [reflectance_set("usgs_soils").sds[0]]
    image, truth = _frame("D65", foliage)
    grey_world = angular_error_deg(estimate_white(image, "grey_world"), truth)
    locus = angular_error_deg(estimate_white(image, "locus", camera=CAMERA), truth)
    assert grey_world > 8.0 and locus < 6.0 and locus < grey_world - 3.0


def test_the_controller_smooths_locks_and_obeys_manual():
    """Smoothing 0.75 moves a quarter of the way (in log chromaticity) towards each new
    estimate; locked keeps the first frame's white; manual returns its white."""
    warm, _ = _frame("blackbody:2856", reflectance_set("cie2017").sds)
    cool, _ = _frame("D65", reflectance_set("cie2017").sds)
    smooth = AutoWhiteBalance(method="grey_world", smoothing=0.75)
    first = smooth.step(None, warm)
    second = smooth.step(first, cool)
    target = estimate_white(cool, "grey_world")
    expected = np.exp(0.75 * np.log(first.white) + 0.25 * np.log(target))
    assert np.allclose(second.white, expected / expected[1])
    locked = AutoWhiteBalance(mode="locked")
    assert locked.step(locked.step(None, warm), cool).white == locked.step(None, warm).white
    assert AutoWhiteBalance(mode="manual", manual_white=(0.5, 1.0, 2.0)).step(None, warm).gains == (2.0, 1.0, 0.5)
