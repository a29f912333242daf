"""Hostile input to the sensor: any radiance gives a frame or a clear SensorError, never a
crash, a NaN or a silently wrong frame."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spectral_cam import sensor as S
from spectral_cam.errors import (
    SensorError,
)
from spectral_cam.image import SpectralImage
from spectral_cam.scene import scene_from_dict

WAVELENGTHS = np.arange(400.0, 701.0, 10.0)
EDGES = np.append(WAVELENGTHS - 5.0, WAVELENGTHS[-1] + 5.0)


# ============================================================================= robustness: sensor
def _image(data, wavelengths=WAVELENGTHS, edges=EDGES):
    return SpectralImage(data, wavelengths, edges)


def _sensor_config(size=16, **exposure):
    return scene_from_dict({"sensor": {"width_px": size, "height_px": size},
                            "exposure": {"time_s": 0.01, **exposure}})


GOOD = np.full((16, 16, 31), 0.01, np.float32)


@pytest.mark.parametrize("data, message", [
    (GOOD.astype(np.int32), "float32 or float64, not int32"),
    ((GOOD * 1000).astype(np.uint16), "float32 or float64, not uint16"),
    (GOOD.astype(np.complex128), "float32 or float64, not complex128"),
    (GOOD > 0, "float32 or float64, not bool"),
    (GOOD.astype(object), "float32 or float64, not object"),
    (GOOD.tolist(), r"\(H, W, B\)"),
    (GOOD[None], r"\(H, W, B\)"),
    (np.zeros((0, 0, 31), np.float32), "0×0 pixels but the sensor is 16×16"),
], ids=["int32", "uint16", "complex", "bool", "object", "list", "4-D", "zero-size"])
def test_expose_rejects_wrong_dtypes_and_shapes(data, message):
    with pytest.raises(SensorError, match=message):
        S.expose(_image(data), _sensor_config())


def test_expose_rejects_bad_wavelength_grids():
    with pytest.raises(SensorError, match="no bands"):
        S.expose(_image(np.zeros((16, 16, 0), np.float32), np.array([]), np.array([400.0])), _sensor_config())
    with pytest.raises(SensorError, match="finite, positive band centres"):
        S.expose(_image(GOOD, np.where(WAVELENGTHS == 500, np.nan, WAVELENGTHS)), _sensor_config())
    with pytest.raises(SensorError, match="increasing band edges"):
        S.expose(_image(GOOD, WAVELENGTHS, EDGES[::-1]), _sensor_config())


@pytest.mark.parametrize("value", [-np.inf, np.nan])
def test_expose_finds_bad_values_in_any_chunk_and_with_auto_exposure(value):
    data = np.full((600, 200, 31), 0.01, np.float32)  # several row chunks
    data[517, 123, 29] = value
    for exposure in ({}, {"time_s": "auto"}):
        with pytest.raises(SensorError, match=r"row 517, column 123\), band 29"):
            S.expose(_image(data), scene_from_dict({"sensor": {"width_px": 200, "height_px": 600},
                                                    "exposure": {"time_s": 0.01, **exposure}}))


@pytest.mark.parametrize("method", S.SHOT_NOISE_METHODS)
@pytest.mark.parametrize("radiance", [1e25, 1e33])
def test_absurdly_bright_finite_radiance_saturates_or_is_a_clear_error(method, radiance):
    """Finite, non-negative radiance is valid input however bright: the frame saturates
    (or a SensorError explains the overflow) — never an IndexError or a NumPy ValueError."""
    try:
        raw = S.expose(_image(np.full((16, 16, 31), radiance, np.float32)), _sensor_config(),
                       shot_noise_method=method)
    except SensorError as exc:
        assert "radiance" in str(exc)
        return
    assert raw.mosaic.min() >= raw.white_level - 3 and raw.mosaic.max() == raw.white_level


@settings(max_examples=60, deadline=None)
@given(st.floats(allow_nan=True, allow_infinity=True, width=32), st.integers(0, 7), st.integers(0, 7),
       st.integers(0, 30), st.sampled_from(S.SHOT_NOISE_METHODS))
def test_any_single_radiance_value_gives_a_frame_or_a_sensor_error(value, row, col, band, method):
    data = np.full((8, 8, 31), 0.02, np.float32)
    data[row, col, band] = value
    try:
        raw = S.expose(_image(data), _sensor_config(8), shot_noise_method=method)
    except SensorError as exc:
        assert not (math.isfinite(value) and value >= 0) or "radiance" in str(exc)
        if not math.isfinite(value) or value < 0:
            assert f"row {row}, column {col}" in str(exc)
        return
    assert math.isfinite(value) and value >= 0
    assert raw.mosaic.dtype == np.uint16 and raw.mosaic.shape == (8, 8) and raw.mosaic.max() <= raw.white_level


def test_overflowing_radiance_is_refused_without_a_numpy_warning():
    """Issue 25 #24: 1e33 W·m⁻²·sr⁻¹ overflows float32 in the camera equation; the overflow is
    the refusal's reason, not a RuntimeWarning printed by NumPy."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        try:
            S.expose(_image(np.full((16, 16, 31), 1e33, np.float32)), _sensor_config())
        except SensorError as exc:
            assert "radiance" in str(exc)
