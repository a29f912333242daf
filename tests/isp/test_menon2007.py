"""Our float32/OpenCV Menon (2007) demosaicing against colour-demosaicing's reference
implementation of the same paper (Mansencal et al., BSD-3-Clause): equal to float32 rounding
away from the border, and as accurate as the reference at the border."""

from __future__ import annotations

import numpy as np
import pytest
from colour_demosaicing import demosaicing_CFA_Bayer_Menon2007, mosaicing_CFA_Bayer

from spectral_cam.isp.demosaic import menon2007
from spectral_cam.isp.menon2007 import REACH_PX

pytestmark = pytest.mark.timeout(60)


@pytest.mark.parametrize("cfa", ["RGGB", "BGGR", "GRBG", "GBRG"])
@pytest.mark.parametrize("shape", [(48, 64), (49, 67)])
@pytest.mark.parametrize("refining_step", [True, False])
def test_interior_equals_colour_demosaicing(cfa, shape, refining_step):
    mosaic = np.random.default_rng(sum(shape)).uniform(0, 1, shape).astype(np.float32)
    ours = menon2007(mosaic, cfa, refining_step=refining_step)
    reference = demosaicing_CFA_Bayer_Menon2007(mosaic.astype(np.float64), cfa, refining_step=refining_step)
    inner = (slice(REACH_PX, -REACH_PX), slice(REACH_PX, -REACH_PX))
    # white noise is the hardest input: every decision and difference is exercised
    np.testing.assert_allclose(ours[inner], reference[inner], atol=2e-6)
    for c, site in enumerate("RGB"):  # measured samples are kept
        mask = np.zeros((2, 2), bool)
        mask.flat[[i for i, ch in enumerate(cfa) if ch == site]] = True
        keep = np.tile(mask, (shape[0] // 2 + 1, shape[1] // 2 + 1))[: shape[0], : shape[1]]
        np.testing.assert_array_equal(ours[..., c][keep], mosaic[keep])


@pytest.mark.parametrize("cfa", ["RGGB", "GBRG"])
def test_borders_as_accurate_as_the_reference(cfa):
    """On a smooth colour image, mosaicked, the error in the outer REACH_PX (20) pixels (where
    the two pad differently) is of the reference's size (measured, RGGB: mean 6.2e-4 vs 5.5e-4,
    max 0.021 vs 0.022; GBRG 6.1e-4 vs 6.2e-4): padding once instead of at every step costs no accuracy."""
    y, x = np.mgrid[0:64, 0:80] / 64.0
    truth = np.stack([0.5 + 0.3 * np.sin(3 * x + y), 0.4 + 0.2 * np.cos(2 * y), 0.3 + 0.2 * x * y], -1)
    mosaic = mosaicing_CFA_Bayer(truth, cfa).astype(np.float32)
    border = np.ones(truth.shape[:2], bool)
    border[REACH_PX:-REACH_PX, REACH_PX:-REACH_PX] = False
    ours = np.abs(menon2007(mosaic, cfa) - truth)[border]
    reference = np.abs(demosaicing_CFA_Bayer_Menon2007(mosaic, cfa) - truth)[border]
    assert ours.mean() <= 1.3 * reference.mean() and ours.max() <= 1.1 * reference.max(), (
        ours.mean(), reference.mean(), ours.max(), reference.max())
