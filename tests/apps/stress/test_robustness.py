"""Where the chain must not fail: hostile input to the sensor, the ISP and the DNG reader
gives a frame, an image or a clear error — never a crash, a NaN image or a half-written file.

(The robustness half of the stress studies' issue; the scene loader's and the EXR reader's
robustness is in ``tests/test_robustness.py``.)
"""

from __future__ import annotations

import logging
import math
import struct
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from spectral_cam import sensor as S
from spectral_cam.cli import main
from spectral_cam.errors import ConfigError, RawFormatError, SensorError, SpectralCamError
from spectral_cam.image import SpectralImage
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.isp.demosaic import DEMOSAIC
from spectral_cam.raw import RawImage, read_raw, write_dng
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


# ============================================================================= robustness: ISP
def _raw(mosaic, cfa="RGGB"):
    return RawImage(mosaic, cfa, 256, 4095, as_shot_neutral=np.array([0.5, 1.0, 0.7]))


@pytest.mark.parametrize("shape", [(0, 0), (0, 8), (1, 8), (8, 1)])
def test_develop_refuses_mosaics_too_small_for_a_bayer_tile(shape):
    for balance in ("as_shot", "grey_world"):
        with pytest.raises(ConfigError):
            develop(_raw(np.full(shape, 1000, np.uint16)), ISPConfig(white_balance=balance))


@pytest.mark.parametrize("shape", [(2, 2), (3, 5), (7, 9), (31, 45)])
@pytest.mark.parametrize("method", list(DEMOSAIC))
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


# ============================================================================= robustness: DNG
@pytest.fixture(scope="module")
def good_dng(tmp_path_factory):
    rng = np.random.default_rng(0)
    raw = RawImage(rng.integers(300, 4000, (32, 40)).astype(np.uint16), "RGGB", 256, 4095,
                   color_matrix=np.array([[0.9, 0.2, -0.1], [-0.3, 1.2, 0.1], [0.05, -0.2, 0.9]]),
                   as_shot_neutral=np.array([0.5, 1.0, 0.7]), noise_profile=(1e-4, 1e-7), camera_model="fuzz")
    return write_dng(raw, tmp_path_factory.mktemp("dng") / "good.dng").read_bytes()


def _tag_entry_offset(data: bytes, code: int) -> int:
    """Byte offset of a tag's 12-byte entry in the first IFD of a little-endian TIFF."""
    assert data[:2] == b"II"
    ifd = struct.unpack_from("<I", data, 4)[0]
    for index in range(struct.unpack_from("<H", data, ifd)[0]):
        offset = ifd + 2 + 12 * index
        if struct.unpack_from("<H", data, offset)[0] == code:
            return offset
    raise KeyError(code)


def _without_cfa_pattern(data: bytes) -> bytes:
    out = bytearray(data)
    struct.pack_into("<H", out, _tag_entry_offset(data, 33422), 33423)  # CFAPattern → an unknown tag
    return bytes(out)


def _black_above_white(data: bytes) -> bytes:
    out = bytearray(data)
    struct.pack_into("<I", out, _tag_entry_offset(data, 50714) + 8, 5000)  # BlackLevel 5000 > WhiteLevel 4095
    return bytes(out)


def test_dng_without_its_cfa_pattern_is_a_raw_format_error(tmp_path, good_dng):
    path = tmp_path / "nocfa.dng"
    path.write_bytes(_without_cfa_pattern(good_dng))
    with pytest.raises(RawFormatError):
        read_raw(path)


@pytest.mark.parametrize("shape", [(16, 16), (21, 23), (22, 22), (23, 25)])
def test_small_and_odd_dngs_round_trip_or_say_why_not(tmp_path, shape):
    """LibRaw refuses raws narrower than 22 pixels; a DNG that write_dng accepted must read
    back, or fail with a message that says so."""
    mosaic = np.random.default_rng(1).integers(300, 4000, shape).astype(np.uint16)
    path = write_dng(_raw(mosaic), tmp_path / "small.dng")
    try:
        back = read_raw(path)
    except RawFormatError as exc:
        assert "22" in str(exc), str(exc)
        return
    np.testing.assert_array_equal(back.mosaic, mosaic)


@pytest.mark.parametrize("case", ["text", "empty", "truncated", "no_cfa_pattern", "black_above_white"])
def test_develop_cli_on_bad_dngs_exits_2_without_output(tmp_path, good_dng, case, capsys):
    payload = {
        "text": b"this is not a raw file",
        "empty": b"",
        "truncated": good_dng[: len(good_dng) // 2],
        "no_cfa_pattern": _without_cfa_pattern(good_dng),
        "black_above_white": _black_above_white(good_dng),
    }[case]
    bad = tmp_path / "bad.dng"
    bad.write_bytes(payload)
    out = tmp_path / "x.png"
    logging.disable(logging.CRITICAL)  # tifffile logs the tags it cannot parse
    try:
        status = main(["develop", str(bad), "-o", str(out)])
    finally:
        logging.disable(logging.NOTSET)
    assert status == 2
    assert capsys.readouterr().err.startswith("spectral-cam: error: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.dng"]


def test_develop_cli_truncated_dng_has_no_traceback(tmp_path, good_dng, capsys):
    bad = tmp_path / "bad.dng"
    bad.write_bytes(good_dng[: len(good_dng) // 3])
    status = main(["develop", str(bad), "-o", str(tmp_path / "x.png")])
    stderr = capsys.readouterr().err
    assert status == 2
    assert "spectral-cam: error:" in stderr and "not a readable raw file" in stderr
    assert "Traceback" not in stderr
    assert not (tmp_path / "x.png").exists()


def test_develop_cli_unwritable_output_is_a_clear_error(tmp_path, good_dng, capsys):
    good = tmp_path / "good.dng"
    good.write_bytes(good_dng)
    status = main(["develop", str(good), "-o", str(good / "x.png")])  # a file's child
    assert status == 2 and "Traceback" not in capsys.readouterr().err


def _mutations():
    flips = st.lists(st.tuples(st.integers(0, 599), st.integers(0, 255)), min_size=1, max_size=6)
    return st.one_of(st.tuples(st.just("flip"), flips), st.tuples(st.just("cut"), st.floats(0.0, 0.999)))


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(_mutations())
def test_mutated_dngs_read_or_raise_raw_format_error_and_never_develop_to_nan(tmp_path, good_dng, mutation):
    kind, detail = mutation
    data = bytearray(good_dng)
    if kind == "cut":
        data = data[: int(detail * len(data))]
    else:
        for position, value in detail:
            data[position % len(data)] = value
    path = tmp_path / "fuzz.dng"
    path.write_bytes(bytes(data))
    logging.disable(logging.CRITICAL)
    try:
        try:
            raw = read_raw(path)
        except RawFormatError as exc:
            assert str(exc)
            return
        assert raw.mosaic.ndim == 2 and raw.mosaic.size > 0 and raw.mosaic.dtype == np.uint16
        assert raw.cfa in ("RGGB", "BGGR", "GRBG", "GBRG", "none")
        balance = "as_shot" if raw.as_shot_neutral is not None else "grey_world"
        try:
            out = develop(raw, ISPConfig(white_balance=balance))
        except SpectralCamError as exc:
            assert str(exc)
            return
        assert np.all(np.isfinite(out.image))
    finally:
        logging.disable(logging.NOTSET)
