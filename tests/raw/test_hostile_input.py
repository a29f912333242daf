"""Hostile DNGs: truncated, mutated or tag-less files read or raise RawFormatError, develop
without NaN, and the CLI exits 2 without output or traceback."""

from __future__ import annotations

import logging
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from spectral_cam.cli import main
from spectral_cam.errors import (
    RawFormatError,
    SpectralCamError,
)
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.raw import RawImage, read_raw, write_dng


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
    path = write_dng(RawImage(mosaic, "RGGB", 256, 4095, as_shot_neutral=np.array([0.5, 1.0, 0.7])), tmp_path / "small.dng")
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
@example(mutation=("flip", [(362, 0)]))  # once an IndexError: a CalibrationIlluminant of count 0
@example(mutation=("flip", [(398, 1)]))  # once a TypeError: a NoiseProfile of count 1
@example(mutation=("flip", [(384, 1)]))  # once a ValueError: a BaselineExposure turned ASCII
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


def test_a_white_level_at_or_below_black_is_refused(tmp_path, good_dng):
    """Issue 12 #13: WhiteLevel 0 read as 65535 by LibRaw developed 16× too dark."""
    data = bytearray(good_dng)
    struct.pack_into("<I", data, _tag_entry_offset(good_dng, 50717) + 8, 0)  # WhiteLevel 0
    path = tmp_path / "white0.dng"
    path.write_bytes(bytes(data))
    with pytest.raises(RawFormatError, match=r"WhiteLevel \[0\] is not above the black level 256"):
        read_raw(path)


def test_a_raw_whose_image_data_is_gone_is_refused_not_developed_to_black(tmp_path, good_dng, capsys):
    """Issue 13 #5: truncated camera raws developed to black with exit 0."""
    from spectral_cam.cli import main

    data = bytearray(good_dng)
    strip = struct.unpack_from("<I", data, _tag_entry_offset(good_dng, 273) + 8)[0]  # StripOffsets
    data[strip:strip + 32 * 40 * 2] = bytes(32 * 40 * 2)  # the mosaic's bytes zeroed, tags intact
    path = tmp_path / "empty.dng"
    path.write_bytes(bytes(data))
    with pytest.raises(RawFormatError, match="holds no data"):
        read_raw(path)
    assert main(["develop", str(path), "-o", str(tmp_path / "out.png"), "-q"]) == 2
    assert "holds no data" in capsys.readouterr().err and not (tmp_path / "out.png").exists()


def test_a_jpeg_xl_dng_is_called_unsupported_not_corrupt(tmp_path, good_dng):
    """Issue 13 #4: a valid JPEG-XL-compressed DNG 1.7 was called "truncated or corrupt"."""
    data = bytearray(good_dng)
    struct.pack_into("<H", data, _tag_entry_offset(good_dng, 259) + 8, 52546)  # Compression = JPEG XL
    path = tmp_path / "jxl.dng"
    path.write_bytes(bytes(data))
    with pytest.raises(RawFormatError, match=r"JPEG XL \(DNG 1.7\) compressed .* LibRaw [0-9.]+ does not decode") as info:
        read_raw(path)
    assert "corrupt" not in str(info.value)


@pytest.mark.timeout(60)
def test_a_dng_cut_short_is_refused_as_truncated(tmp_path):
    """A 1.2 MP DNG with the last 40 % of its bytes gone: its strips end past the end of the
    file. LibRaw reads it without an error (the missing rows come back as zeros or stale memory)."""
    import numpy as np

    from spectral_cam.raw import RawImage, read_raw, write_dng

    mosaic = np.random.default_rng(0).integers(300, 4000, (1000, 1200)).astype(np.uint16)
    path = write_dng(RawImage(mosaic, "RGGB", 256.0, 4095, as_shot_neutral=np.ones(3)), tmp_path / "whole.dng")
    cut = tmp_path / "cut.dng"
    data = path.read_bytes()
    cut.write_bytes(data[: int(len(data) * 0.6)])
    with pytest.raises(RawFormatError, match="truncated: a 1.2 MP image's data ends at byte"):
        read_raw(cut)
