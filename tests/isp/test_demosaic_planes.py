"""The demosaicers on the four CFA planes in row bands on threads (issue 14 #6) compute what
they computed before: menon2007 bit for bit, malvar2004 and bilinear to float32 rounding
(against the previous implementations, kept in tests/isp/demosaic_reference.py), everywhere
including the borders, for every Bayer phase, odd sizes, and any cut into bands and threads."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam.isp import demosaic as module
from spectral_cam.isp.menon2007 import REACH_PX, menon2007_sites

from .demosaic_reference import (
    bilinear_reference,
    malvar2004_reference,
    menon2007_reference,
)

pytestmark = pytest.mark.timeout(120)

PATTERNS = ("RGGB", "BGGR", "GRBG", "GBRG")
SHAPES = [(2, 2), (3, 5), (5, 2), (7, 9), (48, 64), (49, 67), (101, 34)]


def _mosaics(shape):
    """White noise in [0, 1] (every branch of menon2007 taken), and values of mixed sign and
    magnitude (unclipped linear data: below black, highlights, tiny values)."""
    rng = np.random.default_rng(sum(shape))
    noise = rng.uniform(0, 1, shape).astype(np.float32)
    mixed = (rng.standard_normal(shape) * rng.choice([1e-6, 1e-2, 1.0, 40.0], shape)).astype(np.float32)
    return noise, mixed


def _menon_in_bands(mosaic, cfa, *, band_rows, workers, refining_step=True):
    def sites(R, Gr, Gb, B, scratch):
        return menon2007_sites(R, Gr, Gb, B, scratch, refining_step=refining_step)

    return module.by_planes(mosaic, cfa, sites, pad=REACH_PX, offset=0, band_rows=band_rows, workers=workers)


@pytest.mark.parametrize("cfa", PATTERNS)
@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("refining_step", [True, False])
def test_menon2007_equals_the_previous_implementation_bit_for_bit(cfa, shape, refining_step):
    for mosaic in _mosaics(shape):
        reference = menon2007_reference(mosaic, cfa, refining_step=refining_step)
        # the whole frame as one band on one thread
        np.testing.assert_array_equal(
            _menon_in_bands(mosaic, cfa, band_rows=10 ** 6, workers=1, refining_step=refining_step), reference)
        np.testing.assert_array_equal(module.menon2007(mosaic, cfa, refining_step=refining_step), reference)
        # bands of 2 and 5 rows (each with REACH_PX rows of context) on 3 threads
        for band_rows in (2, 5):
            np.testing.assert_array_equal(
                _menon_in_bands(mosaic, cfa, band_rows=band_rows, workers=3, refining_step=refining_step), reference)


def test_menon2007_in_default_bands_on_a_larger_frame_equals_the_previous_implementation():
    mosaic = np.random.default_rng(9).uniform(0, 1, (1100, 390)).astype(np.float32)
    for cfa in ("GRBG", "BGGR"):
        reference = menon2007_reference(mosaic, cfa)
        np.testing.assert_array_equal(module.menon2007(mosaic, cfa), reference)
        np.testing.assert_array_equal(_menon_in_bands(mosaic, cfa, band_rows=module.MENON_BAND_ROWS, workers=4),
                                      reference)


@pytest.mark.parametrize("method, reference", [("bilinear", bilinear_reference),
                                               ("malvar2004", malvar2004_reference)])
@pytest.mark.parametrize("cfa", PATTERNS)
@pytest.mark.parametrize("shape", SHAPES)
def test_linear_methods_equal_the_previous_implementation_to_float32_rounding(method, reference, cfa, shape):
    """Borders included: both mirror about the edge pixel (BORDER_REFLECT_101)."""
    sites = {"bilinear": module._bilinear_sites, "malvar2004": module._malvar_sites}[method]
    for mosaic in _mosaics(shape):
        expected = reference(mosaic, cfa)
        scale = float(np.abs(mosaic).max())
        ours = getattr(module, method)(mosaic, cfa)
        # the previous one summed 9 or 25 products in filter2D's order, ours sums pairs: a few ulp
        np.testing.assert_allclose(ours, expected, rtol=0, atol=4e-7 * scale)
        for band_rows, workers in ((2, 3), (3, 2), (64, 1)):  # the same operations in any band
            np.testing.assert_array_equal(
                module.by_planes(mosaic, cfa, sites, pad=2, offset=1, band_rows=band_rows, workers=workers), ours)


@pytest.mark.parametrize("cfa", PATTERNS)
def test_malvar2004_equals_colour_demosaicing_to_float32_rounding(cfa):
    """Against Mansencal et al.'s implementation of the paper (float64, scipy's 'mirror'
    convolution), away from the 2-pixel border where the kernels reach past the edge."""
    from colour_demosaicing import demosaicing_CFA_Bayer_Malvar2004

    mosaic = np.random.default_rng(2).uniform(0, 1, (47, 62)).astype(np.float32)
    reference = demosaicing_CFA_Bayer_Malvar2004(mosaic.astype(np.float64), cfa)
    ours = module.malvar2004(mosaic, cfa)
    np.testing.assert_allclose(ours[2:-2, 2:-2], reference[2:-2, 2:-2], rtol=0, atol=1e-6)


@pytest.mark.parametrize("cfa", PATTERNS)
def test_bilinear_keeps_samples_and_averages_the_nearest_ones_at_the_border(cfa):
    """Mirror padding about the edge pixel: a missing colour in the first row is the mean of
    the same row's neighbours and the next row's (its own mirror image), e.g. green at a red
    corner is (right + below) / 2."""
    mosaic = np.random.default_rng(4).uniform(0, 1, (6, 8)).astype(np.float32)
    out = module.bilinear(mosaic, cfa)
    index = {"R": 0, "G": 1, "B": 2}
    for (y, x), site in zip(((0, 0), (0, 1), (1, 0), (1, 1)), cfa):
        assert out[y, x, index[site]] == mosaic[y, x]
    if cfa[0] == "R":
        np.testing.assert_allclose(out[0, 0, 1], (mosaic[0, 1] + mosaic[1, 0]) / 2, rtol=1e-6)
        np.testing.assert_allclose(out[0, 0, 2], mosaic[1, 1], rtol=1e-6)


def test_scratch_buffers_are_reused_and_distinct():
    scratch = module._Scratch()
    a, b = scratch("a", (4, 5)), scratch("b", (4, 5))
    assert a.flags.c_contiguous and a.dtype == np.float32 and not np.shares_memory(a, b)
    assert scratch("a", (4, 5)) is a and np.shares_memory(scratch("a", (3, 5)), a)
    mask = scratch("a", (4, 5), np.uint8)
    assert mask.dtype == np.uint8 and not np.shares_memory(mask, a)
    bigger = scratch("a", (6, 5))  # a larger shape: new memory
    assert bigger.shape == (6, 5) and bigger.flags.c_contiguous
