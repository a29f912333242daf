"""One CFA table: every stage that takes a CFA name refuses a bad one with the same error.

Reference: the DNG CFAPattern convention (Adobe DNG Specification 1.7.1.0, tag 33422): a 2×2
tile read row by row from the top-left pixel, 0 = R, 1 = G, 2 = B.
"""

import numpy as np
import pytest

from spectral_cam import scene_from_dict
from spectral_cam.cfa import CFA_PATTERNS, channel_index, tile_layout
from spectral_cam.errors import ConfigError
from spectral_cam.isp.demosaic import demosaic
from spectral_cam.metrics.emva1288 import channel_pixels
from spectral_cam.raw import RawImage, write_dng
from spectral_cam.sensor import electron_rates

pytestmark = pytest.mark.timeout(60)


@pytest.mark.parametrize("cfa, tile", [("RGGB", ((0, 1), (1, 2))), ("BGGR", ((2, 1), (1, 0))),
                                       ("GRBG", ((1, 0), (2, 1))), ("GBRG", ((1, 2), (0, 1)))])
def test_tile_layout_matches_the_dng_codes(cfa, tile):
    assert tile_layout(cfa) == tile
    assert channel_index((2, 2), cfa).tolist() == [list(row) for row in tile]


def test_monochrome_has_no_tile():
    assert tile_layout("none") is None
    assert "none" in CFA_PATTERNS


def _bad_cfa_calls(tmp_path):
    mosaic = np.zeros((4, 4), np.uint16)
    yield lambda: scene_from_dict({"sensor": {"cfa": "XGGB"}})
    yield lambda: electron_rates(np.zeros((4, 4, 2), np.float32), np.ones((2, 3), np.float32), cfa="XGGB")
    yield lambda: write_dng(RawImage(mosaic, "XGGB", 0.0, 4095), tmp_path / "x.dng")
    yield lambda: channel_pixels(mosaic, "XGGB")
    yield lambda: demosaic(mosaic.astype(np.float32), "XGGB")


def test_every_stage_refuses_a_bad_cfa_alike(tmp_path):
    for call in _bad_cfa_calls(tmp_path):
        with pytest.raises(ConfigError, match="valid: RGGB, BGGR, GRBG, GBRG"):
            call()
    assert not (tmp_path / "x.dng").exists()
