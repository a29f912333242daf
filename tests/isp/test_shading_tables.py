"""Issue 39 #24: lens-shading tables are checked, and a flat field's calibration is limited to what
it supports. A uniform flat gives gains of 1 within the surface's standard error (a degree-8 surface
through four red pixels of a 4 × 4 flat gave 0.94-1.64); a noise-free shading exp(p(x, y)) is fitted
back to its own coefficients; a degree the flat does not support, a table of the wrong channel count
or degree (−1; 2000 hung building a 30 GB design matrix), non-finite or absurd gains, and a missing
``isp.shading`` file are refused with what would be valid — the last at scene load, before any render."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from spectral_cam import load_scene, scene_from_dict
from spectral_cam.errors import ConfigError
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.isp.shading import ShadingTable, calibrate_flat_field, load_shading_table
from spectral_cam.raw import RawImage

pytestmark = pytest.mark.timeout(120)

LEVEL, NOISE_DN, BLACK, WHITE = 2000.0, 20.0, 64.0, 4095


def _flat(height: int, width: int, *, seed: int = 0, shading=None, noise_dn: float = NOISE_DN) -> RawImage:
    """An RGGB flat field at LEVEL DN above black with Gaussian noise of ``noise_dn`` (12-bit)."""
    rng = np.random.default_rng(seed)
    signal = np.full((height, width), LEVEL) if shading is None else LEVEL * shading
    mosaic = signal + BLACK + rng.normal(0.0, noise_dn, (height, width)) if noise_dn else signal + BLACK
    return RawImage(np.rint(mosaic).astype(np.uint16) if noise_dn else mosaic.astype(np.float32), "RGGB", BLACK, WHITE,
                    as_shot_neutral=np.ones(3))


@pytest.mark.parametrize("size", [4, 8, 16, 64, 256])
def test_a_uniform_flat_gives_gains_of_one_within_the_surfaces_standard_error(size):
    """Gains of a uniform flat are 1 to within three times the bound the degree is chosen under: the
    surface's standard error at most max(0.2 %, half a pixel's noise, 1.0 % here) — 1.5 %. A 4 × 4 flat
    supports only a constant (its red channel has 4 pixels): gains of exactly 1."""
    table = calibrate_flat_field(_flat(size, size, seed=size))
    gains = table.gains()
    pixel_noise = NOISE_DN / LEVEL
    assert np.abs(gains - 1).max() <= 3 * max(0.002, 0.5 * pixel_noise), (table.degree, gains.min(), gains.max())
    if size <= 8:
        assert table.degree == 0 and np.allclose(gains, 1.0)
    assert table.degree <= 8


def test_a_noise_free_shading_is_fitted_back_to_its_own_polynomial():
    """A flat of exp(p(x, y)) with p of degree 4 (a radial fall to ~0.45 at the corners and a tilt),
    noise-free, 64 × 96: the table's coefficients are p's (monomials x^i·y^(t−i)) to 1e-5, and its
    gains are exp(p(0, 0) − p) to 1e-5 (the Legendre fit's conversion loses nothing)."""
    height, width = 64, 96
    y = ((np.arange(height) + 0.5) / height * 2 - 1)[:, None]
    x = ((np.arange(width) + 0.5) / width * 2 - 1)[None, :]
    p = -0.3 * (x ** 2 + y ** 2) - 0.1 * (x ** 4 + y ** 4) + 0.05 * x - 0.02 * x * y
    table = calibrate_flat_field(_flat(height, width, shading=np.exp(p), noise_dn=0), degree=4)
    expected = np.zeros(15)  # order: 1, y, x, y², xy, x², y³, ..., by total degree, x's power rising
    terms = [(i, t - i) for t in range(5) for i in range(t + 1)]
    for (i, j), value in {(1, 0): 0.05, (2, 0): -0.3, (0, 2): -0.3, (1, 1): -0.02, (4, 0): -0.1, (0, 4): -0.1}.items():
        expected[terms.index((i, j))] = value
    expected[0] = np.log(LEVEL / (WHITE - BLACK))  # the normalised level at p = 0
    for row in table.coefficients:
        np.testing.assert_allclose(row, expected, atol=1e-5)
    np.testing.assert_allclose(table.gains()[..., 0], np.exp(-p), rtol=1e-5)


def test_a_degree_the_flat_cannot_support_is_refused_naming_the_one_it_does():
    with pytest.raises(ConfigError, match=r"degree-8 .* 4 × 4 flat .*4 pixels.*largest degree it supports is 0"):
        calibrate_flat_field(_flat(4, 4), degree=8)
    with pytest.raises(ConfigError, match="too small"):
        calibrate_flat_field(_flat(2, 2))  # one red pixel: not even a constant with a noise estimate
    for bad in (-1, 13, 2.5, True, "high"):
        with pytest.raises(ConfigError, match=r"0\.\.12, or 'auto'"):
            calibrate_flat_field(_flat(16, 16), degree=bad)


def _table_file(tmp_path, **fields) -> str:
    good = calibrate_flat_field(_flat(32, 32)).to_dict()
    path = tmp_path / "table.json"
    path.write_text(json.dumps({**good, **fields}), encoding="utf-8")
    return str(path)


@pytest.mark.parametrize(("fields", "message"), [
    ({"coefficients": [[0.0]]}, r"RGGB table of degree \d+ holds 3 channel\(s\)"),
    ({"degree": -1}, r"degree -1: a whole number in 0\.\.12"),
    ({"degree": 2000}, r"degree 2000: a whole number in 0\.\.12"),
    ({"cfa": "RGGBX"}, "valid: RGGB"),
    ({"shape": [32, 0]}, r"\(height, width\)"),
    ({"coefficients": [[float("nan")] * 3] * 3, "degree": 1}, "not all finite"),
    ({"coefficients": [[0.0, 0.0, 1e3]] * 3, "degree": 1}, r"gains lie in 0\.01\.\.100"),
])
def test_a_broken_table_is_refused_at_once_saying_what_is_valid(tmp_path, fields, message):
    """Each broken table is refused by name in well under a second (degree 2000 built a 30 GB matrix)."""
    path = _table_file(tmp_path, **fields)
    start = time.perf_counter()
    with pytest.raises(ConfigError, match=message) as raised:
        load_shading_table(path)
    assert time.perf_counter() - start < 1.0
    assert "table.json" in str(raised.value)


def test_a_table_built_in_code_is_checked_too():
    """``develop(shading_table=)`` with a one-channel table for an RGGB mosaic: refused, not IndexError."""
    with pytest.raises(ConfigError, match=r"3 channel\(s\)"):
        ShadingTable(np.zeros((1, 1)), 0, (16, 16), "RGGB")
    with pytest.raises(ConfigError, match="0..12"):
        ShadingTable(np.zeros((3, 0)), -1, (16, 16), "RGGB")


def test_a_missing_or_broken_shading_file_is_refused_at_scene_load(tmp_path):
    """Refused by scene_from_dict / load_scene (before any render), and by the develop stage's own
    section; a relative path is read against the scene file's folder, as CSV and XML paths are."""
    with pytest.raises(ConfigError, match="no such file"):
        scene_from_dict({"isp": {"shading": str(tmp_path / "missing.json")}})
    (tmp_path / "broken.json").write_text("{}")
    with pytest.raises(ConfigError, match="not a lens shading table"):
        scene_from_dict({"isp": {"shading": str(tmp_path / "broken.json")}})
    folder = tmp_path / "scene"
    folder.mkdir()
    calibrate_flat_field(_flat(32, 32)).save(folder / "flat.json")
    (folder / "scene.toml").write_text('[isp]\nshading = "flat.json"\n', encoding="utf-8")
    config = load_scene(folder / "scene.toml")
    assert config.isp.shading == str((folder / "flat.json").resolve())
    (folder / "other.toml").write_text('[isp]\nshading = "nope.json"\n', encoding="utf-8")
    with pytest.raises(ConfigError, match="nope.json.*no such file"):
        load_scene(folder / "other.toml")


def test_a_corrected_uniform_flat_stays_uniform_through_develop(tmp_path):
    """The whole path: a 4 × 4 table (degree 0) saved, named by isp.shading, developed: the mosaic is
    unchanged (gains of 1), where the degree-8 table moved pixels by up to 64 %."""
    raw = _flat(4, 4)
    path = calibrate_flat_field(raw).save(tmp_path / "flat.json")
    config = ISPConfig(demosaic="bilinear", tone="linear", colour_matrix="none", white_balance="as_shot")
    plain = develop(raw, config).linear
    corrected = develop(raw, config.replace(shading=str(path))).linear
    np.testing.assert_allclose(corrected, plain, rtol=1e-5)
