"""Frames rendered in tiles (issue 14 #2): film crop windows of whole rows, each pixel seeing
the rays it sees in one whole-frame call, every tile with its own random streams.

The tile size is a module constant (1 MP); these tests shrink it so a small frame splits
into several tiles and the physics can be checked per pixel at affordable sample counts.
"""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam import render
from spectral_cam.errors import ConfigError
from spectral_cam.render import scene_dict
from spectral_cam.render.scene_dict import frame_tiles

from .test_radiometry import LUX, XML_SCENE, patch_band_errors

pytestmark = pytest.mark.timeout(300)


@pytest.fixture
def small_tiles(monkeypatch):
    """Tiles of ``rows`` whole rows on frames of more than ``pixels`` pixels."""

    def shrink(pixels: int, rows: int = 1) -> None:
        monkeypatch.setattr(scene_dict, "TILE_PIXELS", pixels)
        monkeypatch.setattr(scene_dict, "TILE_ROW_MULTIPLE", rows)

    return shrink


def test_tile_grid_covers_the_frame_once_and_depends_on_its_size_only():
    for width, height in [(1, 1), (1024, 1024), (1025, 1024), (8272, 5520), (70000, 40)]:
        tiles = frame_tiles(width, height)
        rows = np.concatenate([np.arange(first, end) for first, end in tiles])
        assert np.array_equal(rows, np.arange(height))
        assert all((end - first) % scene_dict.TILE_ROW_MULTIPLE == 0 for first, end in tiles[:-1])
        if len(tiles) > 1:  # bounded memory: no tile above the limit where the width allows
            assert max((end - first) * width for first, end in tiles) <= max(
                scene_dict.TILE_PIXELS, width * scene_dict.TILE_ROW_MULTIPLE)
    assert frame_tiles(1024, 1024) == [(0, 1024)]  # up to 1 MP: one call, as before tiling


def test_every_tile_sees_its_own_rows_of_the_chart_lamberts_law(make_scene, small_tiles):
    """The pinhole ColorChecker filling a 6 × 4 frame (one pixel per patch, as in
    test_radiometry), rendered one row per tile: every patch keeps its radiance ρ·E/π, so
    each tile's crop window maps to its own rows. 2^18 spp: σ ≈ 0.5 % per band, 3 % is ~6σ."""
    small_tiles(6)
    config = make_scene(
        scene={"preset": "colorchecker", "fill": 1.0, "gap": 0.0, "distance_m": 2.0},
        illuminant={"spd": "D65", "illuminance_lux": LUX},
        lens={"model": "pinhole"},
        sensor={"width_px": 6, "height_px": 4, "pixel_pitch_um": 500.0},
        render={"spp": 1 << 18, "max_depth": 2},
    )
    image = render(config, with_depth=False)
    assert image.meta["tiles"] == [[0, 1], [1, 2], [2, 3], [3, 4]]
    for name, relative in patch_band_errors(image, config):
        assert np.all(np.abs(relative) < 0.03), f"{name}: band errors {np.round(relative * 100, 2)} %"


def test_tiles_of_a_users_xml_scene_keep_its_camera_pose(tmp_path, make_scene, small_tiles):
    """The XML camera stands at z = −3 looking at a plane at z = 2: every tile's depth is 5 m
    (a tile sensor that lost the scene's pose would see the plane from the origin, 2 m)."""
    small_tiles(16 * 2, rows=2)
    path = tmp_path / "scene.xml"
    path.write_text(XML_SCENE)
    config = make_scene(scene={"mitsuba_xml": str(path)}, sensor={"width_px": 16, "height_px": 12},
                        render={"spp": 4})
    image = render(config)
    assert len(image.meta["tiles"]) == 6
    assert np.allclose(image.depth_m, 5.0, rtol=1e-5)


def test_each_tile_draws_its_own_samples(make_scene, small_tiles):
    """On a flat field every row sees the same radiance, so tiles sharing one seed would repeat
    the same Monte-Carlo noise row for row. Tiles' residuals must be uncorrelated: |r| under
    5σ of the correlation of independent noise (σ = 1/√n)."""
    small_tiles(32 * 4, rows=4)
    config = make_scene(scene={"preset": "flat_field"}, sensor={"width_px": 32, "height_px": 8},
                        render={"spp": 1, "max_depth": 2})
    image = render(config, with_depth=False)
    assert image.meta["tiles"] == [[0, 4], [4, 8]]
    first, second = (image.data[rows] - image.data.mean(axis=(0, 1)) for rows in (slice(0, 4), slice(4, 8)))
    assert first.std() > 0
    r = np.corrcoef(first.ravel(), second.ravel())[0, 1]
    assert abs(r) < 5 / np.sqrt(first.size), r
    again = render(config, with_depth=False)  # and a seed still gives the same bits
    assert np.array_equal(image.data, again.data)


def test_a_tiled_frame_reports_progress_per_tile(make_scene, small_tiles):
    small_tiles(16 * 4, rows=4)
    config = make_scene(sensor={"width_px": 16, "height_px": 12}, render={"spp": 4})
    calls = []
    render(config, with_depth=False, progress=lambda done, total, seconds, tile=None: calls.append((done, total, tile)))
    assert [tile for _, _, tile in calls] == [(1, 3), (2, 3), (3, 3)]


def test_auto_spp_on_a_tiled_frame_is_refused_with_the_remedy(make_scene, small_tiles):
    small_tiles(16 * 4, rows=4)
    config = make_scene(sensor={"width_px": 16, "height_px": 12}, render={"spp": "auto"})
    with pytest.raises(ConfigError, match=r"set render.spp to a number"):
        render(config)


def test_rounding_below_zero_is_judged_against_the_whole_frame_not_one_tile():
    """A tile of black sky carries Mitsuba's −1e-19 cancellation residue: cleared, as on an
    untiled frame, while clearly negative radiance is still an error."""
    from spectral_cam.errors import RenderError
    from spectral_cam.render.trace import _RadianceRange

    frame = _RadianceRange()
    black = np.full((2, 3, 4), -1e-19, np.float32)
    bright = np.full((2, 3, 4), 5.0, np.float32)
    assert frame.clear_rounding(black).min() == 0.0 and frame.clear_rounding(bright).max() == 5.0
    frame.check()
    wrong = _RadianceRange()
    wrong.clear_rounding(np.full((2, 3, 4), -0.1, np.float32))
    wrong.clear_rounding(bright)
    with pytest.raises(RenderError, match="negative radiance"):
        wrong.check()
