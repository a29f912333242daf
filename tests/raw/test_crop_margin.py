"""The sensor's crop margin (issue 13 #3): a ring of real pixels around the frame, written as
ActiveArea/DefaultCropOrigin/DefaultCropSize, read back by LibRaw, honoured by our ISP, and
what it is for: demosaicing the frame's edges from real data."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import rawpy
from colour_demosaicing import mosaicing_CFA_Bayer

from spectral_cam import scene_from_dict
from spectral_cam.errors import ConfigError, RawFormatError
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.raw import RawImage, read_raw, write_dng

pytestmark = pytest.mark.timeout(120)


def _smooth_scene(height: int, width: int) -> np.ndarray:
    """A colourful, smooth (band-limited) linear RGB image in (0.1, 0.9)."""
    y, x = np.mgrid[0:height, 0:width].astype(float)
    return np.stack([0.5 + 0.35 * np.sin(x / 6.2 + y / 14.0), 0.5 + 0.35 * np.cos(y / 5.4 - x / 18.0),
                     0.5 + 0.35 * np.sin((x + y) / 8.6)], axis=-1)


def _raw_of(rgb: np.ndarray, cfa: str, crop=None) -> RawImage:
    mosaic = np.rint(mosaicing_CFA_Bayer(rgb, cfa) * 4000 + 64).astype(np.uint16)
    return RawImage(mosaic, cfa, 64.0, 4095, as_shot_neutral=np.ones(3), crop=crop)


LINEAR = ISPConfig(colour_matrix="none", tone="linear", white_balance="as_shot")


@pytest.mark.parametrize("cfa", ["RGGB", "GBRG"])
def test_the_crop_is_written_read_by_libraw_and_read_back(tmp_path, cfa):
    raw = _raw_of(_smooth_scene(52, 68), cfa, crop=(8, 6, 36, 56))
    path = write_dng(raw, tmp_path / "crop.dng")
    with rawpy.imread(str(path)) as handle:  # LibRaw, an independent DNG reader
        sizes = handle.sizes
        assert (sizes.crop_top_margin, sizes.crop_left_margin, sizes.crop_height, sizes.crop_width) == (8, 6, 36, 56)
        assert np.array_equal(handle.raw_image_visible, raw.mosaic)  # the margin is real data, kept
    back = read_raw(path)
    assert back.crop == (8, 6, 36, 56) and np.array_equal(back.mosaic, raw.mosaic)
    developed = develop(back, LINEAR)
    assert developed.image.shape == (36, 56, 3) and developed.meta["crop"] == [8, 6, 36, 56]


@pytest.mark.parametrize("crop", [(0, 0, 53, 68), (-2, 0, 10, 10), (0, 0, 0, 10), (1, 2, 3)])
def test_a_crop_outside_the_mosaic_is_refused(tmp_path, crop):
    raw = _raw_of(_smooth_scene(52, 68), "RGGB", crop=crop)
    with pytest.raises(RawFormatError, match="crop"):
        write_dng(raw, tmp_path / "bad.dng")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("cfa", ["RGGB", "GRBG"])
@pytest.mark.parametrize("demosaic", ["menon2007", "malvar2004"])
def test_a_margin_of_real_pixels_makes_the_frame_edges_as_good_as_its_middle(cfa, demosaic):
    """Demosaicing needs neighbours: without a margin the frame's outer pixels are interpolated
    from mirrored data, with one from the scene itself. Error against the true RGB in the
    outer 2 pixels of the frame: with an 8-pixel margin it is close to the interior's and
    well below the no-margin error (measured, RGGB: menon2007 0.0073 vs 0.019, interior 0.0063;
    malvar2004 0.0027 vs 0.0100, interior 0.0024)."""
    margin, height, width = 8, 40, 56
    truth = _smooth_scene(height + 2 * margin, width + 2 * margin)
    frame = truth[margin:-margin, margin:-margin]
    config = dataclasses.replace(LINEAR, demosaic=demosaic)
    with_margin = develop(_raw_of(truth, cfa, crop=(margin, margin, height, width)), config).linear
    without = develop(_raw_of(frame, cfa), config).linear
    edge = np.ones((height, width), bool)
    edge[2:-2, 2:-2] = False
    scale = 4000 / (4095 - 64)  # the ISP normalises by (DN − black) / (white − black)
    err_with = np.abs(with_margin / scale - frame)
    err_without = np.abs(without / scale - frame)
    interior = err_with[~edge].mean()
    assert err_with[edge].mean() < 1.3 * interior
    assert err_with[edge].mean() < 0.5 * err_without[edge].mean()
    # away from the edges both see the same data: the same result
    np.testing.assert_allclose(with_margin[12:-12, 12:-12], without[12:-12, 12:-12], atol=1e-5)


def test_an_odd_crop_origin_keeps_the_white_balance_statistics_on_the_right_sites():
    """Grey-world gains from the crop of a mosaic whose crop starts on a green site (the tile
    read at the crop origin is GRBG): the same gains as from that crop alone."""
    rgb = _smooth_scene(40, 48) * np.array([0.9, 0.6, 0.3])
    raw = _raw_of(rgb, "RGGB", crop=(2, 1, 36, 44))
    alone = _raw_of(rgb[2:38, 1:45], "GRBG")
    grey = dataclasses.replace(LINEAR, white_balance="grey_world")
    np.testing.assert_allclose(develop(raw, grey).meta["white_balance_gains"],
                               develop(alone, grey).meta["white_balance_gains"], rtol=1e-6)


@pytest.mark.parametrize("margin", [-2, 3, 258, 2.5, True])
def test_sensor_crop_margin_must_be_a_small_even_number(margin):
    with pytest.raises(ConfigError, match="crop_margin_px"):
        scene_from_dict({"sensor": {"crop_margin_px": margin}})
