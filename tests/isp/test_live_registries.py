"""Issue 41: ``isp/config.py`` reads the stage registries when it checks, not tuples copied at import.
A tone curve, white balance or output format registered by a user's module after ``spectral_cam`` is
imported is accepted by :class:`ISPConfig` (and listed by its ``*_METHODS`` names), and the develop
runs it.

References (independent of the code under test): a toy white balance returning fixed gains must
reach the develop's record as those gains; a toy tone curve x ↦ √x on linear values must show each
pixel as the square root of its linear value (the develop's ``.linear``), computed here with NumPy.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from spectral_cam.errors import ConfigError
from spectral_cam.isp import ISPConfig, config, develop
from spectral_cam.isp.encode import ENCODERS
from spectral_cam.isp.tone import TONE
from spectral_cam.isp.white_balance import WHITE_BALANCE
from spectral_cam.raw import RawImage

pytestmark = pytest.mark.timeout(120)


@pytest.fixture
def registries(monkeypatch):
    """TONE, WHITE_BALANCE and ENCODERS as they are, restored after the test."""
    for registry in (TONE, WHITE_BALANCE, ENCODERS):
        monkeypatch.setattr(registry, "_entries", dict(registry._entries))


def _square_root(linear, *, ev=0.0):
    return np.sqrt(np.clip(np.asarray(linear, np.float32) * np.float32(2.0 ** ev), 0, 1))


def _fixed_gains(mosaic, cfa, **_):
    return np.array([2.0, 1.0, 1.5])


def test_entries_registered_after_import_are_accepted_listed_and_run(registries):
    TONE.add("toy_sqrt", _square_root, dng_curve=np.sqrt, description="a test's toy: √x")
    WHITE_BALANCE.add("toy_fixed", _fixed_gains, description="a test's toy: gains 2, 1, 1.5")
    ENCODERS.add("toy_format", lambda developed, path, **_: path, description="a test's toy format")
    settings = {"tone": "toy_sqrt", "white_balance": "toy_fixed", "outputs": ["png", "toy_format"],
                "colour_matrix": "none", "demosaic": "bilinear"}
    isp = ISPConfig.from_dict(settings)
    assert ISPConfig(**{**settings, "outputs": ("toy_format",)}).outputs == ("toy_format",)
    assert "toy_sqrt" in config.TONE_METHODS and "toy_fixed" in config.WHITE_BALANCE_METHODS
    assert "toy_format" in config.OUTPUT_FORMATS

    rng = np.random.default_rng(3)
    raw = RawImage(rng.integers(300, 3000, (16, 16)).astype(np.uint16), "RGGB", 0.0, 4095)
    developed = develop(raw, isp)
    assert developed.meta["white_balance_gains"] == [2.0, 1.0, 1.5]
    expected = np.sqrt(np.clip(np.asarray(developed.linear, np.float64), 0, 1))
    np.testing.assert_allclose(developed.image, expected, atol=1e-6)


def test_a_name_nobody_registered_is_still_refused_with_the_live_list(registries):
    with pytest.raises(ConfigError, match="toy_late"):
        ISPConfig(tone="toy_late")
    TONE.add("toy_late", _square_root, dng_curve=None)
    assert ISPConfig(tone="toy_late").tone == "toy_late"


def test_an_output_format_registered_later_writes_with_its_own_suffix(registries, tmp_path):
    """A format's suffixes live in its entry: write_outputs names the file by it and write_image
    recognises a path by the suffixes it reads (a second list beside ENCODERS gave a KeyError)."""
    from spectral_cam.isp.encode import write_image, write_outputs

    def _bytes(developed, path, **_):
        Path(path).write_bytes(np.ascontiguousarray(developed.image, np.float32).tobytes())
        return Path(path)

    ENCODERS.add("toy_raw32", _bytes, description="a test's toy: float32 bytes", suffix=".f32",
                 reads_suffixes=(".f32",))
    rng = np.random.default_rng(4)
    developed = develop(RawImage(rng.integers(300, 3000, (8, 8)).astype(np.uint16), "RGGB", 0.0, 4095),
                        ISPConfig(demosaic="bilinear", colour_matrix="none", white_balance="grey_world"))
    (written,) = write_outputs(developed, tmp_path, ["toy_raw32"])
    assert written.name == "image.f32" and written.stat().st_size == 8 * 8 * 3 * 4  # H × W × 3 float32
    assert write_image(developed, tmp_path / "again.F32").stat().st_size == 8 * 8 * 3 * 4
    with pytest.raises(ConfigError, match=r"\.f32"):  # the message lists the live suffixes
        write_image(developed, tmp_path / "x.unknown")
