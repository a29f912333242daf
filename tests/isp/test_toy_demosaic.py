"""Issue 41 (checks): a demosaic method is one registry entry. A toy method registered from this
test module is accepted by ``isp.demosaic`` and runs in a whole develop; nothing else changes.

Reference: a spectrally flat grey card under D65 through the whole chain is neutral and uniform
after white balance, whatever the demosaic (a nearest-neighbour fill of a flat mosaic is exact).
"""

from __future__ import annotations

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.isp.demosaic import DEMOSAIC
from spectral_cam.radiance_targets import lambertian_radiance, uniform_image

pytestmark = pytest.mark.timeout(180)


def _nearest(mosaic: np.ndarray, cfa: str) -> np.ndarray:
    """Each 2 × 2 Bayer cell's own R, mean G and B copied to its four pixels."""
    index = {letter: [i for i, c in enumerate(cfa) if c == letter] for letter in "RGB"}
    cells = [mosaic[i // 2::2, i % 2::2] for i in range(4)]
    planes = [np.mean([cells[i] for i in index[letter]], axis=0) for letter in "RGB"]
    return np.repeat(np.repeat(np.stack(planes, axis=-1), 2, axis=0), 2, axis=1).astype(np.float32)


@pytest.fixture
def registry(monkeypatch):
    """DEMOSAIC as it is, restored after the test."""
    monkeypatch.setattr(DEMOSAIC, "_entries", dict(DEMOSAIC._entries))
    return DEMOSAIC


def test_a_demosaic_registered_from_outside_develops_a_grey_card_neutral(registry):
    registry.add("toy_nearest", _nearest, description="nearest neighbour per Bayer cell, a test's toy")
    scene = sc.scene_from_dict({"illuminant": {"spd": "D65"}, "isp": {"demosaic": "toy_nearest", "denoise": "off"},
                                "sensor": {"model": "nikon_d850", "width_px": 32, "height_px": 32, "shot_noise": False,
                                           "read_noise_e": 0.0, "dsnu_e": 0.0, "prnu": 0.0, "vignetting": False},
                                "exposure": {"time_s": "auto"}})
    image = uniform_image(lambertian_radiance("D65", [0.18], illuminance_lux=500.0)[0], (32, 32))
    calls = []
    registry._entries["toy_nearest"] = registry["toy_nearest"].__class__(
        "toy_nearest", lambda m, c: calls.append(c) or _nearest(m, c), (), "counted")
    developed = sc.develop(sc.expose(image, scene), scene.isp)
    assert calls == ["RGGB"]  # the develop ran the toy, once, on the D850's tile
    linear = np.asarray(developed.linear, float)[4:-4, 4:-4]
    assert np.ptp(linear, axis=(0, 1)).max() < 2e-3  # uniform
    np.testing.assert_allclose(linear.mean(axis=(0, 1)) / linear.mean(), 1.0, atol=0.01)  # neutral


def test_a_method_for_a_larger_tile_is_one_entry_that_declares_the_tile(registry):
    """The entry says which tiles it takes; CFA_METHODS, bayer_methods and method_for read it (no other
    list): asked of an X-Trans mosaic it is kept, asked of a Bayer one it is refused naming its tile,
    and a Bayer method asked of X-Trans still falls back to the tile's default."""
    from spectral_cam.errors import ConfigError
    from spectral_cam.isp.demosaic import CFA_METHODS, bayer_methods, method_for

    registry.add("toy_xtrans", _nearest, tiles=("XTRANS",), description="a test's toy for X-Trans only")
    assert method_for("XTRANS", "toy_xtrans") == "toy_xtrans"
    assert CFA_METHODS["XTRANS"] == ("colour_difference", "toy_xtrans")  # the tile's default first
    assert "toy_xtrans" not in bayer_methods()
    assert method_for("XTRANS", "rcd") == "colour_difference"
    with pytest.raises(ConfigError, match="toy_xtrans.*XTRANS"):
        method_for("GRBG", "toy_xtrans")
    with pytest.raises(ValueError, match="tiles"):
        registry.add("toy_unknown_tile", _nearest, tiles=("HEXAGONAL",))
    with pytest.raises(ValueError, match="already has a default"):
        registry.add("toy_second_default", _nearest, tiles=("XTRANS",), default_for=("XTRANS",))
