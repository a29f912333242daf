"""Fixtures of the stress-study tests: tiny study settings."""

from __future__ import annotations

import pytest

from spectral_cam.apps.stress import StressSettings


@pytest.fixture(scope="session")
def tiny():
    """Study settings small enough for seconds-long tests."""
    return StressSettings.quick().replace(
        square_sizes_px=(1, 2, 4, 8), zone_plate_px=128, frequency_bins=16, exposure_levels=7, flat_px=48,
        highlight_factors=(1.0, 4.0), optics_px=40, optics_spp=512, patch_px=10)
