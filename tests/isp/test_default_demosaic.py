"""The default demosaic (issue 12 #2; rcd since issue 37 #7, before it menon2007): on pixel-aligned
edges of an achromatic checkerboard — the bundled ColorChecker and dof scenes — it leaves the
least false colour of the registered methods, and less error than malvar2004 (the default before
issue 12). Off-grid edges between colours: tests/isp/test_edge_false_colour.py. Reference: any chroma of an achromatic scene is error (Li, Gunturk &
Zhang 2008, Proc. SPIE 6822)."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.isp import ISPConfig
from spectral_cam.isp.demosaic import bayer_methods, demosaic

pytestmark = pytest.mark.timeout(60)


def _checkerboard(square_px: int, size: int) -> np.ndarray:
    y, x = np.mgrid[0:size, 0:size] // square_px
    return np.where((x + y) % 2 == 0, 0.8, 0.1).astype(np.float32)


def _errors(truth: np.ndarray, method: str) -> tuple[float, float]:
    """(false colour, mean absolute error) of an achromatic image's mosaic, 6 px in from the edges."""
    rgb = demosaic(truth, "RGGB", method=method)[6:-6, 6:-6]
    false_colour = float(np.mean(rgb.max(axis=-1) - rgb.min(axis=-1)))
    return false_colour, float(np.mean(np.abs(rgb - truth[6:-6, 6:-6, None])))


@pytest.mark.parametrize("square_px", [16, 32])
def test_the_default_demosaic_has_the_least_false_colour_on_pixel_aligned_edges(square_px):
    # 16 px: the dof scene's checkers; 32 px and up: the ColorChecker's patch edges
    truth = _checkerboard(square_px, 96)  # every CFA site of a grey scene reads the grey
    results = {method: _errors(truth, method) for method in bayer_methods()}
    default = ISPConfig().demosaic
    assert default == "rcd"
    assert results[default][0] == min(fc for fc, _ in results.values())
    # measured at 16 px: rcd 0.0024, menon2007 0.029, malvar2004 0.066 of white
    assert results[default][0] < 0.2 * results["menon2007"][0] < 0.6 * results["malvar2004"][0]
    assert results[default][1] == min(err for _, err in results.values())


def test_on_8_px_squares_every_method_leaves_about_the_same_false_colour():
    # where edges are 4 px apart the linear and directional methods leave about the same (measured:
    # vng 0.133, menon2007 0.125, malvar2004 0.138 of white); rcd's ratios of a grey mosaic hold
    # (0.013): the default is the best
    results = {method: _errors(_checkerboard(8, 96), method)[0] for method in bayer_methods()}
    assert results[ISPConfig().demosaic] <= 1.03 * min(results.values())
