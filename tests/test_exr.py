"""Our streaming OpenEXR writer (spectral_cam/exr.py) against the OpenEXR library's reader:
every bit of every channel, the header's codec and attributes, on awkward sizes."""

from __future__ import annotations

import numpy as np
import OpenEXR
import pytest

from spectral_cam.errors import ConfigError
from spectral_cam.exr import ZIP_ROWS, write_exr

pytestmark = pytest.mark.timeout(60)


def _read(path):
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        header = dict(exr.header())  # a copy: the binding empties it when the file closes
        return header, {name: np.array(channel.pixels) for name, channel in exr.channels().items()}


def _channels(height, width, names, seed=0):
    rng = np.random.default_rng(seed)
    data = rng.uniform(-3, 1e4, (height, len(names), width)).astype(np.float32)
    data[:, 0] = np.linspace(0, 1, width, dtype=np.float32)  # a smooth channel ZIP can shrink
    data[0, -1, 0], data[-1, -1, -1] = np.inf, np.float32(1e-42)  # specials and denormals survive
    return data


@pytest.mark.parametrize("compression, codec", [("none", OpenEXR.NO_COMPRESSION), ("zip", OpenEXR.ZIP_COMPRESSION)])
@pytest.mark.parametrize("height, width", [(1, 1), (17, 3), (33, 64), (16, 1)])
def test_openexr_reads_every_bit_we_write(tmp_path, compression, codec, height, width):
    names = ["A", "B", "S0.400,000000nm", "S0.410,000000nm", "Z"]
    data = _channels(height, width, names)
    path = write_exr(tmp_path / "x.exr", names, width, height, lambda a, b: data[a:b],
                     attributes={"spectralLayoutVersion": "1.0", "note": "ünïcode"}, compression=compression)
    header, back = _read(path)
    assert header["compression"] == codec
    assert header["spectralLayoutVersion"] == "1.0" and header["note"] == "ünïcode"
    assert sorted(back) == names
    for index, name in enumerate(names):
        assert back[name].dtype == np.float32 and back[name].tobytes() == data[:, index].tobytes(), name


def test_long_channel_names_set_the_long_names_flag(tmp_path):
    names = ["a" * 40, "b" * 255]
    data = _channels(5, 4, names)
    path = write_exr(tmp_path / "long.exr", names, 4, 5, lambda a, b: data[a:b])
    assert int.from_bytes(path.read_bytes()[4:8], "little") & 0x400
    assert sorted(_read(path)[1]) == names


def test_rows_are_asked_for_a_band_at_a_time(tmp_path):
    """Bounded memory: the writer never asks for more than one 16-row band."""
    calls = []
    data = _channels(50, 8, ["R"])

    def rows(first, end):
        calls.append((first, end))
        return data[first:end]

    write_exr(tmp_path / "x.exr", ["R"], 8, 50, rows)
    assert calls == [(0, 16), (16, 32), (32, 48), (48, 50)] and ZIP_ROWS == 16


def test_bad_requests_are_refused_and_leave_no_file(tmp_path):
    data = _channels(4, 4, ["A", "B"])
    with pytest.raises(ConfigError, match="sorted"):
        write_exr(tmp_path / "x.exr", ["B", "A"], 4, 4, lambda a, b: data[a:b])
    with pytest.raises(ConfigError, match="compression"):
        write_exr(tmp_path / "x.exr", ["A", "B"], 4, 4, lambda a, b: data[a:b], compression="piz")
    with pytest.raises(ConfigError, match="string"):
        write_exr(tmp_path / "x.exr", ["A", "B"], 4, 4, lambda a, b: data[a:b], attributes={"n": 3})
    with pytest.raises(ValueError, match="expected"):  # a callback giving the wrong shape, mid-file
        write_exr(tmp_path / "x.exr", ["A", "B"], 4, 4, lambda a, b: data[a:b, :1])
    assert list(tmp_path.iterdir()) == []
