"""Hostile input to the ISP: tiny, odd-sized, non-finite or non-numeric mosaics give an image
of that size or a clear error, never a NaN image."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from spectral_cam.errors import (
    ConfigError,
    SpectralCamError,
)
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.isp.demosaic import bayer_methods
from spectral_cam.raw import RawImage


# ============================================================================= robustness: ISP
def _raw(mosaic, cfa="RGGB"):
    return RawImage(mosaic, cfa, 256, 4095, as_shot_neutral=np.array([0.5, 1.0, 0.7]))


@pytest.mark.parametrize("shape", [(0, 0), (0, 8), (1, 8), (8, 1)])
def test_develop_refuses_mosaics_too_small_for_a_bayer_tile(shape):
    for balance in ("as_shot", "grey_world"):
        with pytest.raises(ConfigError):
            develop(_raw(np.full(shape, 1000, np.uint16)), ISPConfig(white_balance=balance))


@pytest.mark.parametrize("shape", [(2, 2), (3, 5), (7, 9), (31, 45)])
@pytest.mark.parametrize("method", bayer_methods())
def test_develop_odd_sizes_give_finite_images_of_that_size(shape, method):
    rng = np.random.default_rng(sum(shape))
    out = develop(_raw(rng.integers(300, 4000, shape).astype(np.uint16)), ISPConfig(demosaic=method))
    assert out.image.shape == shape + (3,) and np.all(np.isfinite(out.image))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_develop_never_returns_a_silent_nan_image(bad):
    """A float mosaic holding a NaN or an infinity: a clear error (or a documented, warned
    sanitisation) — not a NaN image."""
    mosaic = np.full((16, 16), 1000.0)
    mosaic[5, 7] = bad
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            out = develop(_raw(mosaic), ISPConfig())
        except SpectralCamError as exc:
            assert "finite" in str(exc) or "NaN" in str(exc)
            return
    assert any(issubclass(w.category, UserWarning) for w in caught), "sanitised without a warning"
    assert np.all(np.isfinite(out.image)) and np.all(np.isfinite(out.linear))


@pytest.mark.parametrize("mosaic", [
    np.full((8, 8), 1000 + 5j),
    np.array([[None] * 8] * 8),
    np.array([["1000"] * 8] * 8),
], ids=["complex", "object", "str"])
def test_develop_rejects_non_numeric_mosaics(mosaic):
    with pytest.raises(SpectralCamError, match="dtype|number"):
        develop(_raw(mosaic), ISPConfig())
